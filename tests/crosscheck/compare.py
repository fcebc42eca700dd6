#!/usr/bin/env python3
"""Cross-check our forward kinematics against independent BVH importers.

    compare.py --bin BUILD/indexer/mocap-index --ref blender [--ref three]
               [--unit U] [--tol 1e-4] [--random K] [--seed S] [--frames F...]
               FILE.bvh...

For every file: sample frames (0, the middle, the last, and K random ones from
a fixed seed), run `mocap-index inspect FILE --frame N [--unit U] --json` per
frame, run each reference once for all sampled frames (tests/crosscheck/
blender_fk.py under `blender -b`, tests/crosscheck/three_fk.mjs under node),
and compare world joint positions joint by joint (matched by name; the parent
names must match too). References report file units; they are converted with
the unit_scale_m that our JSON reports, so the error is in metres. References
keep the file's axes; when our JSON reports "up": "z" (a Z-up file, which we
rotate to Y up), their positions get the same rotation, (x, y, z) -> (x, z, -y),
before the comparison (docs/crosscheck.md).
Without --bin, the references are compared with each other (needs two --ref).

Prints one row per (file, reference) and exits 1 if any error exceeds --tol
(metres), 2 if a tool fails or the joint sets differ. Python 3 stdlib only.
"""

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile

from bvh_header import read_motion_header

HERE = os.path.dirname(os.path.abspath(__file__))


class ToolError(Exception):
    pass


def run(cmd, what):
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, check=False)
    except OSError as e:
        raise ToolError("%s: cannot run %s: %s" % (what, cmd[0], e)) from e
    if p.returncode != 0:
        tail = "\n".join((p.stderr or p.stdout).strip().splitlines()[-15:])
        raise ToolError("%s failed (exit %d): %s\n%s" % (what, p.returncode, " ".join(cmd), tail))
    return p.stdout


def header_frame_count(path):
    """'Frames:' from the MOTION header (only used when --bin is absent)."""
    frame_count, _ = read_motion_header(path)
    if frame_count is None:
        raise ToolError("%s: no 'Frames:' line" % path)
    return frame_count


def sample_frames(path, count, n_random, seed, explicit):
    if explicit:
        frames = [f if f >= 0 else count + f for f in explicit]
    else:
        frames = [0, count // 2, count - 1]
        rng = random.Random("%d:%s" % (seed, os.path.basename(path)))
        if count > 3:
            frames += [rng.randrange(count) for _ in range(n_random)]
    frames = sorted(set(frames))
    bad = [f for f in frames if f < 0 or f >= count]
    if bad:
        raise ToolError("%s: frames %s out of range (file has %d)" % (path, bad, count))
    return frames


def ours(binary, path, frame, unit):
    cmd = [binary, "inspect", path, "--frame", str(frame)]
    if unit:
        cmd += ["--unit", unit]
    cmd.append("--json")
    out = json.loads(run(cmd, "mocap-index inspect"))
    joints = out["joints"]
    names = [j["name"] for j in joints]
    positions = {j["name"]: j["position_m"] for j in joints}
    parents = {j["name"]: (names[j["parent"]] if j["parent"] >= 0 else None) for j in joints}
    if len(positions) != len(joints):
        raise ToolError("%s: duplicate joint names in our output" % path)
    return out, positions, parents


def reference(kind, path, frames, args):
    with tempfile.TemporaryDirectory(prefix="mocap-xcheck-") as tmp:
        out_path = os.path.join(tmp, "ref.json")
        frame_args = [str(f) for f in frames]
        if kind == "blender":
            cmd = [args.blender, "-b", "--factory-startup", "--python-exit-code", "1",
                   "-P", os.path.join(HERE, "blender_fk.py"), "--", path] + frame_args + ["--out", out_path]
        else:
            cmd = [args.node, os.path.join(HERE, "three_fk.mjs"), path] + frame_args + ["--out", out_path]
        run(cmd, kind)
        with open(out_path, "r", encoding="utf-8") as f:
            return json.load(f)


def compare_sets(label, path, a_names, b_names, a_label, b_label):
    only_a = sorted(set(a_names) - set(b_names))
    only_b = sorted(set(b_names) - set(a_names))
    if only_a or only_b:
        raise ToolError("%s: %s: joints only in %s: %s; only in %s: %s"
                        % (label, path, a_label, only_a, b_label, only_b))


def check_parents(label, path, a, b, a_label, b_label):
    wrong = sorted(n for n in a if a[n] != b.get(n))
    if wrong:
        raise ToolError("%s: %s: parents differ between %s and %s for %s"
                        % (label, path, a_label, b_label,
                           ", ".join("%s (%s vs %s)" % (n, a[n], b.get(n)) for n in wrong[:5])))


def rotate_z_up_to_y_up(frames):
    """Our Z-up normalisation applied to a reference's frames: (x, y, z) -> (x, z, -y)."""
    return {f: {n: [p[0], p[2], -p[1]] for n, p in joints.items()} for f, joints in frames.items()}


def max_error(a, b, scale_a, scale_b):
    """(max distance, joint) over joints; a, b: name -> [x, y, z]."""
    worst = (0.0, None)
    for name, pa in a.items():
        pb = b[name]
        d = math.sqrt(sum((scale_a * x - scale_b * y) ** 2 for x, y in zip(pa, pb)))
        if not math.isfinite(d):
            d = math.inf
        if d > worst[0] or worst[1] is None:
            worst = (d, name)
    return worst


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", metavar="FILE.bvh")
    ap.add_argument("--bin", help="mocap-index binary (omit to compare the references with each other)")
    ap.add_argument("--ref", action="append", choices=["blender", "three"], required=True,
                    help="reference implementation (repeatable)")
    ap.add_argument("--unit", help="passed to mocap-index as --unit (default: its detection)")
    ap.add_argument("--ref-scale", type=float,
                    help="metres per file unit for references when --bin is absent (default 1)")
    ap.add_argument("--tol", type=float, default=1e-4, help="max allowed error in metres (default 1e-4)")
    ap.add_argument("--random", type=int, default=4, help="random frames per file (default 4)")
    ap.add_argument("--seed", type=int, default=20240531, help="seed for the random frames")
    ap.add_argument("--frames", type=int, nargs="+", help="exact frames instead of the sampling")
    ap.add_argument("--blender", default=os.environ.get("BLENDER", "blender"))
    ap.add_argument("--node", default=os.environ.get("NODE", "node"))
    args = ap.parse_args()
    if not args.bin and len(args.ref) < 2:
        ap.error("without --bin, give two --ref to compare the references with each other")

    rows = []
    failed = False
    try:
        for path in args.files:
            if args.bin:
                first, _, _ = ours(args.bin, path, 0, args.unit)
                count = int(first["frames"])
                scale = float(first["unit_scale_m"])
                up = first.get("up", "y")
            else:
                count = header_frame_count(path)
                scale = args.ref_scale if args.ref_scale else 1.0
                up = "y"
            frames = sample_frames(path, count, args.random, args.seed, args.frames)
            refs = {kind: reference(kind, path, frames, args) for kind in dict.fromkeys(args.ref)}
            for kind, ref in refs.items():
                if int(ref["frame_count"]) != count:
                    raise ToolError("%s: %s reports %s frames, expected %d" % (path, kind, ref["frame_count"], count))

            if args.bin:
                pairs = [("ours", kind) for kind in refs]
                ours_frames = {}
                ours_parents = None
                for f in frames:
                    _, pos, par = ours(args.bin, path, f, args.unit)
                    ours_frames[str(f)] = pos
                    ours_parents = par
                sources = {"ours": (ours_frames, ours_parents, 1.0)}
            else:
                kinds = list(refs)
                pairs = [(kinds[0], k) for k in kinds[1:]]
                sources = {}
            for kind, ref in refs.items():
                ref_frames = rotate_z_up_to_y_up(ref["frames"]) if up == "z" else ref["frames"]
                sources[kind] = (ref_frames, ref["parents"], scale)

            for a_label, b_label in pairs:
                a_frames, a_parents, a_scale = sources[a_label]
                b_frames, b_parents, b_scale = sources[b_label]
                compare_sets("joints", path, a_parents, b_parents, a_label, b_label)
                check_parents("hierarchy", path, a_parents, b_parents, a_label, b_label)
                worst = (0.0, None, None)
                for f in frames:
                    a, b = a_frames[str(f)], b_frames[str(f)]
                    compare_sets("frame %d" % f, path, a, b, a_label, b_label)
                    err, joint = max_error(a, b, a_scale, b_scale)
                    if err > worst[0] or worst[1] is None:
                        worst = (err, joint, f)
                ok = worst[0] <= args.tol
                failed = failed or not ok
                rows.append((os.path.basename(path), "%s vs %s" % (a_label, b_label), len(frames),
                             len(a_parents), scale, up, worst[0], "%s@%d" % (worst[1], worst[2]),
                             "ok" if ok else "FAIL"))
    except ToolError as e:
        print_table(rows)
        print("error: %s" % e, file=sys.stderr)
        return 2
    print_table(rows)
    if failed:
        print("FAIL: error above %.1e m" % args.tol, file=sys.stderr)
        return 1
    return 0


def print_table(rows):
    if not rows:
        return
    head = ("file", "compared", "frames", "joints", "m/unit", "up", "max error m", "worst joint@frame", "")
    cells = [head] + [(r[0], r[1], str(r[2]), str(r[3]), "%g" % r[4], r[5], "%.3e" % r[6], r[7], r[8])
                      for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(head))]
    for c in cells:
        print("  ".join(x.ljust(w) for x, w in zip(c, widths)).rstrip())
    sys.stdout.flush()


if __name__ == "__main__":
    sys.exit(main())
