#!/usr/bin/env bash
# Exit statuses as docs/cli.md says: verify of a file that is not there is
# 2 (cannot be read), not 1 (damaged); a command whose output cannot be
# written (/dev/full) fails with 2 instead of exiting 0.
#   bash tests/cli/exit_codes.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup exit_codes "$@"
status() { local s=0; "$@" >/dev/null 2>&1 || s=$?; echo "$s"; }
[ "$(status "$indexer" verify "$tmp/missing.h5")" = 2 ] || fail "verify of a missing file is not 2"
mkdir "$tmp/in"
cp "$data/bandai-namco-1/data/dataset-1_walk_normal_001.bvh" "$tmp/in/"
"$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null 2>&1 || fail "build failed"
[ "$(status "$indexer" verify "$tmp/i.h5")" = 0 ] || fail "verify of a sound index is not 0"
if [ -w /dev/full ]; then
  s=0
  "$indexer" info --json "$tmp/i.h5" >/dev/full 2>/dev/null || s=$?
  [ "$s" = 2 ] || fail "info writing to /dev/full exited $s (expected 2)"
fi
# An empty batch (nothing, or blank lines) is an error naming the file, unless
# --allow-empty; nothing is written.
printf '\n  \n' >"$tmp/empty.jsonl"
s=0
"$search" --index "$tmp/i.h5" --queries "$tmp/empty.jsonl" --out "$tmp/e.jsonl" 2>"$tmp/err" || s=$?
[ "$s" = 2 ] || fail "an empty batch exited $s (expected 2)"
grep -q "empty.jsonl: holds no query" "$tmp/err" || fail "unclear empty-batch error: $(cat "$tmp/err")"
[ ! -e "$tmp/e.jsonl" ] || fail "an empty batch wrote its results file"
[ "$(status "$search" --index "$tmp/i.h5" --queries "$tmp/empty.jsonl" --allow-empty)" = 0 ] ||
  fail "--allow-empty refused an empty batch"
echo "PASS"
