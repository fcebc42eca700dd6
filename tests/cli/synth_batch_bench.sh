#!/usr/bin/env bash
# bench/synth_batch.sh (docs/performance.md "Many cores, one command") on an
# index of three set-1 clips, four queries, every second one as a process of
# its own: prints the usage without arguments; the batch's and the single
# processes' times and their ratio, and the single-process files equal the
# batch's byte for byte; leaves nothing in $TMPDIR.
#   bash tests/cli/synth_batch_bench.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup synth_batch_bench "$@"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
[ -x /usr/bin/python3 ] || missing_tool scripts/setup "/usr/bin/python3 not found"
sb="$root/bench/synth_batch.sh"
mkdir "$tmp/clips" "$tmp/scratch"
for c in walk_normal_001 walk_happy_001 walk_sad_001; do
  ln -s "$(cd "$data/bandai-namco-1/data" && pwd)/dataset-1_$c.bvh" "$tmp/clips/"
done
rc=0
bash "$sb" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "BUILD_DIR INDEX.h5 DATA_DIR" "$tmp/err.txt" || fail "usage: exit $rc"
"$build/indexer/mocap-index" build -q --out "$tmp/i.h5" "$tmp/clips" >/dev/null 2>&1 ||
  fail "mocap-index build failed"
export TMPDIR="$tmp/scratch"
PATH="/usr/bin:$PATH" bash "$sb" "$build" "$tmp/i.h5" "$tmp/clips" 4 2 2 >"$tmp/out.txt" 2>&1 ||
  fail "bench/synth_batch.sh failed: $(cat "$tmp/out.txt")"
grep -q "^batch: 4 motions in " "$tmp/out.txt" || fail "batch line: $(cat "$tmp/out.txt")"
grep -q "^one process per query: 2 in " "$tmp/out.txt" || fail "single line: $(cat "$tmp/out.txt")"
grep -q "x; identical files 2 of 2$" "$tmp/out.txt" || fail "ratio line: $(cat "$tmp/out.txt")"
[ -z "$(ls -A "$tmp/scratch")" ] || fail "left in TMPDIR: $(ls -A "$tmp/scratch")"
echo "ok"
