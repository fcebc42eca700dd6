#!/usr/bin/env bash
# Search benchmark:
#   bench/search_bench.sh [--json FILE] [--brute-relative N] [--brute-world N]
#                         BUILD_DIR INDEX.h5 DATA_DIR [COUNT]
# Generates COUNT queries (default 1000) from DATA_DIR's BVH files with
# bench/search_queries.py: held-out queries (the query's clip excluded by
# filter.exclude) in relative and world mode, full and partial, two and three
# frames, and one self-retrieval kind (world, full, two frames, the clip in
# the index); the kind is in each query's id. Then runs, with 1 thread unless
# said (each run as two processes, the relative queries and the others):
#   - exact on the whole batch with 1 and with 2 threads (throughput; per
#     query latencies from the 1-thread run, where each query runs on one core);
#   - brute on a subset: the first N queries of each kind (N = 12 per relative
#     kind, 60 per world or self kind by default: brute takes about 0.5-2 s per
#     relative and 0.01-0.08 s per world query on set 2, so a default run
#     spends one to two minutes in brute), compared with exact's times and
#     rankings on the same queries;
#   - approx on the world and self queries of the subset (relative queries
#     fall back to exact);
# and prints per mode and kind the median and p99 latency of exact (whole
# batch) and brute (subset), exact's on the brute queries, and brute / exact
# (ratio of the medians and of the sums on the same queries), pruning and
# approx recall. The same figures go to FILE as JSON with --json FILE (or
# SEARCH_BENCH_JSON=FILE), for scripts/bench. Wall times depend on the load of
# the machine: the JSON also records CPU seconds per run and the load average.
set -euo pipefail
JSON=${SEARCH_BENCH_JSON:-}
BRUTE_REL=${SEARCH_BENCH_BRUTE_RELATIVE:-12}
BRUTE_WORLD=${SEARCH_BENCH_BRUTE_WORLD:-60}
EXTRA=()  # --max-length S: passed to mocap-search (default: the engine's)
while [[ ${1:-} == --* ]]; do
  case $1 in
    --json) JSON=$2 ;;
    --brute-relative) BRUTE_REL=$2 ;;
    --brute-world) BRUTE_WORLD=$2 ;;
    --max-length) EXTRA=(--max-length "$2") ;;
    *) echo "search_bench: unknown option $1" >&2; exit 2 ;;
  esac
  shift 2
done
if [[ $# -lt 3 ]]; then
  echo "usage: $0 [--json FILE] [--brute-relative N] [--brute-world N] [--max-length S] BUILD_DIR INDEX.h5 DATA_DIR [COUNT]" >&2
  exit 2
fi
BUILD=$1; INDEX=$2; DATA=$3; COUNT=${4:-1000}
S=$BUILD/search/mocap-search
[[ -x $S ]] || { echo "search_bench: $S not found (build first)" >&2; exit 2; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
python3 "$(dirname "$0")/search_queries.py" "$DATA" "$COUNT" 1 > "$T/all.jsonl"
python3 - "$S" "$INDEX" "$T" "$JSON" "$BRUTE_REL" "$BRUTE_WORLD" "${EXTRA[@]}" <<'PY'
import json, math, os, resource, subprocess, sys, time

exe, index, tmp, json_out = sys.argv[1:5]
extra_args = sys.argv[7:]  # e.g. --max-length S
brute_per_kind = {"relative": int(sys.argv[5]), "world": int(sys.argv[6])}
load = lambda p: [json.loads(l) for l in open(p)]
queries = load(f"{tmp}/all.jsonl")
MODES = {"rel": "relative", "world": "world", "self": "self"}  # id prefix -> mode

def kind(qid):
    return qid.split("-", 1)[1]  # q<i>-<mode>-<full|partial>-<frames>

def mode(k):
    return MODES[k.split("-")[0]]

kinds = {q["id"]: kind(q["id"]) for q in queries}
order = sorted(set(kinds.values()), key=lambda k: (list(MODES).index(k.split("-")[0]), k))
subset = []
for k in order:
    n = brute_per_kind["relative" if mode(k) == "relative" else "world"]
    subset += [q for q in queries if kinds[q["id"]] == k][:n]
approx_subset = [q for q in subset if mode(kinds[q["id"]]) != "relative"]

def by_mode(batch):
    """The relative queries, then the world and self ones (non-empty lists).
    A batch mixing relative and world queries is run as two, so that builds
    older than 2026-11-26 (whose exact mode corrupted its heap on such a
    batch) can be measured too, and each mode's time is its own."""
    rel = [q for q in batch if q["relative"]]
    return [b for b in (rel, [q for q in batch if not q["relative"]]) if b]

def run(name, batch, mode_, threads):
    """Runs mocap-search on the queries `batch`, one process per search mode
    (relative, world + self) in turn: rows, wall and CPU seconds summed."""
    rows, wall, cpu = [], 0.0, 0.0
    for part, qs in enumerate(by_mode(batch)):
        src, out = f"{tmp}/{name}-{part}-q.jsonl", f"{tmp}/{name}-{part}.jsonl"
        with open(src, "w") as fh:
            fh.writelines(json.dumps(q) + "\n" for q in qs)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        p = subprocess.run([exe, "--index", index, "-q", "--queries", src, "--mode", mode_,
                            "--threads", str(threads), "--out", out] + extra_args)
        wall += time.monotonic() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu += (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        if p.returncode not in (0, 1):  # 1: some queries failed (reported on their lines)
            sys.exit(f"search_bench: mocap-search --mode {mode_} failed ({p.returncode}) on {src}")
        rows += load(out)
    return {"rows": rows, "wall_s": wall, "cpu_s": cpu, "processes": len(by_mode(batch))}

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

def latency(ms):
    return {"queries": len(ms), "median_ms": median(ms), "p99_ms": pct(ms, 99),
            "max_ms": max(ms) if ms else None}

def summary(rows):
    ok = [r for r in rows if "stats" in r]
    per_kind = {k: latency([r["stats"]["time_ms"] for r in ok if kinds[r["id"]] == k])
                for k in order if any(kinds[r["id"]] == k for r in ok)}
    ms = [r["stats"]["time_ms"] for r in ok]
    st = lambda key: sum(r["stats"][key] for r in ok)
    return {"queries": len(rows), "failed": len(rows) - len(ok), "median_ms": median(ms), "p99_ms": pct(ms, 99),
            "sum_ms": sum(ms), "kinds": per_kind, "clips": st("clips"), "clips_pruned": st("clips_pruned"),
            "frames_evaluated": st("frames_evaluated"), "frames_pruned": st("frames_pruned")}

def strip(r):
    return {k: v for k, v in r.items() if k != "rows"}

def ranking(row):
    return [[(p["clip_index"], p["start_frame"], p["end_frame"]) for p in pr["results"]] for pr in row.get("pairs", [])]

# Opening the index and building the tables: one query per process of the batch.
one = [qs[0] for qs in by_mode(queries)]
o1 = run("o1", one, "exact", 1)
o2 = run("o2", one, "exact", 2)
e1 = run("e1", queries, "exact", 1)
e2 = run("e2", queries, "exact", 2)
b = run("b", subset, "brute", 1)
a = run("a", approx_subset, "approx", 1) if approx_subset else {"rows": [], "wall_s": 0.0, "cpu_s": 0.0}

exact_by_id = {r["id"]: r for r in e1["rows"]}
per_kind = {}
for k in order:
    ex = [r for r in e1["rows"] if kinds[r["id"]] == k]
    br = [r for r in b["rows"] if kinds[r["id"]] == k and "stats" in r]
    pairs = [(r["stats"]["time_ms"], exact_by_id[r["id"]]["stats"]["time_ms"]) for r in br
             if "stats" in exact_by_id.get(r["id"], {})]
    bm = median([p for p, _ in pairs])
    xm = median([q for _, q in pairs])
    per_kind[k] = {
        "mode": mode(k), "frames": k.split("-")[1], "query_frames": int(k.split("-")[2]),
        "failed": sum(1 for r in ex if "stats" not in r),
        "exact": latency([r["stats"]["time_ms"] for r in ex if "stats" in r]),
        "brute": latency([p for p, _ in pairs]),
        "exact_on_brute_queries": latency([q for _, q in pairs]),
        "brute_vs_exact_median": bm / xm if bm is not None and xm else None,
        "brute_vs_exact_sum": (sum(p for p, _ in pairs) / sum(q for _, q in pairs)
                               if pairs and sum(q for _, q in pairs) > 0 else None),
        "exact_equals_brute": all(ranking(r) == ranking(exact_by_id.get(r["id"], {})) for r in br),
    }
same = all(v["exact_equals_brute"] for v in per_kind.values())
rec = [r["stats"]["recall"] for r in a["rows"] if "stats" in r and "recall" in r["stats"]]
result = {
    "format": 2,
    "index": index, "count": len(queries), "load_average": os.getloadavg(),
    "query_batch": "bench/search_queries.py: held-out queries (clip excluded) in relative and world mode, "
                   "full and partial, 2 and 3 frames, and self-retrieval (world, full, 2 frames, clip in the index)",
    "brute_per_kind": brute_per_kind,
    "kinds": per_kind,
    "batch": {"exact_1_thread": strip(e1), "exact_2_threads": strip(e2),
              "speedup_2_vs_1_wall": e1["wall_s"] / e2["wall_s"] if e2["wall_s"] > 0 else None,
              "load_1_query": {"1_thread": strip(o1), "2_threads": strip(o2)},
              "speedup_2_vs_1_wall_without_load": ((e1["wall_s"] - o1["wall_s"]) / (e2["wall_s"] - o2["wall_s"])
                                                   if e2["wall_s"] > o2["wall_s"] else None),
              "exact_1_thread_summary": summary(e1["rows"]), "exact_2_threads_summary": summary(e2["rows"])},
    "subset": {"queries": len(subset), "approx_queries": len(approx_subset),
               "brute": {**strip(b), **summary(b["rows"])},
               "approx": {**strip(a), **summary(a["rows"]), "mean_recall": sum(rec) / len(rec) if rec else None},
               "exact_equals_brute": same},
}
f = lambda v, d=2: "n/a" if v is None else f"{v:.{d}f}"
print(f"load average {' '.join(f(l) for l in result['load_average'])} (wall times are inflated under load)")
print(f"batch exact, {len(queries)} queries in {e1['processes']} processes (relative; world and self): 1 thread {f(e1['wall_s'])} s wall ({f(e1['cpu_s'])} s CPU), "
      f"2 threads {f(e2['wall_s'])} s wall ({f(e2['cpu_s'])} s CPU): {f(result['batch']['speedup_2_vs_1_wall'])}x; "
      f"without opening the index ({f(o1['wall_s'])} / {f(o2['wall_s'])} s for 1 query per process): "
      f"{f(result['batch']['speedup_2_vs_1_wall_without_load'])}x")
s1 = result["batch"]["exact_1_thread_summary"]
print(f"  failed {s1['failed']}; clips {s1['clips']}, pruned {s1['clips_pruned']}; frames evaluated {s1['frames_evaluated']}, pruned {s1['frames_pruned']}")
print("latency per query (ms), 1 thread: median / p99 (queries); brute / exact on the same queries")
print(f"  {'kind':<16} {'exact (batch)':>22} {'brute (subset)':>22} {'exact (same)':>16} {'median x':>9} {'sum x':>7} same")
for k in order:
    d = per_kind[k]
    cell = lambda s: f"{f(s['median_ms'])} / {f(s['p99_ms'])} ({s['queries']})"
    print(f"  {k:<16} {cell(d['exact']):>22} {cell(d['brute']):>22} "
          f"{f(d['exact_on_brute_queries']['median_ms']) + ' / ' + f(d['exact_on_brute_queries']['p99_ms']):>16} "
          f"{f(d['brute_vs_exact_median'], 1):>9} {f(d['brute_vs_exact_sum'], 1):>7} {d['exact_equals_brute']}")
print(f"exact == brute on the subset ({len(subset)} queries): {same}; brute {f(b['cpu_s'])} s CPU")
print(f"approx mean recall {f(result['subset']['approx']['mean_recall'], 3)} on {len(approx_subset)} world and self queries")
if json_out:
    with open(json_out, "w") as fh:
        json.dump(result, fh, indent=1)
    print(f"JSON: {json_out}")
PY
