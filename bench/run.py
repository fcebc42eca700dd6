#!/usr/bin/env python3
"""Measures the whole pipeline on the real data and writes bench/results.json.

Called by scripts/bench (which builds first); see docs/performance.md for
what each figure means. Every figure that is a rate or a time is taken
`--runs` times and reported as median with min and max.

  bench/run.py --build DIR --data DIR [--runs N] [--queries N]
               [--scales 1,2,4,8] [--json bench/results.json] [--work DIR]

Stages (each prints one progress line to stderr):
  ingest    bvh_parse_bench on set 2 (Google Benchmark repetitions)
  energy    energy_bench: h scan, g step, per-frame dynamics, clip steps
  index     mocap-index build of set 2 with --jobs 1 and 2, incremental
            rebuild with nothing changed (GNU time: wall, peak RSS)
  search    bench/search_bench.sh (latency per mode and query kind, recall,
            1 vs 2 thread throughput, pruning)
  synth     mocap-synth-quality on set 1 gaps (time per transition, g vs slerp)
  scaling   1x..8x set 2 (hard-linked copies): build time, size, peak RSS,
            search latency, pruning and search peak RSS per size
"""
import argparse
import datetime
import json
import math
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def stat(values):
    """Median, min, max of a list of numbers (and the values themselves)."""
    v = [float(x) for x in values if x is not None]
    if not v:
        return None
    return {"median": statistics.median(v), "min": min(v), "max": max(v), "runs": v}


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, text=True, capture_output=True, **kw)


def timed(cmd):
    """Runs cmd under GNU time; returns (stdout, wall_s, user_s, sys_s, peak_rss_MB)."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        t0 = time.monotonic()
        p = subprocess.run(["/usr/bin/time", "-v", "-o", tf.name] + cmd, text=True,
                           capture_output=True)
        wall = time.monotonic() - t0
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr[-2000:]}")
        t = tf.read()
    def field(name):
        m = re.search(rf"{re.escape(name)}: ([0-9.:]+)", t)
        return m.group(1) if m else "0"
    rss_mb = float(field("Maximum resident set size (kbytes)")) / 1024.0
    return p.stdout, wall, float(field("User time (seconds)")), float(
        field("System time (seconds)")), rss_mb


def machine():
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem_gb = 0.0
    try:
        with open("/proc/meminfo") as f:
            mem_gb = int(f.readline().split()[1]) / 1024 / 1024
    except OSError:
        pass
    try:
        commit = run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).stdout.strip()
        dirty = run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"]).stdout
        commit += "+changes" if dirty.strip() else ""
    except (subprocess.CalledProcessError, FileNotFoundError):
        commit = "unknown"
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_GB": round(mem_gb, 1),
            "os": platform.platform(), "commit": commit,
            "load_average_at_start": os.getloadavg()[0]}


def set2_dir(data):
    d = os.environ.get("MOCAP_BN2_DIR")
    if d and os.path.isdir(d):
        return d
    base = os.path.join(tempfile.gettempdir(), "mocap-bandai-namco-2")
    d = os.path.join(base, "bandai-namco-2", "data")
    if not os.path.exists(os.path.join(base, ".unpacked")):
        log(f"unpacking set 2 into {base}")
        # Into a folder of this process's own, then renamed into place, so a
        # test or benchmark running at the same time never reads a
        # half-written cache (tests/test_support.cpp does the same).
        mine = "%s.tmp-%d" % (base, os.getpid())
        shutil.rmtree(mine, ignore_errors=True)
        os.makedirs(mine)
        run(["tar", "--zstd", "-xf", os.path.join(data, "bandai-namco-2.tar.zst"), "-C", mine])
        open(os.path.join(mine, ".unpacked"), "w").close()
        try:
            os.rename(mine, base)
        except OSError:
            if not os.path.exists(os.path.join(base, ".unpacked")):
                shutil.rmtree(base, ignore_errors=True)
                os.rename(mine, base)
        shutil.rmtree(mine, ignore_errors=True)
    return d


def gbench(binary, flt, runs, min_time=None):
    """Google Benchmark repetitions -> {name: [rep rows]}."""
    cmd = [binary, f"--benchmark_filter={flt}", f"--benchmark_repetitions={runs}",
           "--benchmark_format=json"]
    if min_time:
        cmd.append(f"--benchmark_min_time={min_time}")
    out = run(cmd).stdout
    rows = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("run_type") != "iteration":
            continue
        if b.get("error_occurred"):
            raise RuntimeError(f"{b['name']}: {b.get('error_message')}")
        name = re.sub(r"/(min_time|real_time|repeats):.*$", "", b["run_name"])
        rows.setdefault(name, []).append(b)
    return rows


def ingest(a):
    rows = gbench(os.path.join(a.build, "bench", "bvh_parse_bench"), "BM_ParseBandaiNamco2",
                  a.runs)["BM_ParseBandaiNamco2"]
    return {"benchmark": "bvh_parse_bench BM_ParseBandaiNamco2 (set 2, one thread, CPU time)",
            "files": rows[0].get("files"), "MB": rows[0].get("MB"),
            "MB_per_s": stat(r["bytes_per_second"] / 1e6 for r in rows),
            "frames_per_s": stat(r["frames/s"] for r in rows)}


def energy(a):
    want = {"BM_HScan/4096": "h_scan_frames_per_s",
            "BM_NewtonEulerStep": "g_steps_per_s",
            "BM_ClipDynamics": "clip_dynamics_frames_per_s",
            "BM_ClipStepEnergies": "clip_steps_per_s",
            "BM_InverseDynamics": "inverse_dynamics_per_s"}
    rows = gbench(os.path.join(a.build, "bench", "energy_bench"),
                  "BM_HScan/4096|BM_NewtonEulerStep|BM_ClipDynamics|BM_ClipStepEnergies|"
                  "BM_InverseDynamics", a.runs, "1")
    return {key: stat(r["items_per_second"] for r in rows[name]) for name, key in want.items()
            if name in rows}


def build_index(a, inputs, out, jobs, full=True):
    cmd = [os.path.join(a.build, "indexer", "mocap-index"), "build", "--json", "-q",
           "--jobs", str(jobs), "--out", out] + (["--full"] if full else []) + inputs
    stdout, wall, user, sys_, rss = timed(cmd)
    j = json.loads(stdout.strip().splitlines()[-1])
    j.update({"wall_s": wall, "user_s": user, "sys_s": sys_, "peak_rss_MB": rss})
    return j


def index_stage(a, set2, work):
    out = os.path.join(work, "set2.h5")
    res = {}
    for jobs in (1, 2):
        rs = [build_index(a, [set2], out, jobs) for _ in range(a.runs)]
        res[f"jobs{jobs}"] = {
            "wall_s": stat(r["wall_s"] for r in rs),
            "frames_per_s": stat(r["frames"] / r["wall_s"] for r in rs),
            "cpu_s": stat(r["user_s"] + r["sys_s"] for r in rs),
            "peak_rss_MB": stat(r["peak_rss_MB"] for r in rs),
            "stages_s": {k: statistics.median(r["stages"][k] for r in rs)
                         for k in rs[0].get("stages", {})},
        }
        res["clips"], res["frames"] = rs[0]["clips"], rs[0]["frames"]
        res["index_bytes"], res["source_bytes"] = rs[0]["index_bytes"], rs[0]["source_bytes"]
    res["speedup_1_to_2"] = res["jobs1"]["wall_s"]["median"] / res["jobs2"]["wall_s"]["median"]
    inc = [build_index(a, [set2], out, 2, full=False) for _ in range(a.runs)]
    assert all(r["up_to_date"] for r in inc), "incremental rebuild was not a no-op"
    res["incremental_nothing_changed"] = {"wall_s": stat(r["wall_s"] for r in inc),
                                          "peak_rss_MB": stat(r["peak_rss_MB"] for r in inc)}
    return res, out


def search_stage(a, index, set2, work):
    """bench/search_bench.sh writes its figures as JSON (SEARCH_BENCH_JSON)."""
    per_run = []
    for i in range(a.runs):
        out = os.path.join(work, f"search{i}.json")
        env = dict(os.environ, SEARCH_BENCH_JSON=out)
        p = subprocess.run([os.path.join(HERE, "search_bench.sh"), a.build, index, set2,
                            str(a.queries)], env=env, text=True, capture_output=True)
        if p.returncode != 0:
            raise RuntimeError(f"search_bench.sh failed: {p.stderr[-3000:]}")
        with open(out) as f:
            per_run.append(json.load(f))
    return merge_runs(per_run)


def merge_runs(runs):
    """Numbers at the same path in every run -> stat(); the rest from run 1."""
    first = runs[0]
    if isinstance(first, dict):
        return {k: merge_runs([r.get(k) for r in runs]) for k in first}
    if isinstance(first, (int, float)) and not isinstance(first, bool):
        vals = [r for r in runs if isinstance(r, (int, float))]
        return stat(vals) if len(runs) > 1 else first
    return first


# mocap-synth-quality options of the deep refinement setting.
DEEP_REFINEMENT = ["--refine-polish", "100", "--refine-polish-window", "8",
                   "--refine-polish-smoothing", "0.3"]


def quality_figures(s):
    """The g and sliding figures of a mocap-synth-quality summary."""
    return {"astar_lower_g_fraction": s.get("astar_lower_g", 0) / max(1, s.get("gaps", 1)),
            "ratio_mean_g_astar_to_slerp": s.get("ratio_mean_g"),
            "foot_sliding_astar_m": s.get("foot_sliding_astar_m"),
            "foot_sliding_slerp_m": s.get("foot_sliding_slerp_m")}


def synth_stage(a, work):
    idx = os.path.join(work, "set1.h5")
    build_index(a, [os.path.join(a.data, "bandai-namco-1")], idx, 2)
    rs = []
    for i in range(a.runs):
        out = os.path.join(work, f"quality{i}.json")
        run([os.path.join(a.build, "synth", "mocap-synth-quality"), "--index", idx,
             "--json", out])
        with open(out) as f:
            rs.append(json.load(f)["summary"])
    s = rs[0]
    # The deep refinement setting (docs/synthesis.md "Reading"): one run (its
    # energies are deterministic; its time is seconds per transition).
    deep_out = os.path.join(work, "quality-deep.json")
    run([os.path.join(a.build, "synth", "mocap-synth-quality"), "--index", idx,
         "--json", deep_out] + DEEP_REFINEMENT)
    with open(deep_out) as f:
        d = json.load(f)["summary"]
    deep = {"options": " ".join(DEEP_REFINEMENT), **quality_figures(d),
            "median_cpu_ms_per_transition": d.get("median_cpu_ms"),
            "max_ms_per_transition": d.get("max_ms")}
    return {"gaps": s.get("gaps"), "deep": deep, **quality_figures(s),
            "median_ms_per_transition": stat(r.get("median_ms") for r in rs),
            "median_cpu_ms_per_transition": stat(r.get("median_cpu_ms") for r in rs),
            "max_ms_per_transition": stat(r.get("max_ms") for r in rs)}


# Query kinds of the scaling stage (bench/search_queries.py): world mode only,
# so that the scaling plot can also be drawn for builds older than 2026-11-26,
# whose exact mode corrupted its heap on a batch mixing relative and world
# queries.
SCALING_KINDS = "world-full-2,world-partial-2"


def scaling_queries(set2, work, count):
    """Held-out two-frame world-mode queries from set 2: half full-frame, half partial."""
    path = os.path.join(work, "scaling_queries.jsonl")
    q = run([sys.executable, os.path.join(HERE, "search_queries.py"), set2, str(count), "7",
             SCALING_KINDS]).stdout
    with open(path, "w") as f:
        f.write(q)
    return path, len(q.splitlines())


def percentile(v, p):
    """Nearest-rank percentile, the definition bench/search_bench.sh uses."""
    v = sorted(v)
    return v[min(len(v) - 1, max(0, math.ceil(p / 100.0 * len(v)) - 1))]


def scaled_copies(set2, work, k):
    """WORK/x{k}: k hard-linked copies of set 2 (no extra disk). Not symlinks:
    the indexer enters a folder once by its canonical path, so k links to one
    folder would index one copy."""
    coll = os.path.join(work, f"x{k}")
    os.makedirs(coll, exist_ok=True)
    for i in range(k):
        copy = os.path.join(coll, f"copy{i + 1}")
        if not os.path.exists(copy):
            run(["cp", "-al", set2, copy + ".tmp"])
            os.rename(copy + ".tmp", copy)
    return coll


def scaling_stage(a, set2, work):
    qpath, nq = scaling_queries(set2, work, a.scaling_queries)
    rows = []
    for k in a.scales:
        log(f"scaling {k}x: index build")
        coll = scaled_copies(set2, work, k)
        idx = os.path.join(work, f"x{k}.h5")
        b = build_index(a, [coll], idx, 2)
        log(f"scaling {k}x: {nq} queries, exact, 1 thread")
        res = os.path.join(work, f"x{k}.jsonl")
        _, wall, user, sys_, rss = timed([os.path.join(a.build, "search", "mocap-search"),
                                          "--index", idx, "--queries", qpath, "--threads", "1",
                                          "--mode", "exact", "-q", "--out", res])
        with open(res) as f:
            out = [json.loads(l) for l in f]
        ok = [r for r in out if "stats" in r]
        ms = [r["stats"]["time_ms"] for r in ok]
        clips = sum(r["stats"]["clips"] for r in ok)
        frames_eval = sum(r["stats"]["frames_evaluated"] for r in ok)
        frames_pruned = sum(r["stats"]["frames_pruned"] for r in ok)
        rows.append({
            "scale": k, "clips": b["clips"], "frames": b["frames"],
            "build_wall_s": b["wall_s"], "build_frames_per_s": b["frames"] / b["wall_s"],
            "build_peak_rss_MB": b["peak_rss_MB"], "build_stages_s": b.get("stages"),
            "index_bytes": b["index_bytes"],
            "queries": len(ok), "query_errors": len(out) - len(ok),
            "search_median_ms": statistics.median(ms), "search_p99_ms": percentile(ms, 99),
            "search_batch_wall_s": wall, "search_peak_rss_MB": rss,
            # wall time outside the queries: start-up, opening the index and
            # loading the arrays the batch needs (serial, once per batch)
            "search_open_load_s": max(0.0, wall - sum(ms) / 1000.0),
            "clips_pruned_fraction": sum(r["stats"]["clips_pruned"] for r in ok) / max(1, clips),
            "frames_pruned_fraction": frames_pruned / max(1, frames_eval + frames_pruned),
        })
        os.remove(idx)
        os.remove(res)
    return {"queries": nq, "query_kind": "held-out two-frame world-mode queries, half full-frame, half partial; "
                                         "exact; 1 thread",
            "rows": rows}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", required=True, help="Release build with MOCAP_BENCH=ON")
    p.add_argument("--data", default=os.environ.get("MOCAP_DATA_DIR", os.path.join(ROOT, "..", "shared", "data")))
    p.add_argument("--runs", type=int, default=3, help="repetitions per figure (default 3)")
    p.add_argument("--queries", type=int, default=1000, help="search batch size (default 1000)")
    p.add_argument("--scaling-queries", type=int, default=100)
    p.add_argument("--scales", default="1,2,4,8")
    p.add_argument("--only", default="ingest,energy,index,search,synth,scaling",
                   help="comma-separated stages to run")
    p.add_argument("--json", default=os.path.join(HERE, "results.json"))
    p.add_argument("--work", default=None, help="scratch folder (default: a temporary one)")
    a = p.parse_args()
    a.build = os.path.abspath(a.build)
    a.data = os.path.abspath(a.data)
    a.scales = [int(x) for x in a.scales.split(",") if x]
    only = set(a.only.split(","))
    if not os.path.isdir(os.path.join(a.data, "bandai-namco-1")):
        sys.exit(f"bench/run.py: no data at {a.data} (set --data or MOCAP_DATA_DIR)")
    work = a.work or tempfile.mkdtemp(prefix="mocap-bench-")
    os.makedirs(work, exist_ok=True)
    free_gb = shutil.disk_usage(work).free / 1e9
    need_gb = 1.2 * (max(a.scales) + 1) if "scaling" in only else 2.5
    if free_gb < need_gb:
        sys.exit(f"bench/run.py: {work} has {free_gb:.1f} GB free, needs about {need_gb:.0f} GB")

    results = {"meta": {"date": datetime.datetime.now().isoformat(timespec="seconds"),
                        "command": os.environ.get("MOCAP_BENCH_COMMAND",
                                                  " ".join(["bench/run.py"] + sys.argv[1:])),
                        "runs": a.runs, "data": a.data, "machine": machine()}}
    keys = {"ingest": "ingest", "energy": "energy", "index": "index_build", "search": "search",
            "synth": "synth", "scaling": "scaling"}
    # Where each stage's figures come from: this run, or (stages not re-run,
    # kept from the previous JSON) the run that measured them.
    here = {"date": results["meta"]["date"], "commit": results["meta"]["machine"]["commit"],
            "command": results["meta"]["command"]}
    stages = {key: here for stage, key in keys.items() if stage in only}
    if os.path.exists(a.json):  # figures of stages not re-run this time are kept
        try:
            with open(a.json) as f:
                old = json.load(f)
            om = old.get("meta", {})
            before = {"date": om.get("date", "?"), "commit": om.get("machine", {}).get("commit", "?"),
                      "command": om.get("command", "?")}
            for stage, key in keys.items():
                if stage not in only and key in old:
                    results[key] = old[key]
                    stages[key] = om.get("stages", {}).get(key, before)
        except (OSError, ValueError):
            pass
    results["meta"]["stages"] = stages
    set2 = set2_dir(a.data)
    try:
        t0 = time.monotonic()
        if "ingest" in only:
            log("ingest: BVH parse benchmark")
            results["ingest"] = ingest(a)
        if "energy" in only:
            log("energy: benchmarks")
            results["energy"] = energy(a)
        index_path = os.path.join(work, "set2.h5")
        if "index" in only or "search" in only:
            log("index: set 2, --jobs 1 and 2")
            ib, index_path = index_stage(a, set2, work)
            if "index" in only:
                results["index_build"] = ib
        if "search" in only:
            log(f"search: {a.queries} queries x {a.runs} runs")
            results["search"] = search_stage(a, index_path, set2, work)
        if os.path.exists(index_path):
            os.remove(index_path)
        if "synth" in only:
            log("synth: A* vs slerp on set-1 gaps")
            results["synth"] = synth_stage(a, work)
        if "scaling" in only:
            results["scaling"] = scaling_stage(a, set2, work)
        results["meta"]["seconds"] = time.monotonic() - t0
        results["meta"]["load_average_at_end"] = os.getloadavg()[0]
    finally:
        if a.work is None:
            shutil.rmtree(work, ignore_errors=True)
    with open(a.json, "w") as f:
        json.dump(results, f, indent=1, sort_keys=True)
        f.write("\n")
    log(f"wrote {a.json}")


if __name__ == "__main__":
    main()
