#!/usr/bin/env bash
# Search benchmark:
#   bench/search_bench.sh [--json FILE] BUILD_DIR INDEX.h5 DATA_DIR [COUNT]
# Generates COUNT queries (default 1000) from DATA_DIR's BVH files
# (bench/search_queries.py: half full-frame, half partial; two and three
# query frames), then runs
#   - exact on the whole batch with 1 and with 2 threads (throughput; per
#     query latencies from the 1-thread run, where each query runs on one core);
#   - brute, exact and approx with 1 thread on a subset: the first 50
#     full-frame queries and the first 20 partial ones (brute on all COUNT
#     would take too long);
# and prints median and p99 latency per query kind (full / partial x two /
# three frames) and mode, exact vs brute speed-up, clips and frames pruned,
# approx recall. The same figures go to FILE as JSON with --json FILE (or
# SEARCH_BENCH_JSON=FILE), for scripts/bench. Wall times depend on the load of
# the machine: the JSON also records CPU seconds per run and the load average.
set -euo pipefail
JSON=${SEARCH_BENCH_JSON:-}
if [[ ${1:-} == --json ]]; then
  JSON=$2
  shift 2
fi
if [[ $# -lt 3 ]]; then
  echo "usage: $0 [--json FILE] BUILD_DIR INDEX.h5 DATA_DIR [COUNT]" >&2
  exit 2
fi
BUILD=$1; INDEX=$2; DATA=$3; COUNT=${4:-1000}
S=$BUILD/search/mocap-search
[[ -x $S ]] || { echo "search_bench: $S not found (build first)" >&2; exit 2; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
python3 "$(dirname "$0")/search_queries.py" "$DATA" "$COUNT" 1 > "$T/all.jsonl"
python3 - "$S" "$INDEX" "$T" "$JSON" <<'PY'
import json, math, os, resource, subprocess, sys, time

exe, index, tmp, json_out = sys.argv[1:5]
load = lambda p: [json.loads(l) for l in open(p)]
queries = load(f"{tmp}/all.jsonl")

def is_full(q):
    return all("bvh" in f and "only" not in f for f in q["frames"])

def kind(q):
    return f"{'full' if is_full(q) else 'partial'}-{len(q['frames'])}"

full = [q for q in queries if is_full(q)][:50]
partial = [q for q in queries if not is_full(q)][:20]
with open(f"{tmp}/subset.jsonl", "w") as fh:
    fh.writelines(json.dumps(q) + "\n" for q in full + partial)
kinds = {q["id"]: kind(q) for q in queries}

def run(name, batch, mode, threads, extra=()):
    out = f"{tmp}/{name}.jsonl"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    subprocess.run([exe, "--index", index, "-q", "--queries", batch, "--mode", mode,
                    "--threads", str(threads), "--out", out, *extra], check=False)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"rows": load(out), "wall_s": wall, "cpu_s": cpu}

def pct(xs, p):
    if not xs:
        return None
    xs = sorted(xs)
    return xs[min(len(xs) - 1, max(0, math.ceil(p / 100.0 * len(xs)) - 1))]  # nearest rank

def median(xs):
    if not xs:
        return None
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])

def summary(rows):
    ok = [r for r in rows if "stats" in r]
    per_kind = {}
    for k in sorted({kinds[r["id"]] for r in ok}):
        ms = [r["stats"]["time_ms"] for r in ok if kinds[r["id"]] == k]
        per_kind[k] = {"queries": len(ms), "median_ms": median(ms), "p99_ms": pct(ms, 99), "max_ms": max(ms)}
    ms = [r["stats"]["time_ms"] for r in ok]
    st = lambda key: sum(r["stats"][key] for r in ok)
    return {"queries": len(rows), "failed": len(rows) - len(ok), "median_ms": median(ms), "p99_ms": pct(ms, 99),
            "sum_ms": sum(ms), "kinds": per_kind, "clips": st("clips"), "clips_pruned": st("clips_pruned"),
            "frames_evaluated": st("frames_evaluated"), "frames_pruned": st("frames_pruned")}

def strip(r):
    return {k: v for k, v in r.items() if k != "rows"}

with open(f"{tmp}/one.jsonl", "w") as fh:
    fh.write(json.dumps(queries[0]) + "\n")
o1 = run("o1", f"{tmp}/one.jsonl", "exact", 1)  # opening the index and building the tables
o2 = run("o2", f"{tmp}/one.jsonl", "exact", 2)
e1 = run("e1", f"{tmp}/all.jsonl", "exact", 1)
e2 = run("e2", f"{tmp}/all.jsonl", "exact", 2)
b = run("b", f"{tmp}/subset.jsonl", "brute", 1)
x = run("x", f"{tmp}/subset.jsonl", "exact", 1)
a = run("a", f"{tmp}/subset.jsonl", "approx", 1)

def ranking(rows):
    return {r["id"]: [[(p["clip_index"], p["start_frame"], p["end_frame"]) for p in pr["results"]] for pr in r.get("pairs", [])] for r in rows}
same = ranking(b["rows"]) == ranking(x["rows"])
bf = [r["stats"]["time_ms"] for r in b["rows"] if "stats" in r and kinds[r["id"]].startswith("full")]
xf = [r["stats"]["time_ms"] for r in x["rows"] if "stats" in r and kinds[r["id"]].startswith("full")]
rec = [r["stats"]["recall"] for r in a["rows"] if "stats" in r and "recall" in r["stats"]]
two_full = [r["stats"]["time_ms"] for r in e1["rows"] if "stats" in r and kinds[r["id"]] == "full-2"]
result = {
    "index": index, "count": len(queries), "load_average": os.getloadavg(),
    "batch": {"exact_1_thread": strip(e1), "exact_2_threads": strip(e2),
              "speedup_2_vs_1_wall": e1["wall_s"] / e2["wall_s"] if e2["wall_s"] > 0 else None,
              "load_1_query": {"1_thread": strip(o1), "2_threads": strip(o2)},
              "speedup_2_vs_1_wall_without_load": ((e1["wall_s"] - o1["wall_s"]) / (e2["wall_s"] - o2["wall_s"])
                                                   if e2["wall_s"] > o2["wall_s"] else None),
              "exact_1_thread_summary": summary(e1["rows"]), "exact_2_threads_summary": summary(e2["rows"])},
    "subset": {"full_frame_queries": len(full), "partial_queries": len(partial),
               "brute": {**strip(b), **summary(b["rows"])}, "exact": {**strip(x), **summary(x["rows"])},
               "approx": {**strip(a), **summary(a["rows"]), "mean_recall": sum(rec) / len(rec) if rec else None},
               "exact_equals_brute": same,
               "full_frame_speedup_sum": sum(bf) / sum(xf) if xf and sum(xf) > 0 else None,
               "full_frame_speedup_median_per_query": median([p / q for p, q in zip(bf, xf) if q > 0])},
    "two_frame_full_exact_1_core": {"queries": len(two_full), "median_ms": median(two_full), "p99_ms": pct(two_full, 99)},
}
f = lambda v, d=2: "n/a" if v is None else f"{v:.{d}f}"
print(f"load average {' '.join(f(l) for l in result['load_average'])} (2-core machine: wall times are inflated under load)")
print(f"batch exact, {len(queries)} queries: 1 thread {f(e1['wall_s'])} s wall ({f(e1['cpu_s'])} s CPU), "
      f"2 threads {f(e2['wall_s'])} s wall ({f(e2['cpu_s'])} s CPU): {f(result['batch']['speedup_2_vs_1_wall'])}x; "
      f"without opening the index ({f(o1['wall_s'])} / {f(o2['wall_s'])} s for 1 query): "
      f"{f(result['batch']['speedup_2_vs_1_wall_without_load'])}x")
s1 = result["batch"]["exact_1_thread_summary"]
print(f"  failed {s1['failed']}; clips {s1['clips']}, pruned {s1['clips_pruned']}; frames evaluated {s1['frames_evaluated']}, pruned {s1['frames_pruned']}")
print("latency per query (ms), 1 thread: median / p99")
print(f"  {'kind':<10} {'exact (batch)':>18} {'brute (subset)':>18} {'exact (subset)':>18} {'approx (subset)':>18}")
for k in sorted(set(s1["kinds"]) | set(result["subset"]["brute"]["kinds"])):
    cell = lambda s: f"{f(s['kinds'][k]['median_ms'])} / {f(s['kinds'][k]['p99_ms'])} ({s['kinds'][k]['queries']})" if k in s["kinds"] else "-"
    print(f"  {k:<10} {cell(s1):>18} {cell(result['subset']['brute']):>18} {cell(result['subset']['exact']):>18} {cell(result['subset']['approx']):>18}")
sub = result["subset"]
print(f"exact vs brute, {len(full)} full-frame queries: {f(sub['full_frame_speedup_sum'], 1)}x by sum, "
      f"{f(sub['full_frame_speedup_median_per_query'], 1)}x median per query; same rankings: {same}")
for m in ("brute", "exact", "approx"):
    s = sub[m]
    print(f"  {m:<6} subset: clips {s['clips']}, pruned {s['clips_pruned']}; frames evaluated {s['frames_evaluated']}, pruned {s['frames_pruned']}; {f(s['cpu_s'])} s CPU")
print(f"approx mean recall {f(sub['approx']['mean_recall'], 3)} (approx times include the exact run for recall)")
tf = result["two_frame_full_exact_1_core"]
print(f"two-frame full-frame exact on 1 core ({tf['queries']}): median {f(tf['median_ms'])} ms, p99 {f(tf['p99_ms'])} ms")
if json_out:
    with open(json_out, "w") as fh:
        json.dump(result, fh, indent=1)
    print(f"JSON: {json_out}")
PY
