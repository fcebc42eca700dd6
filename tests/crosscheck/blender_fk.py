"""Independent forward-kinematics reference: Blender's own BVH importer, headless.

    blender -b --factory-startup --python-exit-code 1 \
        -P tests/crosscheck/blender_fk.py -- FILE.bvh FRAME... [--out PATH]

Prints (or writes to PATH) one JSON object:
    {"reference": "Blender <version> io_anim_bvh <version>", "file": ...,
     "frame_count": N, "frame_time_s": T, "units": "file",
     "parents": {"<joint>": "<parent joint>" or null, ...},
     "frames": {"<frame>": {"<joint>": [x, y, z], ...}, ...}}
World joint origins (pose-bone heads) in FILE units with the BVH axes kept.
FRAME is 0-based; negative values count from the end (-1 = last frame).
On stdout the JSON is the last line (Blender prints its own chatter before it).

Import settings (bpy.ops.import_anim.bvh):
  axis_forward='Y', axis_up='Z'  -> axis_conversion() is the identity, so the
                                    armature keeps the BVH axes (the default
                                    -Z/Y would rotate BVH Y-up into Blender Z-up);
  global_scale=1.0               -> file units;
  rotate_mode='NATIVE'           -> pose bones use the file's Euler order;
  use_fps_scale=False            -> BVH frame i is keyed at Blender frame
                                    frame_start + i (no resampling);
  update_scene_fps/duration=False, use_cyclic=False, target='ARMATURE',
  frame_start=1 (the importer's default; it clamps anything below 1 to 1).

The 'rU' workaround: Blender 3.4's importer (io_anim_bvh/import_bvh.py,
read_bvh) opens the file with open(file_path, 'rU'); Python 3.11 removed the
'U' mode and raises "ValueError: invalid mode: 'rU'". We do NOT touch
builtins.open: we inject a module-level `open` into io_anim_bvh.import_bvh
that drops 'U' from the mode (universal newlines are the Python 3 default for
text mode anyway) and otherwise calls builtins.open. Global name lookup inside
that module finds our wrapper before the builtin, so only the importer is
affected. On a Blender whose importer no longer uses 'U' the wrapper is inert.

Joints: every ROOT/JOINT becomes a bone named after the joint (the importer
joins multi-word names with '_'). End Sites make no bone (they only set the
tail). Zero-length bones (CMU LHipJoint/RHipJoint) get a lengthened tail, but
the head, i.e. the joint origin, is unchanged; we only read heads.

Semantics worth knowing (from import_bvh.py): position channels REPLACE the
OFFSET (pose location = channel value - rest head); a joint with only some
position axes gets 0 (not the OFFSET component) for the missing axes, and a
joint with only some rotation channels reads a wrong column (line[-1]) for the
missing ones -- so Blender is a reference only for joints with all three or
none of each kind, which holds for the CMU and Bandai Namco files.
"""

import builtins
import json
import os
import re
import sys

import bpy

# Blender does not put the script's folder on the module path.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bvh_header import read_motion_header  # noqa: E402


def _parse_args(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    out_path = None
    positional = []
    i = 0
    while i < len(args):
        if args[i] == "--out":
            if i + 1 >= len(args):
                raise SystemExit("blender_fk.py: --out needs a path")
            out_path = args[i + 1]
            i += 2
            continue
        positional.append(args[i])
        i += 1
    if len(positional) < 2:
        raise SystemExit("usage: blender -b --factory-startup --python-exit-code 1 -P blender_fk.py "
                         "-- FILE.bvh FRAME... [--out PATH]")
    frames = []
    for s in positional[1:]:
        if not re.fullmatch(r"-?\d+", s):
            raise SystemExit("blender_fk.py: not a frame number: %s" % s)
        frames.append(int(s))
    return positional[0], frames, out_path


def _open_without_universal_newlines(file, mode="r", *args, **kwargs):
    if isinstance(mode, str) and "U" in mode:
        mode = mode.replace("U", "") or "r"
    return builtins.open(file, mode, *args, **kwargs)


def main():
    path, requested, out_path = _parse_args(sys.argv)
    frame_count, frame_time = read_motion_header(path)  # read here, not by Blender

    bpy.ops.wm.read_factory_settings(use_empty=True)
    import addon_utils
    addon_utils.enable("io_anim_bvh", default_set=True)
    from io_anim_bvh import import_bvh
    import_bvh.open = _open_without_universal_newlines  # the 'rU' workaround, see above

    frame_start = 1
    before = set(bpy.data.objects)
    result = bpy.ops.import_anim.bvh(
        filepath=path,
        target='ARMATURE',
        global_scale=1.0,
        frame_start=frame_start,
        use_fps_scale=False,
        update_scene_fps=False,
        update_scene_duration=False,
        use_cyclic=False,
        rotate_mode='NATIVE',
        axis_forward='Y',
        axis_up='Z',
    )
    if result != {'FINISHED'}:
        raise SystemExit("blender_fk.py: import failed: %r" % (result,))
    new = [o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE']
    if len(new) != 1:
        raise SystemExit("blender_fk.py: expected one new armature, got %d" % len(new))
    arm = new[0]

    # Number of keyed frames = BVH frames (the importer keys frame i at frame_start + i).
    keyed = max((len(fc.keyframe_points) for fc in arm.animation_data.action.fcurves), default=0)
    if frame_count is not None and keyed != frame_count:
        raise SystemExit("blender_fk.py: Blender keyed %d frames, header says %d" % (keyed, frame_count))

    parents = {b.name: (b.parent.name if b.parent else None) for b in arm.pose.bones}
    scene = bpy.context.scene
    frames = {}
    for f in requested:
        frame = keyed + f if f < 0 else f
        if frame < 0 or frame >= keyed:
            raise SystemExit("blender_fk.py: frame %d out of range (file has %d)" % (f, keyed))
        scene.frame_set(frame_start + frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arm_eval = arm.evaluated_get(depsgraph)
        world = arm_eval.matrix_world
        joints = {}
        for pose_bone in arm_eval.pose.bones:
            head = world @ pose_bone.head
            joints[pose_bone.name] = [head.x, head.y, head.z]
        frames[str(frame)] = joints

    bvh_addon = sys.modules.get("io_anim_bvh")
    addon_version = ".".join(str(v) for v in bvh_addon.bl_info.get("version", ())) if bvh_addon else "?"
    out = {
        "reference": "Blender %s io_anim_bvh %s" % (bpy.app.version_string, addon_version),
        "file": path,
        "frame_count": keyed,
        "frame_time_s": frame_time,
        "units": "file",
        "parents": parents,
        "frames": frames,
    }
    text = json.dumps(out)
    if out_path is not None:
        with builtins.open(out_path, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    else:
        sys.stdout.write("\n" + text + "\n")
        sys.stdout.flush()


main()
