#!/usr/bin/env bash
# The input-limit flags (docs/cli.md "Input limits"): each limit can be
# lowered (and raised) per command, the refusal names the file and the flag,
# and values out of range are refused before any work.
#   bash tests/cli/input_limits.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup input_limits "$@"
bn="$(cd "$data/bandai-namco-1/data" && pwd)"
walk="$bn/dataset-1_walk_normal_001.bvh"
mkdir "$tmp/in"
cp "$walk" "$bn/dataset-1_walk_normal_002.bvh" "$tmp/in/"

# Out-of-range values: refused by the parser, nothing written.
for bad in "--max-query-frames 1" "--max-joints 0" "--max-bvh-mib 0" "--max-json-mib -3"; do
  # shellcheck disable=SC2086
  if "$indexer" build -q --out "$tmp/bad.h5" $bad "$tmp/in" >/dev/null 2>&1; then
    fail "mocap-index build $bad was accepted"
  fi
  [ ! -e "$tmp/bad.h5" ] || fail "mocap-index build $bad wrote an index"
done

# --max-joints: a file with more joints is skipped, naming the file and the flag.
status=0
"$indexer" build -q --json --out "$tmp/j.h5" --max-joints 20 "$tmp/in" >"$tmp/j.json" 2>"$tmp/err.txt" ||
  status=$?
[ "$status" -ne 0 ] || fail "--max-joints 20: two 50-joint files were indexed"
grep -q "max-joints" "$tmp/j.json" "$tmp/err.txt" || fail "the refusal does not name --max-joints"
grep -q "dataset-1_walk_normal_001.bvh" "$tmp/j.json" "$tmp/err.txt" || fail "the refusal does not name the file"
"$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null 2>&1 || fail "default build failed"

# --max-bvh-mib: a query frame's BVH over the limit fails that query alone.
head -c $((2 * 1024 * 1024)) /dev/zero | tr '\0' ' ' >"$tmp/pad.txt"
cat "$walk" "$tmp/pad.txt" >"$tmp/big.bvh"
{
  printf '{"id": "big", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
    "$tmp/big.bvh" "$tmp/big.bvh"
  printf '{"id": "ok", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
    "$walk" "$walk"
} >"$tmp/q.jsonl"
status=0
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" --max-bvh-mib 2 \
  2>/dev/null || status=$?
[ "$status" -eq 1 ] || fail "--max-bvh-mib 2: exit $status (expected 1: one query fails)"
grep '"id":"big"' "$tmp/r.jsonl" | grep -q "big.bvh" || fail "the big file's query does not name it"
grep '"id":"ok"' "$tmp/r.jsonl" | grep -q '"results":\[{' || fail "the good query was not answered"
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/r2.jsonl" --max-bvh-mib 3 \
  2>/dev/null || fail "--max-bvh-mib 3: the 2.2 MiB file was refused"

# --max-query-frames: a three-frame query over a limit of 2 is refused.
printf '{"id": "three", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 20}, {"bvh": "%s", "frame": 30}], "top": 1}\n' \
  "$walk" "$walk" "$walk" >"$tmp/three.jsonl"
status=0
"$search" -q --index "$tmp/i.h5" --queries "$tmp/three.jsonl" --max-query-frames 2 >"$tmp/r3.jsonl" \
  2>/dev/null || status=$?
[ "$status" -eq 1 ] || fail "--max-query-frames 2: exit $status (expected 1)"
grep -q "max-query-frames" "$tmp/r3.jsonl" || fail "the refusal does not name --max-query-frames"
"$search" -q --index "$tmp/i.h5" --queries "$tmp/three.jsonl" >/dev/null 2>&1 ||
  fail "the three-frame query failed under the default limit"

# --max-json-mib and --max-batch-mib, on mocap-synth.
printf '{"id": "s", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
  "$walk" "$walk" >"$tmp/s.json"
cat "$tmp/s.json" "$tmp/pad.txt" >"$tmp/s-big.json"
status=0
"$synth" --index "$tmp/i.h5" --query "$tmp/s-big.json" --out "$tmp/m.bvh" --max-json-mib 1 \
  >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -ne 0 ] || fail "--max-json-mib 1: a 2 MiB query file was read"
grep -q "s-big.json" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ ! -e "$tmp/m.bvh" ] || fail "a motion was written"
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/res.jsonl" >/dev/null 2>&1 || true
cat "$tmp/res.jsonl" "$tmp/pad.txt" >"$tmp/res-big.jsonl"
status=0
"$synth" --index "$tmp/i.h5" --query "$tmp/s.json" --results "$tmp/res-big.jsonl" --out "$tmp/m.bvh" \
  --max-batch-mib 1 >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -ne 0 ] || fail "--max-batch-mib 1: a 2 MiB results file was read"
grep -q "res-big.jsonl" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
echo "PASS"
