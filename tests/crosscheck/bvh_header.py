"""The MOTION header of a BVH file, read independently of every importer.

Shared by the cross-check scripts (compare.py, and blender_fk.py inside
Blender's Python): Python 3 standard library only.
"""


def read_motion_header(path):
    """(frame_count, frame_time_s) from the 'Frames:' and 'Frame Time:' lines
    after MOTION; None for a value the file does not give. Reading stops at
    the 'Frame Time:' line."""
    frame_count = None
    frame_time = None
    with open(path, "r", encoding="utf-8", errors="replace") as f:
        in_motion = False
        for line in f:
            words = line.split()
            if not words:
                continue
            if words[0].upper() == "MOTION":
                in_motion = True
            elif in_motion and words[0].lower() == "frames:":
                frame_count = int(words[1])
            elif in_motion and words[0].lower() == "frame" and len(words) >= 3:
                frame_time = float(words[2])
                break
    return frame_count, frame_time
