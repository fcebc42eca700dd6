#!/usr/bin/env bash
# mocap-synth --queries (a batch into --out-dir) on a few set-1 clips: usage
# errors first (exit 2: --queries with --query, --out or --pick, no
# --out-dir, --out-dir a file, an unreadable batch or results file), then a
# batch of four good and two bad queries (an unknown joint, a missing BVH
# file) exits 1 with the bad ones in summary.jsonl and on stderr; each good
# query's BVH equals, byte for byte, mocap-synth --query BATCH --id ID's;
# --threads 1 and 2 write the same bytes; --reports and --html-reports write
# NAME.json and NAME.html; a foreign file in the folder is kept (that query
# fails) unless --force; summary lines in input order with their fields;
# --results and a collection of the same files.
#   bash tests/cli/synth_batch.sh BUILD_DIR DATA_DIR
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
. "$here/lib/common.sh"
cli_setup synth_batch "$@"
set1="$(cd "$data/bandai-namco-1/data" && pwd)"
files=()
for stem in walk_normal_001 walk_active_001 run_normal_001 bow_normal_001 bye_normal_001 bye_active_001; do
  files+=("$set1/dataset-1_$stem.bvh")
done
"$indexer" build -q --out "$tmp/index.h5" "${files[@]}" >/dev/null

# q ID STEM FRAMES [TIMES]: a query of frames of one set-1 file, its clip excluded.
q() {
  python3 - "$set1" "$@" <<'EOF'
import json, sys
set1, qid, stem, frames = sys.argv[1:5]
times = sys.argv[5].split(",") if len(sys.argv) > 5 else None
fs = []
for i, f in enumerate(frames.split(",")):
    fr = {"bvh": f"{set1}/dataset-1_{stem}.bvh", "frame": int(f)}
    if times:
        fr["time_s"] = float(times[i])
    fs.append(fr)
print(json.dumps({"id": qid, "top": 5, "frames": fs,
                  "filter": {"exclude": [f"dataset-1_{stem}*"]}}))
EOF
}
batch="$tmp/batch.jsonl"
{
  q walk-2 walk_normal_001 20,70
  q "bye/3" bye_normal_001 10,50,90
  q timed walk_active_001 10,40 0,1.0
  echo '{"id": "bad-joint", "frames": [{"joints": {"NoSuchJoint": {"quat": [1, 0, 0, 0]}}}, {"root_position": [1, 0.9, 0]}]}'
  echo
  echo "{\"id\": \"missing-bvh\", \"frames\": [{\"bvh\": \"$tmp/none.bvh\", \"frame\": 0}, {\"bvh\": \"$tmp/none.bvh\", \"frame\": 5}]}"
  q run-2 run_normal_001 5,20
} >"$batch"
good=(walk-2 "bye/3" timed run-2)
name() { tr -c 'A-Za-z0-9._\n-' '_' <<<"$1"; }

expect_usage() {  # expect_usage PATTERN ARGS...: exit 2 with PATTERN on stderr
  local pattern="$1" rc=0
  shift
  "$synth" --index "$tmp/index.h5" "$@" >"$tmp/out.txt" 2>"$tmp/err.txt" || rc=$?
  [ "$rc" = 2 ] || { cat "$tmp/err.txt" >&2; fail "exit $rc, expected 2, for: $*"; }
  grep -q -- "$pattern" "$tmp/err.txt" || { cat "$tmp/err.txt" >&2; fail "message '$pattern' missing for: $*"; }
}
expect_usage "excludes --query" --queries "$batch" --out-dir "$tmp/u" --query "$batch"
expect_usage "excludes --out" --queries "$batch" --out-dir "$tmp/u" --out "$tmp/u.bvh"
expect_usage "excludes --id" --queries "$batch" --out-dir "$tmp/u" --id walk-2
expect_usage "excludes --pick" --queries "$batch" --out-dir "$tmp/u" --pick 1:2
expect_usage "needs --out-dir" --queries "$batch"
echo hello >"$tmp/a-file"
expect_usage "not a folder" --queries "$batch" --out-dir "$tmp/a-file"
expect_usage "missing.jsonl" --queries "$tmp/missing.jsonl" --out-dir "$tmp/u"
expect_usage "cannot read the search results" --queries "$batch" --out-dir "$tmp/u" --results "$tmp/missing.jsonl"
[ "$(cat "$tmp/a-file")" = hello ] || fail "--out-dir's file was changed"
[ ! -e "$tmp/u/summary.jsonl" ] || fail "a refused batch wrote a summary"

# The batch: 2 threads with reports, 1 thread without.
rc=0
"$synth" --index "$tmp/index.h5" --queries "$batch" --out-dir "$tmp/b2" --threads 2 --reports \
  --html-reports >"$tmp/out2.txt" 2>"$tmp/err2.txt" || rc=$?
[ "$rc" = 1 ] || { cat "$tmp/err2.txt" >&2; fail "a batch with bad queries exited $rc, expected 1"; }
grep -q "mocap-synth: query bad-joint (line 4): .*unknown joint" "$tmp/err2.txt" ||
  { cat "$tmp/err2.txt" >&2; fail "the bad joint's error is not on stderr"; }
grep -q "mocap-synth: query missing-bvh (line 6): " "$tmp/err2.txt" ||
  { cat "$tmp/err2.txt" >&2; fail "the missing BVH's error is not on stderr"; }
grep -q "mocap-synth: 6/6 queries" "$tmp/err2.txt" || fail "no final progress line"
grep -q "^summary: .*b2/summary.jsonl (4 of 6 queries made)" "$tmp/out2.txt" ||
  { cat "$tmp/out2.txt" >&2; fail "the summary's path is not printed"; }
rc=0
"$synth" --index "$tmp/index.h5" --queries "$batch" --out-dir "$tmp/b1" --threads 1 -q \
  >/dev/null 2>"$tmp/err1.txt" || rc=$?
[ "$rc" = 1 ] || fail "--threads 1 exited $rc"
! grep -q "queries$" "$tmp/err1.txt" || fail "-q printed progress"
for id in "${good[@]}"; do
  n="$(name "$id")"
  [ -s "$tmp/b2/$n.bvh" ] || fail "no $n.bvh"
  [ -s "$tmp/b2/$n.json" ] || fail "no $n.json (--reports)"
  grep -q "<html\|<!DOCTYPE html" "$tmp/b2/$n.html" || fail "no $n.html (--html-reports)"
  cmp -s "$tmp/b1/$n.bvh" "$tmp/b2/$n.bvh" || fail "$id: --threads 1 and 2 wrote different motions"
  [ ! -e "$tmp/b1/$n.json" ] || fail "a report without --reports"
  "$synth" --index "$tmp/index.h5" --query "$batch" --id "$id" --out "$tmp/single-$n.bvh" >/dev/null
  cmp -s "$tmp/single-$n.bvh" "$tmp/b2/$n.bvh" || fail "$id: the batch's motion is not the single run's"
done
[ -e "$tmp/b2/bye_3.bvh" ] || fail "bye/3 is not written as bye_3.bvh"
ls "$tmp/b2" | grep -q "bad-joint\|missing-bvh" && fail "a failed query wrote a file"

# The summary: input order, its fields; the same but for the times whatever the threads.
python3 - "$tmp/b2/summary.jsonl" "$tmp/b1/summary.jsonl" <<'EOF'
import json, sys
two = [json.loads(l) for l in open(sys.argv[1])]
one = [json.loads(l) for l in open(sys.argv[2])]
ids = [l["id"] for l in two]
assert ids == ["walk-2", "bye/3", "timed", "bad-joint", "missing-bvh", "run-2"], ids
assert [l["line"] for l in two] == [1, 2, 3, 4, 6, 7], [l["line"] for l in two]
for l in two:
    if l["id"] in ("bad-joint", "missing-bvh"):
        assert set(l) == {"id", "line", "error"}, l
        continue
    assert list(l) == ["id", "line", "bvh", "motion", "report", "html", "frames", "duration_s",
                       "measures", "time_ms"], list(l)
    assert l["bvh"].endswith(".bvh") and l["report"].endswith(".json"), l
    assert list(l["measures"]) == ["w_J", "unsupported_J", "no_contact_ratio",
                                   "peak_angular_speed_radps", "foot_skating_ratio"], l
    assert l["frames"] >= 2 and l["duration_s"] > 0 and l["time_ms"] > 0, l
timed = two[2]
assert abs(timed["duration_s"] - 1.0) < 1e-3, timed
for a, b in zip(one, two):
    for x in (a, b):
        for k in ("time_ms", "bvh", "motion", "report", "html"):
            x.pop(k, None)
    assert a == b, (a, b)
EOF

# A foreign file at a query's path: kept, that query fails; --force replaces it.
head -1 "$batch" >"$tmp/one.jsonl"
mkdir -p "$tmp/f"
echo hello >"$tmp/f/walk-2.bvh"
rc=0
"$synth" --index "$tmp/index.h5" --queries "$tmp/one.jsonl" --out-dir "$tmp/f" -q \
  >/dev/null 2>"$tmp/errf.txt" || rc=$?
[ "$rc" = 1 ] || fail "a foreign file in the way: exit $rc, expected 1"
[ "$(cat "$tmp/f/walk-2.bvh")" = hello ] || fail "the foreign file was replaced without --force"
grep -q "error" "$tmp/f/summary.jsonl" || fail "the refused query is not in the summary"
"$synth" --index "$tmp/index.h5" --queries "$tmp/one.jsonl" --out-dir "$tmp/f" -q --force >/dev/null
cmp -s "$tmp/f/walk-2.bvh" "$tmp/b2/walk-2.bvh" || fail "--force did not replace the foreign file"
# A folder at a query's path is refused even with --force.
mkdir -p "$tmp/g/walk-2.bvh"
rc=0
"$synth" --index "$tmp/index.h5" --queries "$tmp/one.jsonl" --out-dir "$tmp/g" -q --force \
  >/dev/null 2>/dev/null || rc=$?
[ "$rc" = 1 ] || fail "a folder in the way: exit $rc, expected 1"

# --results: the results file read once gives the same motions.
"$search" --index "$tmp/index.h5" --queries "$batch" --out "$tmp/r.jsonl" -q 2>/dev/null || true
rc=0
"$synth" --index "$tmp/index.h5" --queries "$batch" --results "$tmp/r.jsonl" --out-dir "$tmp/br" \
  --summary "$tmp/br-summary.jsonl" -q >/dev/null 2>/dev/null || rc=$?
[ "$rc" = 1 ] || fail "--results: exit $rc, expected 1"
[ -s "$tmp/br-summary.jsonl" ] || fail "--summary PATH not written"
# A collection of the same files: the same motions as the index.
"$indexer" build -q --shards 2 --out "$tmp/col.json" "${files[@]}" >/dev/null
rc=0
"$synth" --index "$tmp/col.json" --queries "$batch" --out-dir "$tmp/bc" -q >/dev/null 2>/dev/null || rc=$?
[ "$rc" = 1 ] || fail "a collection: exit $rc, expected 1"
for id in "${good[@]}"; do
  n="$(name "$id")"
  cmp -s "$tmp/bc/$n.bvh" "$tmp/b2/$n.bvh" || fail "$id: the collection's motion is not the index's"
done
# An empty batch: exit 2 naming the file, no folder made; --allow-empty: an
# empty summary, exit 0.
printf '\n\n' >"$tmp/empty.jsonl"
rc=0
"$synth" --index "$tmp/index.h5" --queries "$tmp/empty.jsonl" --out-dir "$tmp/be" 2>"$tmp/err.txt" ||
  rc=$?
[ "$rc" = 2 ] || fail "an empty batch exited $rc (expected 2)"
grep -q "empty.jsonl: holds no query" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ ! -e "$tmp/be" ] || fail "an empty batch made its folder"
"$synth" --index "$tmp/index.h5" --queries "$tmp/empty.jsonl" --out-dir "$tmp/be" --allow-empty \
  -q >/dev/null || fail "--allow-empty refused an empty batch"
[ -f "$tmp/be/summary.jsonl" ] && [ ! -s "$tmp/be/summary.jsonl" ] || fail "no empty summary"
# --format glb / npz: NAME.glb / NAME.npz, byte for byte the single run's
# --out of that extension; the summary names them under "motion" (and has
# no "bvh"); a bad format is a usage error.
expect_usage "--format" --queries "$batch" --out-dir "$tmp/bx" --format fbx
for fmt in glb npz; do
  rc=0
  "$synth" --index "$tmp/index.h5" --queries "$batch" --out-dir "$tmp/b-$fmt" --format "$fmt" -q \
    >/dev/null 2>&1 || rc=$?
  [ "$rc" = 1 ] || fail "--format $fmt exited $rc"
  id="${good[0]}"
  n="$(name "$id")"
  "$synth" --index "$tmp/index.h5" --query "$batch" --id "$id" --out "$tmp/single-$n.$fmt" >/dev/null
  cmp -s "$tmp/single-$n.$fmt" "$tmp/b-$fmt/$n.$fmt" || fail "$id: the batch's .$fmt is not the single run's"
  [ ! -e "$tmp/b-$fmt/$n.bvh" ] || fail "--format $fmt wrote a BVH"
  /usr/bin/python3 - "$tmp/b-$fmt/summary.jsonl" "$fmt" <<'PY' || fail "--format $fmt: summary"
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
made = [l for l in lines if "error" not in l]
assert made and all(l["motion"].endswith("." + sys.argv[2]) and "bvh" not in l for l in made), made
PY
done
echo "OK"
