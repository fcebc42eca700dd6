#!/usr/bin/env bash
# Sharded collections (docs/index-format.md "Collections"): mocap-index build
# --shards N writes N indexes balanced by frames and a manifest last; the
# shards hold together exactly the clips of one index, in its order; a
# rebuild reuses them; verify and info read the manifest; a changed or
# missing shard, a bad shard count or an --out of another kind are clear
# errors and leave the manifest alone; mocap-search and mocap-synth over a
# manifest answer as the single index does, and refuse a missing or changed
# shard by name.
#   bash tests/cli/shards.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup shards "$@"
set1="$data/bandai-namco-1"

# Invalid counts and outputs first: nothing written.
status=0
"$indexer" build -q --shards 0 --out "$tmp/c0.json" "$set1" >/dev/null 2>&1 || status=$?
[ "$status" -ne 0 ] || fail "--shards 0 was accepted"
status=0
"$indexer" build -q --shards 500 --out "$tmp/c500.json" "$set1" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] || fail "--shards 500 over 174 files: exit $status (expected 2)"
grep -q "500 shards need at least as many files" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ ! -e "$tmp/c500.json" ] || fail "a manifest was written"
echo "keep me" >"$tmp/notes.json.txt"
cp "$tmp/notes.json.txt" "$tmp/other.json"
status=0
"$indexer" build -q --shards 2 --out "$tmp/other.json" "$set1" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] || fail "an --out that is not a manifest: exit $status (expected 2)"
cmp -s "$tmp/other.json" "$tmp/notes.json.txt" || fail "the file at --out was changed"

"$indexer" build -q --out "$tmp/one.h5" "$set1" >/dev/null
for n in 2 3; do
  "$indexer" build -q --json --shards "$n" --out "$tmp/c$n.json" "$set1" >"$tmp/b$n.json"
  "$indexer" verify "$tmp/c$n.json" >/dev/null || fail "verify of the $n-shard collection failed"
  "$indexer" info --json "$tmp/c$n.json" >"$tmp/i$n.json"
done
"$indexer" info --json "$tmp/one.h5" >"$tmp/i1.json"
python3 - "$tmp" <<'PY'
import json, subprocess, sys
t = sys.argv[1]
one = json.load(open(t + "/i1.json"))
for n in (2, 3):
    m = json.load(open(f"{t}/c{n}.json"))
    assert m["format"] == "mocap-collection" and m["version"] == 1, m
    assert len(m["shards"]) == n
    info = json.load(open(f"{t}/i{n}.json"))
    assert info["clips"] == one["clips"] and info["frames"] == one["frames"], (info, one)
    frames = [s["frames"] for s in m["shards"]]
    # Balanced: no shard further from the mean than the longest clip allows.
    assert max(frames) - min(frames) < 0.1 * sum(frames), frames
    assert sum(s["clips"] for s in m["shards"]) == one["clips"]
print("ok")
PY
# The shards hold the single index's clips, in its order (their /clips/path).
if /usr/bin/python3 -c "import h5py" 2>/dev/null; then
  /usr/bin/python3 - "$tmp" <<'PY'
import h5py, json, sys
t = sys.argv[1]
def paths(f):
    with h5py.File(f, "r") as h:
        return [p.decode() if isinstance(p, bytes) else p for p in h["clips/path"][()]]
one = paths(t + "/one.h5")
for n in (2, 3):
    m = json.load(open(f"{t}/c{n}.json"))
    joined = sum((paths(t + "/" + s["path"]) for s in m["shards"]), [])
    assert joined == one, f"{n} shards: the clips differ from the single index's"
print("ok")
PY
fi
# One process over a manifest answers exactly as the single index: 40
# held-out queries of every kind (bench/search_queries.py), results equal
# but for the stats.
python3 "$(dirname "${BASH_SOURCE[0]}")/../../bench/search_queries.py" "$(cd "$set1/data" && pwd)" 40 7 >"$tmp/q.jsonl"
"$search" -q --index "$tmp/one.h5" --queries "$tmp/q.jsonl" --out "$tmp/r1.jsonl" || true
for n in 2 3; do
  "$search" -q --index "$tmp/c$n.json" --queries "$tmp/q.jsonl" --out "$tmp/r$n.jsonl" || true
  python3 - "$tmp/r1.jsonl" "$tmp/r$n.jsonl" <<'PY' || fail "$n shards: results differ from the single index"
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert len(a) == len(b) == 40
results = 0
for x, y in zip(a, b):
    x.pop("stats", None)
    y.pop("stats", None)
    assert x == y, (x.get("id"), json.dumps(x)[:200], json.dumps(y)[:200])
    results += sum(len(p["results"]) for p in x.get("pairs", []))
assert results > 300, results
PY
done

# mocap-synth over a manifest makes the single index's motion: the same BVH
# and HTML bytes, the same REPORT.json but for the paths (index, bvh) and the
# timings. Three held-out key poses; the two chosen partial motions lie in
# different shards of both collections (checked by their clip_index against
# the manifest's clip counts).
d="$(cd "$set1/data" && pwd)"
cat >"$tmp/sq.json" <<EOF
{"id": "walk-bye-run", "relative": false,
 "frames": [{"bvh": "$d/dataset-1_walk_normal_001.bvh", "frame": 20},
            {"bvh": "$d/dataset-1_bye_normal_001.bvh", "frame": 60},
            {"bvh": "$d/dataset-1_run_normal_001.bvh", "frame": 12}],
 "filter": {"exclude": ["dataset-1_walk_normal_001*", "dataset-1_bye_normal_001*",
                        "dataset-1_run_normal_001*"]},
 "top": 5}
EOF
# synth_run NAME INDEX [ARGS...]: mocap-synth into $tmp/NAME.{bvh,json,html}.
synth_run() {
  local name="$1" index="$2"
  shift 2
  "$synth" --index "$index" --query "$tmp/sq.json" --out "$tmp/$name.bvh" \
    --report "$tmp/$name.json" --html "$tmp/$name.html" "$@" >/dev/null 2>"$tmp/err.txt" ||
    fail "mocap-synth $name: $(cat "$tmp/err.txt")"
}
# same_motion A B MANIFEST: A and B are the same motion and reports, and B's
# chosen partial motions come from two different shards of MANIFEST.
same_motion() {
  cmp -s "$tmp/$1.bvh" "$tmp/$2.bvh" || fail "$2: the BVH differs from $1's"
  cmp -s "$tmp/$1.html" "$tmp/$2.html" || fail "$2: the HTML report differs from $1's"
  python3 - "$tmp/$1.json" "$tmp/$2.json" "$3" <<'PY' || fail "$2: the report differs from $1's"
import bisect, json, sys
def load(path):
    r = json.load(open(path))
    del r["timings_ms"], r["index"], r["motion"]["bvh"]
    for t in r["transitions"]:
        del t["time_ms"]
    return r
a, b = load(sys.argv[1]), load(sys.argv[2])
assert a == b, (json.dumps(a["chosen"])[:300], json.dumps(b["chosen"])[:300])
starts = [0]
for s in json.load(open(sys.argv[3]))["shards"]:
    starts.append(starts[-1] + s["clips"])
clips = [c["clip_index"] for c in b["chosen"]]
assert len(clips) == 2 and len({bisect.bisect_right(starts, c) for c in clips}) == 2, (clips, starts)
PY
}
synth_run m1 "$tmp/one.h5"
for n in 2 3; do
  synth_run "m$n" "$tmp/c$n.json"
  same_motion m1 "m$n" "$tmp/c$n.json"
done
# A results file of the collection search (collection clip numbers) with
# picks gives the single index's motion for its own results file.
"$search" -q --index "$tmp/c3.json" --query "$tmp/sq.json" --out "$tmp/sr3.jsonl"
"$search" -q --index "$tmp/one.h5" --query "$tmp/sq.json" --out "$tmp/sr1.jsonl"
synth_run p1 "$tmp/one.h5" --results "$tmp/sr1.jsonl" --pick 1:2 --pick 2:3
synth_run p3 "$tmp/c3.json" --results "$tmp/sr3.jsonl" --pick 1:2 --pick 2:3
cmp -s "$tmp/p1.bvh" "$tmp/p3.bvh" || fail "--results of the collection: the BVH differs"
cmp -s "$tmp/m1.bvh" "$tmp/p1.bvh" && fail "the picks changed nothing"

# A rebuild with nothing changed reuses every shard.
"$indexer" build -q --json --shards 3 --out "$tmp/c3.json" "$set1" >"$tmp/again.json"
python3 -c "
import json, sys
r = json.load(open('$tmp/again.json'))
assert all(s['up_to_date'] for s in r['shards']), r" || fail "a rebuild parsed again"

# A changed shard: verify fails naming it, info refuses, the manifest stays.
before="$(md5sum <"$tmp/c3.json")"
printf 'x' >>"$tmp/c3.shard-2-of-3.h5"
status=0
"$indexer" verify "$tmp/c3.json" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 1 ] || fail "verify of a changed shard: exit $status (expected 1)"
grep -q "c3.shard-2-of-3.h5: changed since the manifest was written" "$tmp/err.txt" ||
  fail "unclear: $(cat "$tmp/err.txt")"
status=0
"$indexer" info "$tmp/c3.json" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] || fail "info of a changed shard: exit $status (expected 2)"
# A missing shard.
rm "$tmp/c2.shard-1-of-2.h5"
status=0
"$indexer" verify "$tmp/c2.json" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 1 ] || fail "verify of a missing shard: exit $status (expected 1)"
grep -q "c2.shard-1-of-2.h5" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ "$(md5sum <"$tmp/c3.json")" = "$before" ] || fail "the manifest changed"
# The search refuses a collection with a changed shard before any query.
status=0
"$search" -q --index "$tmp/c3.json" --queries "$tmp/q.jsonl" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] || fail "search over a changed shard: exit $status (expected 2)"
grep -q "c3.shard-2-of-3.h5" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
# So does the synthesis (exit 1, docs/cli.md), with and without a results
# file, naming the shard, and it writes no motion.
for index in c3 c2; do
  for results in "" "$tmp/sr3.jsonl"; do
    status=0
    "$synth" --index "$tmp/$index.json" --query "$tmp/sq.json" --out "$tmp/bad.bvh" \
      ${results:+--results "$results"} >/dev/null 2>"$tmp/err.txt" || status=$?
    [ "$status" -eq 1 ] || fail "mocap-synth over a damaged $index: exit $status (expected 1)"
    shard="c3.shard-2-of-3.h5: changed since the manifest was written"
    [ "$index" = c2 ] && shard="c2.shard-1-of-2.h5"
    grep -q "^mocap-synth: .*$shard" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
    [ ! -e "$tmp/bad.bvh" ] || fail "a motion was written over a damaged $index"
  done
done
echo "PASS"
