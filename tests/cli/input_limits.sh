#!/usr/bin/env bash
# The input-limit flags (docs/cli.md "Input limits"): each limit can be
# lowered (and raised) per command, the refusal names the file and the flag,
# and values out of range are refused before any work. Every reader of an
# input enforces its limit (mocap-index build too), quoting the right one,
# and none reserves the limit up front.
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

# A query batch for mocap-synth --query over --max-batch-mib 1, its first
# line longer than the limit: refused quoting that limit (not the single
# query's).
{
  printf '{"id": "s",'
  cat "$tmp/pad.txt"
  printf '"frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' "$walk" "$walk"
  cat "$tmp/s.json"
} >"$tmp/batch-big.jsonl"
status=0
"$synth" --index "$tmp/i.h5" --query "$tmp/batch-big.jsonl" --id s --out "$tmp/m.bvh" \
  --max-batch-mib 1 >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -ne 0 ] || fail "--max-batch-mib 1: a 2 MiB batch was read"
grep -q "batch-big.jsonl.*limit of 1048576 bytes" "$tmp/err.txt" ||
  fail "the refusal does not quote --max-batch-mib's limit: $(cat "$tmp/err.txt")"
# The largest --max-batch-mib reserves nothing: a small query file is read.
"$synth" --index "$tmp/i.h5" --query "$tmp/s.json" --out "$tmp/m.bvh" --max-batch-mib 16777216 \
  >/dev/null 2>"$tmp/err.txt" || fail "--max-batch-mib 16777216: $(cat "$tmp/err.txt")"

# --max-bvh-mib on mocap-index build (one index and --shards): a file over
# the limit is skipped naming it and the limit, the others indexed (named to
# sort between the two others, so that each shard holds a file it can index).
cp "$tmp/big.bvh" "$tmp/in/dataset-1_walk_normal_001b.bvh"
for shards in "" "--shards 2"; do
  rm -f "$tmp/b.h5" "$tmp/b.json"
  out="$tmp/b.h5"
  [ -n "$shards" ] && out="$tmp/b.json"
  status=0
  # shellcheck disable=SC2086
  "$indexer" build -q $shards --json --out "$out" --max-bvh-mib 2 "$tmp/in" >"$tmp/bb.json" \
    2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 1 ] || fail "build $shards --max-bvh-mib 2: exit $status (expected 1: one file skipped)"
  grep -q "001b.bvh" "$tmp/bb.json" || fail "build $shards: the big file is not named: $(cat "$tmp/bb.json")"
  grep -q "limit of 2097152 bytes" "$tmp/bb.json" || fail "build $shards: the limit is not quoted"
  "$indexer" verify "$out" >/dev/null || fail "build $shards: the index does not verify"
done
rm "$tmp/in/dataset-1_walk_normal_001b.bvh"
echo "PASS"
