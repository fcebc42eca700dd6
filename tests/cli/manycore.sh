#!/usr/bin/env bash
# bench/manycore (docs/performance.md "Many cores, one command") on three
# set-1 clips, 1 and 2 cores, a few queries: refuses bad counts and a missing
# folder; writes one table row per core count and JSON with the machine and
# every figure (positive, the index bytes per frame equal for both rows: the
# build's output does not depend on --jobs), and leaves nothing in $TMPDIR.
#   bash tests/cli/manycore.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup manycore "$@"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
py=/usr/bin/python3
[ -x "$py" ] || missing_tool scripts/setup "/usr/bin/python3 not found"
mc="$root/bench/manycore"
mkdir "$tmp/clips" "$tmp/scratch"
for c in walk_normal_001 walk_happy_001 bye_normal_001; do
  ln -s "$(cd "$data/bandai-namco-1/data" && pwd)/dataset-1_$c.bvh" "$tmp/clips/"
done
export TMPDIR="$tmp/scratch"
for bad in "--copies 0" "--queries 0"; do
  rc=0
  # shellcheck disable=SC2086
  "$py" "$mc" --build "$build" $bad "$tmp/clips" >/dev/null 2>"$tmp/err.txt" || rc=$?
  [ "$rc" != 0 ] && grep -q "must be >= 1" "$tmp/err.txt" || fail "$bad: exit $rc, $(cat "$tmp/err.txt")"
done
rc=0
"$py" "$mc" --build "$build" "$tmp/missing" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" != 0 ] && grep -q "not a folder" "$tmp/err.txt" || fail "missing folder: $(cat "$tmp/err.txt")"
"$py" "$mc" --build "$build" --cores 1,2 --copies 2 --queries 13 --synth-queries 2 \
  --json "$tmp/r.json" --md "$tmp/r.md" "$tmp/clips" >/dev/null 2>&1 || fail "bench/manycore failed"
[ "$(grep -c '^| [12] |' "$tmp/r.md")" = 2 ] || fail "table: $(cat "$tmp/r.md")"
"$py" - "$tmp/r.json" <<'PY' || fail "JSON: $(head -c 400 "$tmp/r.json")"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["machine"]["cores"] >= 1 and r["copies"] == 2
rows = r["rows"]
assert [x["cores"] for x in rows] == [1, 2]
for x in rows:
    assert all(v > 0 for v in x.values()), x
assert rows[0]["frames"] == rows[1]["frames"]
assert rows[0]["index_bytes_per_frame"] == rows[1]["index_bytes_per_frame"]
PY
[ -z "$(ls -A "$tmp/scratch")" ] || fail "left behind: $(ls "$tmp/scratch")"
echo "OK"
