#!/usr/bin/env python3
"""Generates a query batch for the search benchmark (stdlib only).

search_queries.py DATA_DIR COUNT SEED > queries.jsonl
Half full-frame queries (BVH frames), half partial (root position on the
ground plane, + heading, or one arm's rotation, or BVH 'only'); two or three
query frames each, frames of one random clip in time order.
"""
import json, os, random, sys

data, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = random.Random(seed)
files = sorted(os.path.join(r, f) for r, _, fs in os.walk(data) for f in fs if f.endswith(".bvh"))
def frames_of(path):
    with open(path) as fh:
        for line in fh:
            if line.startswith("Frames:"):
                return int(line.split()[1])
    return 0
counts = {}
for i in range(count):
    path = rng.choice(files)
    n = counts.setdefault(path, frames_of(path))
    h = 2 if i % 4 < 2 else 3
    picks = sorted(rng.sample(range(n), h)) if n >= h else list(range(h))
    full = i % 2 == 0
    frames = []
    for k, f in enumerate(picks):
        if full:
            frames.append({"bvh": path, "frame": f})
        else:
            kind = (i // 2) % 3
            if kind == 0:
                frames.append({"bvh": path, "frame": f, "only": ["root_position_xz"]})
            elif kind == 1:
                frames.append({"root_position": [rng.uniform(-3, 3), None, rng.uniform(-3, 3)]})
            else:
                frames.append({"bvh": path, "frame": f, "only": ["RightUpperArm", "RightForeArm"]})
    print(json.dumps({"id": f"q{i}", "frames": frames, "top": 10}))
