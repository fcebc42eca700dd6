#!/usr/bin/env bash
# A build onto a full disk fails cleanly: exit 2 with a message (no crash
# in HDF5's clean-up at exit), the previous index intact, no temporary file
# left. Needs a small tmpfs (mount; root): skipped where it cannot be made.
#   bash tests/cli/full_disk.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup full_disk "$@"
mkdir "$tmp/small" "$tmp/in"
if ! mount -t tmpfs -o size=1600k tmpfs "$tmp/small" 2>/dev/null; then
  echo "SKIP: cannot mount a small tmpfs here (needs root)"
  exit 77
fi
trap 'umount "$tmp/small" 2>/dev/null; rm -rf "$tmp"' EXIT
cp "$data/bandai-namco-1/data/dataset-1_walk_normal_001.bvh" "$tmp/in/"
"$indexer" build -q --out "$tmp/small/i.h5" "$tmp/in" >/dev/null 2>&1 || fail "a small index did not fit"
before="$(md5sum <"$tmp/small/i.h5")"
cp "$data/bandai-namco-1/data/"dataset-1_walk_*_00[12].bvh "$tmp/in/"
status=0
"$indexer" build -q --out "$tmp/small/i.h5" "$tmp/in" >/dev/null 2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] || fail "a build onto a full disk exited $status (expected 2; 139 = crash)"
[ -s "$tmp/err.txt" ] || fail "no message"
[ "$(md5sum <"$tmp/small/i.h5")" = "$before" ] || fail "the previous index changed"
if ls -A "$tmp/small" | grep -q tmp; then fail "a temporary file was left: $(ls -A "$tmp/small")"; fi
echo "PASS"
