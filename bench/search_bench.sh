#!/usr/bin/env bash
# Search benchmark: bench/search_bench.sh BUILD_DIR INDEX.h5 DATA_DIR [COUNT]
# Generates COUNT queries (default 1000) from DATA_DIR's BVH files, runs
# exact on 1 and 2 threads, brute and approx on the full-frame ones, and
# prints the figures of docs/performance.md ("Search").
set -euo pipefail
BUILD=$1; INDEX=$2; DATA=$3; COUNT=${4:-1000}
S=$BUILD/search/mocap-search
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
python3 "$(dirname "$0")/search_queries.py" "$DATA" "$COUNT" 1 > "$T/all.jsonl"
python3 -c "
import json,sys
L=[json.loads(l) for l in open('$T/all.jsonl')]
full=[q for q in L if all('bvh' in f and 'only' not in f for f in q['frames'])]
two=[q for q in full if len(q['frames'])==2]
open('$T/full.jsonl','w').write(''.join(json.dumps(q)+'\n' for q in full[:50]))
open('$T/two.jsonl','w').write(''.join(json.dumps(q)+'\n' for q in two))
"
run() { local t0=$(date +%s.%N); "$S" --index "$INDEX" -q "$@"; python3 -c "import time;print(f'{time.time()-$t0:.2f}')" ; }
echo "batch exact 1 thread:  $(run --queries "$T/all.jsonl" --threads 1 --out "$T/e1.jsonl") s"
echo "batch exact 2 threads: $(run --queries "$T/all.jsonl" --threads 2 --out "$T/e2.jsonl") s"
"$S" --index "$INDEX" -q --queries "$T/full.jsonl" --threads 1 --mode brute --out "$T/b.jsonl"
"$S" --index "$INDEX" -q --queries "$T/full.jsonl" --threads 1 --mode exact --out "$T/x.jsonl"
"$S" --index "$INDEX" -q --queries "$T/two.jsonl" --threads 1 --mode exact --out "$T/two_out.jsonl"
"$S" --index "$INDEX" -q --queries "$T/full.jsonl" --threads 1 --mode approx --out "$T/a.jsonl"
python3 - "$T" <<'PY'
import json, statistics, sys
t = sys.argv[1]
load = lambda n: [json.loads(l) for l in open(f"{t}/{n}")]
def ms(rows): return [r["stats"]["time_ms"] for r in rows if "stats" in r]
b, x, a, two, e1 = load("b.jsonl"), load("x.jsonl"), load("a.jsonl"), load("two_out.jsonl"), load("e1.jsonl")
print(f"full-frame queries ({len(b)}): brute median {statistics.median(ms(b)):.1f} ms, exact median {statistics.median(ms(x)):.2f} ms, "
      f"speed-up (sum) {sum(ms(b))/sum(ms(x)):.1f}x, median per-query {statistics.median([p/q for p,q in zip(ms(b),ms(x))]):.1f}x")
print(f"two-frame full-frame exact on 1 core ({len(two)}): median {statistics.median(ms(two)):.2f} ms, p90 {sorted(ms(two))[int(0.9*len(two))]:.2f} ms")
rec = [r["stats"]["recall"] for r in a if "stats" in r]
print(f"approx: median {statistics.median(ms(a)):.1f} ms (incl. the exact run for recall), mean recall {statistics.mean(rec):.3f}")
fails = sum(1 for r in e1 if "error" in r)
print(f"batch: {len(e1)} queries, {fails} failed; exact median {statistics.median(ms(e1)):.2f} ms")
clips = x[0]["stats"]["clips"] / len(x[0]["pairs"]) if x else 0
print(f"per clip (exact, full-frame): {statistics.median(ms(x))/len(x[0]['pairs'])/clips*1000:.2f} us/clip/pair; brute {statistics.median(ms(b))/len(b[0]['pairs'])/clips*1000:.2f} us")
PY
