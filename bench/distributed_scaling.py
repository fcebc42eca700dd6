#!/usr/bin/env python3
"""Shards and ranks: build time, per-rank memory and batch throughput of 1x..8x set 2.

  bench/distributed_scaling.py --build DIR --data DIR [--work DIR]
        [--scales 1,2,4,8] [--shards 1,2,4] [--queries 60] [--json FILE]

For each scale k (k hard-linked copies of set 2, k x 384,931 frames; the
queries exclude every copy of their own clip, by file name) and each
shard count n: `mocap-index build` (n = 1) or `mocap-index build --shards n`
(wall time, peak RSS); then one batch of held-out relative queries
(bench/search_queries.py kinds rel-full-2 and rel-partial-2), one thread per
process, answered
  - by one process over the plain index (n = 1) or the manifest (n > 1),
  - by `mpirun -np 1` and by `mpirun -np 2` with --distribute shards (n > 1)
    and, when two copies of the whole collection fit in memory, queries;
each run's wall time (process start to exit, index loading included), the
search's own "answered in" time, queries per second and peak resident memory
per process (the greatest over the ranks). Every run's results are checked
against the one-process run on the plain index (the stats aside).

Writes the rows as JSON (--json) and a Markdown table on stdout; progress on
stderr. Needs about 1.1 GB of disk per copy and shard count at a time (each
scale's indexes are removed before the next), Open MPI (scripts/setup) and
GNU time. docs/performance.md "Shards and ranks" shows a run.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from run import HERE, log, machine, scaled_copies, set2_dir  # noqa: E402

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
KINDS = "rel-full-2,rel-partial-2"


def timed(cmd):
    """(stderr, wall_s, peak_rss_MB of the process or its largest child); raises on failure."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        t0 = time.monotonic()
        p = subprocess.run(["/usr/bin/time", "-v", "-o", tf.name] + cmd, text=True,
                           capture_output=True, env={**os.environ, **MPI_ENV})
        wall = time.monotonic() - t0
        if p.returncode not in (0, 1):
            raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr[-2000:]}")
        m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", tf.read())
    return p.stderr, wall, int(m.group(1)) / 1024.0 if m else 0.0


def same_results(a, b):
    def load(p):
        out = []
        for line in open(p):
            r = json.loads(line)
            r.pop("stats", None)
            out.append(r)
        return out
    return load(a) == load(b)


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", required=True)
    p.add_argument("--data", required=True)
    p.add_argument("--work", default=None)
    p.add_argument("--scales", default="1,2,4,8")
    p.add_argument("--shards", default="1,2,4")
    p.add_argument("--queries", type=int, default=60)
    p.add_argument("--json", default=None)
    a = p.parse_args()
    indexer = os.path.join(a.build, "indexer", "mocap-index")
    search = os.path.join(a.build, "search", "mocap-search")
    work = a.work or tempfile.mkdtemp(prefix="mocap-dist-")
    os.makedirs(work, exist_ok=True)
    set2 = set2_dir(a.data)
    queries = os.path.join(work, "queries.jsonl")
    with open(queries, "w") as f:
        f.write(subprocess.run([sys.executable, os.path.join(HERE, "search_queries.py"), set2,
                                str(a.queries), "5", KINDS], check=True, text=True,
                               capture_output=True).stdout)
    nq = sum(1 for _ in open(queries))
    memory_MB = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2**20
    rows = []
    for k in [int(x) for x in a.scales.split(",")]:
        coll = scaled_copies(set2, work, k)
        reference = None
        single_rss = None
        for n in [int(x) for x in a.shards.split(",")]:
            target = os.path.join(work, f"x{k}.h5") if n == 1 else os.path.join(
                work, f"x{k}-s{n}", "collection.json")
            log(f"{k}x, {n} shard(s): build")
            build = [indexer, "build", "-q", "--jobs", "2", "--out", target]
            _, build_s, build_rss = timed(build + (["--shards", str(n)] if n > 1 else []) + [coll])
            frames = 384931 * k
            runs = [("one process", [search])]
            runs.append(("mpirun -np 1", ["mpirun", "-np", "1", search]))
            if n > 1:
                runs.append(("mpirun -np 2, shards",
                             ["mpirun", "-np", "2", search, "--distribute", "shards"]))
            if single_rss and 2 * single_rss < 0.8 * memory_MB:
                runs.append(("mpirun -np 2, queries",
                             ["mpirun", "-np", "2", search, "--distribute", "queries"]))
            for label, cmd in runs:
                out = os.path.join(work, "r.jsonl")
                log(f"{k}x, {n} shard(s): {label}")
                err, wall, rss = timed(cmd + ["--index", target, "--queries", queries,
                                              "--threads", "1", "--out", out, "--force"])
                m = re.search(r"answered in ([0-9.]+) s", err)
                answered = float(m.group(1)) if m else None
                m = re.search(r"peak memory per rank (\d+)-(\d+) MB", err)
                rank_rss = float(m.group(2)) if m else rss
                if reference is None:
                    reference = os.path.join(work, f"ref{k}.jsonl")
                    shutil.copy(out, reference)
                if label == "one process" and n == 1:
                    single_rss = rank_rss
                rows.append({
                    "scale": k, "frames": frames, "shards": n, "run": label,
                    "build_wall_s": build_s, "build_peak_rss_MB": build_rss,
                    "wall_s": wall, "answered_s": answered, "queries": nq,
                    "queries_per_s": nq / wall, "peak_rss_per_rank_MB": rank_rss,
                    "rss_bytes_per_frame": rank_rss * 2**20 / frames,
                    "same_results": same_results(reference, out)})
                log(f"  {wall:.2f} s wall, answered in {answered} s, {rank_rss:.0f} MB per rank, "
                    f"same: {rows[-1]['same_results']}")
            if n == 1:
                os.remove(target)
            else:
                shutil.rmtree(os.path.dirname(target))
    result = {"machine": machine(), "queries": nq, "kinds": KINDS, "threads_per_rank": 1,
              "rows": rows}
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)
    print("| scale | frames | shards | build s | run | wall s | answered s | queries/s | "
          "peak MB per rank | B/frame | same |")
    print("|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r['scale']}x | {r['frames']:,} | {r['shards']} | {r['build_wall_s']:.1f} | "
              f"{r['run']} | {r['wall_s']:.2f} | {r['answered_s']} | {r['queries_per_s']:.1f} | "
              f"{r['peak_rss_per_rank_MB']:.0f} | {r['rss_bytes_per_frame']:.0f} | "
              f"{'yes' if r['same_results'] else 'NO'} |")


if __name__ == "__main__":
    main()
