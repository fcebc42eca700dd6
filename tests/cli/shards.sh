#!/usr/bin/env bash
# Sharded collections (docs/index-format.md "Collections"): mocap-index build
# --shards N writes N indexes balanced by frames and a manifest last; the
# shards hold together exactly the clips of one index, in its order; a
# rebuild reuses them; verify and info read the manifest; a changed or
# missing shard, a bad shard count or an --out of another kind are clear
# errors and leave the manifest alone; mocap-search over a manifest answers
# as the single index does.
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

# mocap-synth reads one index: a manifest is refused clearly.
printf '{"frames": [{"root_position": [0, null, 0]}, {"root_position": [0, null, 1]}]}\n' >"$tmp/s.json"
status=0
"$synth" --index "$tmp/c2.json" --query "$tmp/s.json" --out "$tmp/m.bvh" >/dev/null 2>"$tmp/err.txt" ||
  status=$?
[ "$status" -ne 0 ] && grep -q "a collection manifest" "$tmp/err.txt" || fail "mocap-synth: $(cat "$tmp/err.txt")"

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
echo "PASS"
