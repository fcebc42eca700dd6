#!/usr/bin/env bash
# Bytes that are not UTF-8 (a Latin-1 file name, a query line, a damaged
# BVH quoted in a message) never end a run: the JSON outputs carry them as
# U+FFFD, a bad query fails alone and the batch goes on, build --json and
# info print valid JSON.
#   bash tests/cli/invalid_utf8.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup invalid_utf8 "$@"
valid_json_lines() { python3 -c 'import json,sys
for line in open(sys.argv[1], encoding="utf-8"): json.loads(line)' "$1" || fail "not valid UTF-8 JSON lines: $1"; }
bn="$(cd "$data/bandai-namco-1/data" && pwd)"
mkdir "$tmp/in"
latin="$tmp/in/caf$(printf '\xe9')_walk.bvh"  # "café" in Latin-1
cp "$bn/dataset-1_walk_normal_001.bvh" "$latin"
cp "$bn/dataset-1_walk_normal_002.bvh" "$tmp/in/"
printf 'HIERARCHY\nROOT J\xf6int\n{\n' >"$tmp/in/broken$(printf '\xff').bvh"
"$indexer" build --json --out "$tmp/i.h5" "$tmp/in" >"$tmp/build.json" 2>/dev/null ||
  [ $? -eq 1 ] || fail "build --json ended with an error"
valid_json_lines "$tmp/build.json"
"$indexer" info --json "$tmp/i.h5" >"$tmp/info.json" || fail "info --json failed"
valid_json_lines "$tmp/info.json"
{
  printf '{"id": "latin", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
    "$latin" "$latin"
  printf '{"id": "missing", "frames": [{"bvh": "%s/nowhere-\xe9.bvh", "frame": 1}, {"root_position": [0, null, 0]}]}\n' "$tmp"
  printf '{"id": "bad-\xff-line", "frames": []}\n'
  printf '{"id": "ok", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
    "$bn/dataset-1_walk_normal_001.bvh" "$bn/dataset-1_walk_normal_001.bvh"
} >"$tmp/q.jsonl"
status=0
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" 2>/dev/null || status=$?
[ "$status" -eq 1 ] || fail "mocap-search exited $status (expected 1: some queries failed)"
valid_json_lines "$tmp/r.jsonl"
[ "$(wc -l <"$tmp/r.jsonl")" -eq 4 ] || fail "expected 4 answers, got $(wc -l <"$tmp/r.jsonl")"
grep -q '"id":"ok"' "$tmp/r.jsonl" || grep -q '"id": "ok"' "$tmp/r.jsonl" || fail "the good query was not answered"
echo "PASS"
