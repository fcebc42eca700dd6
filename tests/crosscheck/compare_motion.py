#!/usr/bin/env python3
"""Cross-check one motion written in our three formats (.bvh, .glb, .npz).

    compare_motion.py --bin BUILD/indexer/mocap-index --bvh M.bvh [--unit U]
                      [--glb M.glb [--ref three] [--ref blender]] [--npz M.npz]
                      [--tol 1e-4] [--random K] [--seed S]

The reference is our forward kinematics of the BVH (`mocap-index inspect
M.bvh --frame N [--unit U] --json`, as compare.py) on sampled frames (0, the
middle, the last and K random ones from a fixed seed). Against it:
  --ref three    three.js GLTFLoader's world joint origins of M.glb
                 (tests/crosscheck/three_gltf.mjs under node);
  --ref blender  Blender's glTF importer's (tests/crosscheck/blender_gltf.py
                 under `blender -b`);
  --npz          the npz's `positions` (numpy's np.load), and its names,
                 parents and fps (1 / the BVH's frame time).
Joints are matched by name; parents must match. Everything is in metres,
+Y up. Prints one row per check; exits 1 if an error exceeds --tol, 2 if a
tool fails or the joint sets differ.
"""

import argparse
import json
import os
import random
import sys
import tempfile

from compare import ToolError, ours
from compare import run as run_tool

HERE = os.path.dirname(os.path.abspath(__file__))


def sampled(count, n_random, seed):
    frames = {0, count // 2, count - 1}
    rng = random.Random(seed)
    frames.update(rng.randrange(count) for _ in range(n_random if count > 3 else 0))
    return sorted(frames)


def run(cmd, what, blender):
    """compare.run; Blender without this interpreter's bin folder on PATH (a
    pyenv or virtual environment python3 puts it first, and Blender's Python
    then takes that installation for its own and misses Debian's numpy, which
    its glTF importer needs; scripts/blender-import does the same)."""
    prefix = os.path.realpath(sys.prefix)
    if not blender or prefix == "/usr":
        return run_tool(cmd, what)
    saved = os.environ["PATH"]
    os.environ["PATH"] = os.pathsep.join(
        p for p in saved.split(os.pathsep) if not os.path.realpath(p).startswith(prefix + os.sep))
    try:
        return run_tool(cmd, what)
    finally:
        os.environ["PATH"] = saved


def gltf_reference(kind, glb, frames, args):
    with tempfile.TemporaryDirectory(prefix="mocap-xcheck-") as tmp:
        out_path = os.path.join(tmp, "ref.json")
        frame_args = [str(f) for f in frames]
        if kind == "blender":
            cmd = [args.blender, "-b", "--factory-startup", "--python-exit-code", "1",
                   "-P", os.path.join(HERE, "blender_gltf.py"), "--", glb] + frame_args + [
                       "--out", out_path]
        else:
            cmd = [args.node, os.path.join(HERE, "three_gltf.mjs"), glb] + frame_args + [
                "--out", out_path]
        run(cmd, kind, kind == "blender")
        with open(out_path, "r", encoding="utf-8") as f:
            return json.load(f)


def npz_reference(path, frames, frame_time_s):
    """The npz as a reference: its positions on the frames, names, parents."""
    import numpy as np  # only this check needs numpy

    with np.load(path) as d:
        names = [str(n) for n in d["names"]]
        parents = {n: (names[p] if p >= 0 else None) for n, p in zip(names, d["parents"].tolist())}
        if abs(float(d["fps"]) * frame_time_s - 1.0) > 1e-9:
            raise ToolError("%s: fps %r is not 1 / %r" % (path, float(d["fps"]), frame_time_s))
        positions = d["positions"]
        rotations = d["rotations"]
        if positions.shape[1:] != (len(names), 3) or rotations.shape[:2] != positions.shape[:2]:
            raise ToolError("%s: shapes %s, %s" % (path, positions.shape, rotations.shape))
        norms = np.linalg.norm(rotations, axis=2)
        if np.abs(norms - 1.0).max() > 1e-9:
            raise ToolError("%s: rotations are not unit quaternions" % path)
        return {"reference": "numpy %s np.load" % np.__version__,
                "frame_count": positions.shape[0], "parents": parents,
                "frames": {str(f): {n: positions[f, j].tolist() for j, n in enumerate(names)}
                           for f in frames}}


def max_error(label, ours_frames, ours_parents, ref):
    """Largest distance (m) between our joints and the reference's, by name."""
    if set(ref["parents"]) != set(ours_parents) or ref["parents"] != ours_parents:
        missing = sorted(set(ours_parents) ^ set(ref["parents"]))
        raise ToolError("%s: joints or parents differ (%s)" % (label, missing or "parents"))
    worst = (0.0, None, None)
    for f, joints in ours_frames.items():
        for name, p in joints.items():
            q = ref["frames"][str(f)][name]
            e = sum((a - b) ** 2 for a, b in zip(p, q)) ** 0.5
            if e > worst[0]:
                worst = (e, f, name)
    return worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--bvh", required=True)
    ap.add_argument("--unit")
    ap.add_argument("--glb")
    ap.add_argument("--npz")
    ap.add_argument("--ref", action="append", default=[], choices=["three", "blender"])
    ap.add_argument("--tol", type=float, default=1e-4)
    ap.add_argument("--random", type=int, default=6)
    ap.add_argument("--seed", type=int, default=46)
    ap.add_argument("--blender", default=os.environ.get("BLENDER", "blender"))
    ap.add_argument("--node", default=os.environ.get("NODE", "node"))
    args = ap.parse_args()
    try:
        first, _, parents = ours(args.bin, args.bvh, 0, args.unit)
        frames = sampled(first["frames"], args.random, args.seed)
        ours_frames = {f: ours(args.bin, args.bvh, f, args.unit)[1] for f in frames}
        refs = [gltf_reference(k, args.glb, frames, args) for k in args.ref]
        if args.npz:
            refs.append(npz_reference(args.npz, frames, first["frame_time_s"]))
        failed = False
        for ref in refs:
            if ref["frame_count"] != first["frames"]:
                raise ToolError("%s: %d frames, the BVH has %d" % (
                    ref["reference"], ref["frame_count"], first["frames"]))
            e, f, name = max_error(ref["reference"], ours_frames, parents, ref)
            ok = e <= args.tol
            failed |= not ok
            print("%-4s %-45s frames %-28s max %.3g m%s" % (
                "ok" if ok else "FAIL", ref["reference"], ",".join(map(str, frames)), e,
                "" if ok else " (frame %s, %s)" % (f, name)))
        return 1 if failed else 0
    except ToolError as e:
        print("ERROR: %s" % e, file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
