#!/usr/bin/python3
"""Cross-rig retrieval: a CMU walk's best Bandai Namco matches against within-rig matches.

  bench/cross_rig.py --build DIR [--data DIR] [--index FILE] [--json FILE]

On an index of Bandai Namco set 1 and CMU subject 131 (built in a temporary
folder with `mocap-index build`, or --index), runs two-frame walk queries
0.5 s apart, held out (the query's own clip excluded), relative placement
(the default), and prints the best scores (J) and the top-5 content labels:

  cmu>bn   CMU 131_01 walk frames -> Bandai Namco clips  (across rigs)
  cmu>cmu  the same queries -> the other CMU clips       (within the CMU rig)
  bn>bn    Bandai Namco walk clips -> the other Bandai Namco clips (within)
  bn>bn-style  the same, every clip of the query's style held out (the
           other take of the same walk is a near copy; a CMU query has none)
  bn>cmu   the same queries -> the CMU clips             (across rigs)

and the ratios of the medians of the best scores: across rigs over within
rigs (docs/retrieval-quality.md "Across rigs"). Exits 1 when a query fails.
Debian's /usr/bin/python3; no packages beyond the standard library.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

# CMU 131_01 walks at about 1.3 m/s from frame 480 to 700 (120 fps): query
# frames there, each with the frame 0.5 s later.
CMU_WALK = [("131_01", f, 60) for f in (520, 560, 600, 640)]
# Bandai Namco forward walks (30 fps): a frame a third into the clip and the
# frame 0.5 s later.
BN_WALKS = ["walk_normal_001", "walk_active_001", "walk_happy_001", "walk_proud_001",
            "walk_tired_001", "walk_old_001", "walk_sad_001", "walk_angry_001"]
WALK_CONTENT = {"walk", "walk-left", "walk-right"}


def frame_count(path):
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("Frames:"):
                return int(line.split()[1])
    raise SystemExit(f"{path}: no 'Frames:' line")


def queries(data):
    bn = os.path.join(data, "bandai-namco-1", "data")
    out = []

    def add(kind, path, f, step, flt):
        out.append({"id": f"{kind}|{os.path.basename(path)}|{f}", "top": 5, "filter": flt,
                    "frames": [{"bvh": path, "frame": f}, {"bvh": path, "frame": f + step}]})

    for name, f, step in CMU_WALK:
        path = os.path.join(data, "cmu", name + ".bvh")
        add("cmu>bn", path, f, step, {"clips": ["dataset-1_*"], "exclude": [name + ".bvh"]})
        add("cmu>cmu", path, f, step, {"clips": ["131_*"], "exclude": [name + ".bvh"]})
    for name in BN_WALKS:
        path = os.path.join(bn, f"dataset-1_{name}.bvh")
        f = frame_count(path) // 3
        own = f"dataset-1_{name}.bvh"
        add("bn>bn", path, f, 15, {"clips": ["dataset-1_*"], "exclude": [own]})
        style = name.split("_")[1]
        add("bn>bn-style", path, f, 15,
            {"clips": ["dataset-1_*"], "exclude": [f"dataset-1_*_{style}_*"]})
        add("bn>cmu", path, f, 15, {"clips": ["131_*"], "exclude": [own]})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", required=True, help="build folder (indexer/, search/)")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..",
                                                   "shared", "data"))
    ap.add_argument("--index", help="an index of set 1 + CMU 131 (default: built here)")
    ap.add_argument("--json", help="write the scores and ratios here")
    a = ap.parse_args()
    data = os.path.abspath(a.data)
    search = os.path.join(a.build, "search", "mocap-search")
    with tempfile.TemporaryDirectory() as tmp:
        index = a.index
        if not index:
            index = os.path.join(tmp, "set1-cmu.h5")
            subprocess.run([os.path.join(a.build, "indexer", "mocap-index"), "build", "-q",
                            "--out", index, os.path.join(data, "bandai-namco-1"),
                            os.path.join(data, "cmu")], check=True, stdout=subprocess.DEVNULL)
        qs = queries(data)
        qfile, rfile = os.path.join(tmp, "q.jsonl"), os.path.join(tmp, "r.jsonl")
        with open(qfile, "w") as f:
            f.writelines(json.dumps(q) + "\n" for q in qs)
        subprocess.run([search, "--index", index, "--queries", qfile, "--out", rfile, "-q"],
                       check=False)
        results = [json.loads(line) for line in open(rfile)]
    best, rows, walks = {}, [], {}
    for r in results:
        if "error" in r:
            print(f"{r['id']}: {r['error']}", file=sys.stderr)
            return 1
        kind, clip, frame = r["id"].split("|")
        res = r["pairs"][0]["results"]
        labels = [x["labels"].get("content") or os.path.basename(x["clip"]) for x in res]
        best.setdefault(kind, []).append(res[0]["score_J"])
        if kind.endswith(">bn"):
            walks.setdefault(kind, []).extend(c in WALK_CONTENT for c in labels)
        rows.append((kind, clip, int(frame), res[0]["score_J"], labels))
    print(f"{'kind':11} {'query':30} {'frame':>5} {'best J':>7}  top 5")
    for kind, clip, frame, score, labels in rows:
        print(f"{kind:11} {clip:30} {frame:5d} {score:7.1f}  {', '.join(labels)}")
    med = {k: statistics.median(v) for k, v in best.items()}
    ratios = {
        "cmu>bn / bn>bn": med["cmu>bn"] / med["bn>bn"],
        "cmu>bn / bn>bn-style": med["cmu>bn"] / med["bn>bn-style"],
        "cmu>bn / cmu>cmu": med["cmu>bn"] / med["cmu>cmu"],
        "bn>cmu / cmu>cmu": med["bn>cmu"] / med["cmu>cmu"],
        "bn>cmu / bn>bn": med["bn>cmu"] / med["bn>bn"],
    }
    print()
    for k in ("cmu>bn", "cmu>cmu", "bn>bn", "bn>bn-style", "bn>cmu"):
        print(f"median best {k:11} {med[k]:7.1f} J   ({', '.join(f'{x:.1f}' for x in best[k])})")
    for k, v in ratios.items():
        print(f"ratio {k:22} {v:5.2f}")
    # The same CMU query across and within rigs.
    same = [x / y for x, y in zip(best["cmu>bn"], best["cmu>cmu"])]
    print(f"per CMU query, cmu>bn / cmu>cmu: {', '.join(f'{x:.2f}' for x in same)}")
    for k, v in walks.items():
        print(f"{k}: {sum(v)} of {len(v)} top-5 results are forward walks (walk, walk-left, "
              "walk-right)")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"best_J": best, "median_J": med, "ratios": ratios,
                       "cmu_query_ratios": same,
                       "walk_share": {k: sum(v) / len(v) for k, v in walks.items()}}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
