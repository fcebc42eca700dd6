#!/usr/bin/env bash
# Batch synthesis against one process per query:
#   bench/synth_batch.sh BUILD_DIR INDEX.h5 DATA_DIR [COUNT] [EVERY] [THREADS]
# Draws COUNT held-out relative queries (default 200; two and three full
# frames, bench/search_queries.py seed 3) from DATA_DIR's BVH files, makes
# them all with one `mocap-synth --queries --out-dir` (THREADS threads,
# default 2), then every EVERY-th of them (default 5) with one `mocap-synth
# --query --id --out` process each, and prints the batch's seconds per
# motion, the single processes' seconds per motion, their ratio (the
# throughput gained by the batch) and how many single-process files equal
# the batch's byte for byte. Temporary files go to a folder of its own,
# removed at the end.
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
BUILD=$1 INDEX=$2 DATA=$3 COUNT=${4:-200} EVERY=${5:-5} THREADS=${6:-2}
SYNTH="$BUILD/synth/mocap-synth"
[ -x "$SYNTH" ] || { echo "synth_batch: no $SYNTH (scripts/build)" >&2; exit 2; }
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/synth-batch.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
Q="$WORK/q.jsonl"
python3 "$HERE/search_queries.py" "$DATA" "$COUNT" 3 rel-full-2,rel-full-3 > "$Q"
now() { date +%s.%N; }
t0=$(now)
"$SYNTH" -q --threads "$THREADS" --index "$INDEX" --queries "$Q" --out-dir "$WORK/batch" > /dev/null
t1=$(now)
mkdir -p "$WORK/single"
ids=$(python3 -c "import json, sys; ids = [json.loads(l)['id'] for l in open(sys.argv[1])]; print(' '.join(ids[::int(sys.argv[2])]))" "$Q" "$EVERY")
n=0
t2=$(now)
for id in $ids; do
  "$SYNTH" --threads "$THREADS" --index "$INDEX" --query "$Q" --id "$id" \
    --out "$WORK/single/$id.bvh" > /dev/null 2>&1 || true
  n=$((n + 1))
done
t3=$(now)
same=0
for f in "$WORK"/single/*.bvh; do
  [ -e "$f" ] && cmp -s "$f" "$WORK/batch/$(basename "$f")" && same=$((same + 1))
done
python3 - "$t0" "$t1" "$t2" "$t3" "$COUNT" "$n" "$same" "$THREADS" <<'PY'
import sys
t0, t1, t2, t3 = map(float, sys.argv[1:5])
count, n, same, threads = map(int, sys.argv[5:9])
batch, single = (t1 - t0) / count, (t3 - t2) / n
print(f"batch: {count} motions in {t1 - t0:.2f} s ({batch * 1000:.1f} ms each), {threads} threads")
print(f"one process per query: {n} in {t3 - t2:.2f} s ({single * 1000:.0f} ms each)")
print(f"batch / processes throughput: {single / batch:.1f}x; identical files {same} of {n}")
PY
