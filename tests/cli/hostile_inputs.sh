#!/usr/bin/env bash
# Finite values beyond physical sense and folder link loops, through the
# commands: a BVH with a root position of 1e30 or a frame time of 1e-300 is
# skipped by build (exit 1) and the index it writes verifies; queries with a
# root position of 1e30 m or a transition time of 1e-300 s fail alone with
# "out of range"; build and summary of a folder holding links back up the
# tree end (within the timeout) and index each file once; NaN given to
# mocap-synth --fps or mocap-search --min-length/--max-length is refused
# naming the flag.
#   bash tests/cli/hostile_inputs.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup hostile_inputs "$@"
walk="$(cd "$data/bandai-namco-1/data" && pwd)/dataset-1_walk_normal_001.bvh"
mkdir -p "$tmp/in/sub"
cp "$walk" "$tmp/in/"
awk 'f && !done {$1 = "1e30"; done = 1} /^Frame Time/ {f = 1} {print}' "$walk" >"$tmp/in/far.bvh"
sed 's/^Frame Time:.*/Frame Time: 1e-300/' "$walk" >"$tmp/in/fast.bvh"
ln -s .. "$tmp/in/sub/up"
ln -s ../sub "$tmp/in/sub/again"
status=0
timeout 60 "$indexer" build -q --json --out "$tmp/i.h5" "$tmp/in" >"$tmp/build.json" 2>/dev/null ||
  status=$?
[ "$status" -eq 1 ] || fail "build exited $status (expected 1: two files skipped; 124 = hung)"
python3 - "$tmp/build.json" <<'PY' || fail "build summary: $(cat "$tmp/build.json")"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["clips"] == 1, d["clips"]
reasons = " ".join(s["reason"] for s in d["skipped"])
assert reasons.count("out of range") == 2, reasons
PY
"$indexer" verify "$tmp/i.h5" >/dev/null || fail "the index does not verify"
status=0
timeout 60 "$indexer" summary "$tmp/in" >/dev/null 2>&1 || status=$?
[ "$status" -ne 124 ] || fail "summary hung on the link loop"
{
  printf '{"id": "far", "frames": [{"root_position": [1e30, null, 0]}, {"root_position": [0, null, 1]}]}\n'
  printf '{"id": "fast", "transition_time": 1e-300, "frames": [{"bvh": "%s", "frame": 1}, {"bvh": "%s", "frame": 9}]}\n' "$walk" "$walk"
  printf '{"id": "ok", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' "$walk" "$walk"
} >"$tmp/q.jsonl"
status=0
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" 2>/dev/null || status=$?
[ "$status" -eq 1 ] || fail "search exited $status (expected 1)"
[ "$(grep -c "out of range\|must be 0.001 to 60" "$tmp/r.jsonl")" -eq 2 ] || fail "unclear errors: $(cat "$tmp/r.jsonl")"
grep '"id":"ok"' "$tmp/r.jsonl" | grep -q '"results":\[{' || fail "the good query was not answered"
# NaN flags are refused as any value out of range, naming the flag.
printf '{"id": "s", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
  "$walk" "$walk" >"$tmp/s.json"
for v in nan -nan NaN; do
  status=0
  "$synth" --index "$tmp/i.h5" --query "$tmp/s.json" --out "$tmp/nan.bvh" --fps "$v" \
    >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -ne 0 ] || fail "mocap-synth --fps $v was accepted"
  grep -q "fps" "$tmp/err.txt" || fail "--fps $v: unclear: $(cat "$tmp/err.txt")"
  [ ! -e "$tmp/nan.bvh" ] || fail "--fps $v: a motion was written"
  for flag in --min-length --max-length; do
    status=0
    "$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" "$flag" "$v" >/dev/null \
      2>"$tmp/err.txt" || status=$?
    [ "$status" -eq 2 ] || fail "$flag $v: exit $status (expected 2)"
    grep -q -- "$flag" "$tmp/err.txt" || fail "$flag $v: unclear: $(cat "$tmp/err.txt")"
    if grep -q "SearchOptions" "$tmp/err.txt"; then fail "$flag $v names a C++ field"; fi
  done
done
echo "PASS"
