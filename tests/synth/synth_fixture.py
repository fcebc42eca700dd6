#!/usr/bin/env python3
"""Writes the query and search-result files the synth CLI tests use.

Clip indices follow the index's order (clips sorted by path), for an index
built from DATA/bandai-namco-1 and DATA/cmu. Results files follow the search
output contract (docs/synthesis.md). Python 3 stdlib only.
"""
import argparse, glob, json, os

ap = argparse.ArgumentParser()
ap.add_argument("--index-data", required=True)
ap.add_argument("--out", required=True)
a = ap.parse_args()
d = a.index_data
paths = sorted(glob.glob(d + "/bandai-namco-1/data/*.bvh") + glob.glob(d + "/cmu/*.bvh"))
paths = [os.path.abspath(p) for p in paths]
idx = {os.path.basename(p): i for i, p in enumerate(paths)}
bn = os.path.abspath(d + "/bandai-namco-1/data")

def res(rank, name, s, e, score, folder=bn):
    return {"rank": rank, "clip": folder + "/" + name, "clip_index": idx[name], "labels": {},
            "start_frame": s, "end_frame": e, "score_J": score, "h_in_J": score / 2,
            "h_out_J": score / 2, "path_cost_J": 0.0}

query = {"id": "walk-run-turn", "relative": False, "top": 5, "frames": [
    {"bvh": bn + "/dataset-1_walk_normal_001.bvh", "frame": 10},
    {"bvh": bn + "/dataset-1_run_active_001.bvh", "frame": 40},
    {"root_heading_deg": 90, "joints": {"LeftArm": {"euler_deg": [0, 0, -60], "order": "XYZ"}}}]}
json.dump(query, open(a.out + "/query.json", "w"))
bad = dict(query)
bad["frames"] = query["frames"][:2] + [{"joints": {"NoSuchJoint": {"euler_deg": [0, 0, 0], "order": "XYZ"}}}]
json.dump(bad, open(a.out + "/bad-joint.json", "w"))

def line(pairs, qid="walk-run-turn"):
    return json.dumps({"id": qid, "pairs": pairs, "stats": {}}) + "\n"

pairs = [
    {"from": 0, "to": 1, "results": [res(1, "dataset-1_walk_normal_002.bvh", 5, 28, 120.0),
                                     res(2, "dataset-1_walk_active_001.bvh", 10, 50, 150.0)]},
    {"from": 1, "to": 2, "results": [res(1, "dataset-1_run_chimpira_001.bvh", 20, 60, 300.0),
                                     res(2, "dataset-1_walk-left_normal_001.bvh", 10, 60, 320.0)]}]
open(a.out + "/results.jsonl", "w").write(line([], "another-query") + line(pairs))
open(a.out + "/other-id.jsonl", "w").write(line(pairs, "not-this-one"))
unknown = json.loads(json.dumps(pairs))
unknown[0]["results"][0]["clip"] = bn + "/no_such_clip.bvh"
open(a.out + "/unknown-clip.jsonl", "w").write(line(unknown))
mix = json.loads(json.dumps(pairs))
mix[1]["results"][0] = res(1, "131_01.bvh", 10, 100, 300.0, os.path.abspath(d + "/cmu"))
open(a.out + "/cmu-mix.jsonl", "w").write(line(mix))
print(a.out)
