#!/usr/bin/env python3
"""Generates a query batch for the search benchmark (stdlib only, seeded).

search_queries.py DATA_DIR COUNT SEED [KIND,...] > queries.jsonl

Queries describe users: key poses from elsewhere, so each query built from a
clip's frames excludes that clip with `"filter": {"exclude": [its file name]}`
(held out). Query i has kind KINDS[i % len(KINDS)] (or of the KINDS given),
written in its id as `q<i>-<kind>` (the query format refuses unknown fields):

  rel-{full,partial}-{2,3}    held out, "relative": true
  world-{full,partial}-{2,3}  held out, "relative": false
  self-full-2                 world mode, the clip not excluded (its frames
                              are in the index at h = 0: self-retrieval)

Every query states "relative" explicitly. Full: BVH frames of one random clip.
Partial, in turn: the root's ground position of BVH frames (`only`), a
hand-written root path (world: anywhere in a 6 m square; relative: from
[0, 0] in steps of at most 1.5 m, nothing held out), or one arm of BVH frames.
Query frames are 2 or 3 frames in time order spanning a window of 0.5-2 s
placed at random in the clip (any frame, not only the first/last).
"""
import json
import os
import random
import re
import sys

KINDS = [f"{m}-{f}-{h}" for m in ("rel", "world") for f in ("full", "partial") for h in (2, 3)] + ["self-full-2"]


def header(path):
    """(frame count, frame time s) from a BVH file's MOTION header."""
    n, dt = 0, 1.0 / 30.0
    with open(path) as fh:
        for line in fh:
            if line.startswith("Frames:"):
                n = int(line.split()[1])
            elif line.startswith("Frame Time:"):
                dt = float(line.split()[2])
                break
    return n, dt


def glob_literal(name):
    """A shell glob (fnmatch, as filter.exclude matches) for exactly `name`."""
    return re.sub(r"([*?\[\\])", r"\\\1", name)


def pick_frames(rng, n, dt, h):
    """h distinct frames in time order spanning a 0.5-2 s window (shorter in a
    shorter clip) at a random place in a clip of n frames: the window's first
    and last frame, and for h = 3 one frame between them."""
    if n < h:
        return list(range(h))  # too short: the search reports the bad frame
    w = max(h, min(n, int(round(rng.uniform(0.5, 2.0) / dt)) + 1))
    start = rng.randrange(n - w + 1)
    inner = sorted(rng.sample(range(1, w - 1), h - 2))
    return [start] + [start + f for f in inner] + [start + w - 1]


def main():
    data, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    kinds = sys.argv[4].split(",") if len(sys.argv) > 4 else KINDS
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        sys.exit(f"search_queries.py: unknown kind(s) {unknown}; expected some of {KINDS}")
    rng = random.Random(seed)
    files = sorted(os.path.join(r, f) for r, _, fs in os.walk(data) for f in fs if f.endswith(".bvh"))
    headers = {}
    partial_turn = {}
    for i in range(count):
        kind = kinds[i % len(kinds)]
        mode, frames_kind, h = kind.split("-")
        h = int(h)
        path = rng.choice(files)
        n, dt = headers.setdefault(path, header(path))
        picks = pick_frames(rng, n, dt, h)
        q = {"id": f"q{i}-{kind}", "relative": mode == "rel"}
        held_out = mode != "self"
        if frames_kind == "full":
            frames = [{"bvh": path, "frame": f} for f in picks]
        else:
            turn = partial_turn.get(mode, 0)
            partial_turn[mode] = turn + 1
            if turn % 3 == 0:
                frames = [{"bvh": path, "frame": f, "only": ["root_position_xz"]} for f in picks]
            elif turn % 3 == 1:
                held_out = False  # hand-written: no clip to hold out
                if mode == "rel":
                    x = z = 0.0
                    frames = [{"root_position": [0.0, None, 0.0]}]
                    for _ in range(h - 1):
                        x += rng.uniform(-1.5, 1.5)
                        z += rng.uniform(-1.5, 1.5)
                        frames.append({"root_position": [x, None, z]})
                else:
                    frames = [{"root_position": [rng.uniform(-3, 3), None, rng.uniform(-3, 3)]} for _ in range(h)]
            else:
                frames = [{"bvh": path, "frame": f, "only": ["RightUpperArm", "RightForeArm"]} for f in picks]
        q["frames"] = frames
        q["top"] = 10
        if held_out:
            q["filter"] = {"exclude": [glob_literal(os.path.basename(path))]}
        print(json.dumps(q))


if __name__ == "__main__":
    main()
