#!/usr/bin/env python3
"""Interleaved A/B comparison of mocap-search builds on one query batch (stdlib only).

    bench/search_ab.py [--runs N] [--mode exact|approx|brute] [--threads T]
                       INDEX.h5 QUERIES.jsonl [NAME=VALUE,...,]BINARY ...

Each BINARY (optionally preceded by environment settings NAME=VALUE, comma
separated, e.g. `MOCAP_X=1,build/search/mocap-search`) answers the batch N
times (default 3), the binaries taking turns, so a slow phase of a shared
machine hits them alike. Per binary it prints the sum over queries of each
query's fastest time (the least disturbed estimate) and of its median time
(`stats.time_ms`, the query alone, not opening the index), the frames
evaluated, the peak resident memory, and whether every binary returned the
same rankings as the first. Exit status 1 when the rankings differ. A batch
with relative and world queries (bench/search_queries.py's) is answered as
two batches, one per mode (builds older than 2026-11-26 corrupted their heap
on a mixed batch in exact mode; BVH paths must then be absolute); times and frames are
summed, the peak memory is the larger.

With --vs-brute, each round also runs the first binary in brute mode, and
each binary's line gives its speed-up over brute as the ratio of the sums of
each query's fastest time (the rankings are compared with brute's too).
"""
import argparse, json, os, statistics, subprocess, sys, tempfile

ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
ap.add_argument("--runs", type=int, default=3)
ap.add_argument("--mode", default="exact")
ap.add_argument("--threads", type=int, default=1)
ap.add_argument("--vs-brute", action="store_true", help="also time brute mode (first binary)")
ap.add_argument("index")
ap.add_argument("queries")
ap.add_argument("specs", nargs="+", metavar="[NAME=VALUE,...,]BINARY")
a = ap.parse_args()

BRUTE = "brute"
# (binary spec, mode, name of its figures)
runs_of = [(s, a.mode, s) for s in a.specs] + ([(a.specs[0], "brute", BRUTE)] if a.vs_brute else [])
times = {name: {} for name in a.specs + ([BRUTE] if a.vs_brute else [])}
evaluated, rss, rankings = {}, {}, {}
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "out.jsonl")
    lines = [line for line in open(a.queries) if line.strip()]
    by_mode = [[line for line in lines if json.loads(line).get("relative", False) == rel] for rel in (True, False)]
    parts = [a.queries]  # a mixed batch: its relative queries, then the others
    if all(by_mode):
        parts = [os.path.join(tmp, f"queries-{i}.jsonl") for i in range(2)]
        for path, part in zip(parts, by_mode):
            with open(path, "w") as fh:
                fh.writelines(part)
    for _ in range(a.runs):
        for spec, mode, s in runs_of:
            *settings, exe = spec.split(",")
            env = dict(os.environ)
            for kv in settings:
                k, v = kv.split("=", 1)
                env[k] = v
            rows, rss[s] = [], 0
            for part in parts:
                p = subprocess.run(["/usr/bin/time", "-f", "%M", exe, "--index", a.index, "-q",
                                    "--queries", part, "--mode", mode, "--threads",
                                    str(a.threads), "--out", out], env=env, capture_output=True, text=True)
                if p.returncode not in (0, 1):  # 1: some queries failed (reported on their lines)
                    sys.exit(f"{exe} failed ({p.returncode}): {p.stderr[-2000:]}")
                rss[s] = max(rss[s], int(p.stderr.strip().splitlines()[-1]))
                rows += [json.loads(line) for line in open(out)]
            for r in rows:
                if "stats" in r:
                    times[s].setdefault(r["id"], []).append(r["stats"]["time_ms"])
            evaluated[s] = sum(r["stats"]["frames_evaluated"] for r in rows if "stats" in r)
            rankings[s] = [[(x["clip_index"], x["start_frame"], x["end_frame"]) for p in r.get("pairs", [])
                            for x in p["results"]] for r in rows]
same = all(rankings[s] == rankings[a.specs[0]] for s in times)
fastest = {s: sum(min(v) for v in times[s].values()) for s in times}
for s in times:
    t = times[s]
    vs = f", {fastest[BRUTE] / fastest[s]:.1f}x brute" if a.vs_brute and s != BRUTE else ""
    print(f"{s}: sum of fastest {fastest[s]:.0f} ms{vs}, "
          f"sum of medians {sum(statistics.median(v) for v in t.values()):.0f} ms, "
          f"frames evaluated {evaluated[s]}, peak RSS {rss[s] / 1024:.0f} MB")
print(f"same rankings: {same}")
sys.exit(0 if same else 1)
