#!/usr/bin/env bash
# Two builds to one index: while one holds the index's lock (here flock(1)
# on the lock file, as a running build does), a second mocap-index build to
# the same --out fails at once with a message naming the lock, and the
# index is left as it was; once the lock is free the build runs.
#   bash tests/cli/build_lock.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup build_lock "$@"
command -v flock >/dev/null || { echo "SKIP: no flock(1)"; exit 77; }
mkdir "$tmp/in"
cp "$data/bandai-namco-1/data/dataset-1_walk_normal_001.bvh" "$tmp/in/"
"$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null 2>&1 || fail "first build failed"
before="$(md5sum <"$tmp/i.h5")"
cp "$data/bandai-namco-1/data/dataset-1_walk_normal_002.bvh" "$tmp/in/"
if flock "$tmp/.i.h5.lock" "$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null 2>"$tmp/err.txt"; then
  fail "a build ran while another held the lock"
fi
grep -q "another process is writing" "$tmp/err.txt" || fail "unclear message: $(cat "$tmp/err.txt")"
[ "$(md5sum <"$tmp/i.h5")" = "$before" ] || fail "the index changed under the lock"
"$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null 2>&1 || fail "build after the lock failed"
echo "PASS"
