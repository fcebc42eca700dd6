"""Independent reference for our glTF output: Blender's own glTF importer, headless.

    blender -b --factory-startup --python-exit-code 1 \
        -P tests/crosscheck/blender_gltf.py -- FILE.glb FRAME... [--out PATH]

Prints (or writes to PATH) one JSON object, as blender_fk.py does:
    {"reference": "Blender <version> io_scene_gltf2 <version>", "file": ...,
     "frame_count": N, "frame_time_s": T, "units": "m",
     "parents": {"<joint>": "<parent joint>" or null, ...},
     "frames": {"<frame>": {"<joint>": [x, y, z], ...}, ...}}
World joint origins (pose-bone heads) in metres, in glTF's axes (+Y up):
Blender's importer turns +Y up into its +Z up, (x, y, z) -> (x, -z, y); the
inverse is applied here. FRAME is 0-based; negative values count from the
end (-1 = last frame). On stdout the JSON is the last line.

The importer keys an animation at Blender frames time * fps (scene.render.fps
/ fps_base). The scene's rate is set to the file's (its keyframe times:
frame_time = last time / (count - 1)) before the import, so keyframe f lands
on Blender frame f, which is what frame_set(f) evaluates. The file's skin
lists every joint, so the joints import as the bones of one armature; their
heads are the joints' world origins whatever rest orientation the importer
gives the bones (its bone heuristic).
"""

import json
import struct
import sys

import addon_utils
import bpy


def usage(message):
    sys.stderr.write(f"blender_gltf.py: {message}\n"
                     "usage: blender -b -P blender_gltf.py -- FILE.glb FRAME... [--out PATH]\n")
    sys.exit(2)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out, positional = None, []
    i = 0
    while i < len(argv):
        if argv[i] == "--out":
            if i + 1 >= len(argv):
                usage("--out needs a path")
            out = argv[i + 1]
            i += 2
            continue
        positional.append(argv[i])
        i += 1
    if len(positional) < 2:
        usage("need a .glb file and at least one frame")
    try:
        frames = [int(s) for s in positional[1:]]
    except ValueError:
        usage("frames must be integers")
    return positional[0], frames, out


def keyframe_times(path):
    """The first animation sampler's input: (count, last time), read from the
    .glb's JSON chunk (the accessor's count and max)."""
    with open(path, "rb") as f:
        data = f.read()
    magic, version, _ = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2:
        raise SystemExit(f"{path}: not a glTF 2.0 binary")
    length, _ = struct.unpack_from("<II", data, 12)
    doc = json.loads(data[20:20 + length])
    sampler = doc["animations"][0]["samplers"][0]
    accessor = doc["accessors"][sampler["input"]]
    return accessor["count"], accessor["max"][0]


def importer_version():
    for mod in addon_utils.modules():
        if mod.__name__ == "io_scene_gltf2":
            return ".".join(str(v) for v in mod.bl_info.get("version", ()))
    return "?"


def main():
    path, requested, out = parse_args()
    count, last_time = keyframe_times(path)
    frame_time = last_time / (count - 1) if count > 1 else 1.0 / 30.0
    scene = bpy.context.scene
    fps = max(1, round(1.0 / frame_time))
    scene.render.fps = fps
    scene.render.fps_base = fps * frame_time
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    bpy.ops.import_scene.gltf(filepath=path)
    armatures = [o for o in scene.objects if o.type == "ARMATURE"]
    if len(armatures) != 1:
        raise SystemExit(f"{path}: {len(armatures)} armatures imported, expected 1")
    arm = armatures[0]
    parents = {b.name: (b.parent.name if b.parent else None) for b in arm.data.bones}
    frames = {}
    for f in requested:
        frame = count + f if f < 0 else f
        if not 0 <= frame < count:
            usage(f"frame {f} out of range (file has {count})")
        scene.frame_set(frame)
        joints = {}
        for pb in arm.pose.bones:
            x, y, z = arm.matrix_world @ pb.head
            joints[pb.name] = [x, z, -y]
        frames[str(frame)] = joints
    result = {
        "reference": f"Blender {bpy.app.version_string} io_scene_gltf2 {importer_version()}",
        "file": path, "frame_count": count, "frame_time_s": frame_time, "units": "m",
        "parents": parents, "frames": frames,
    }
    text = json.dumps(result)
    if out:
        with open(out, "w") as f:
            f.write(text + "\n")
    else:
        print(text)


main()
