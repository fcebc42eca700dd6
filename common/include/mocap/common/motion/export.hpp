#pragma once
// Export of a partial motion: frames first..last (0-based, inclusive) of a
// clip of an index or of a collection's shards, as BVH in the clip's own
// skeleton, written as synthesis writes its output (motion_bvh_clip,
// skeleton_motion.hpp): the skeleton's joints, channels and OFFSETs,
// the clip's file units and frame time. Each frame is read from the index
// alone (the source file is not opened): its local rotations (clip_frame),
// and the translation of every joint with position channels at that frame,
// from the frame's joint origins and world rotations (so a joint above the
// pelvis that moves, Bandai Namco's joint_Root in a few takes, moves in the
// file too). Forward kinematics of the file gives the index's joint
// positions of those frames (its float precision: within 1e-5 m), so
// indexing the exported file again gives the source frames (docs/search.md
// "Export"). `mocap-search export` (docs/cli.md) runs it.
#include <cstddef>
#include <string>

#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/util/frame_range.hpp"

namespace mocap {

/// The clip (number in `clips`) named `name`: its path as the index stores
/// it (absolute, as built), that path given relative to the working folder,
/// any other path to the same file (through a symbolic link, "..", another
/// mount: compared by file identity, among clips of that file name), or its
/// file name alone. The stored path stays what results and errors show.
/// InputError(clips.path(), 0, ...) when no clip has that name (the message
/// lists up to five close names: file names within a small edit distance,
/// or containing `name`), or when several clips have that file name (it
/// lists their paths: give the full path).
std::size_t find_clip(const ClipSource& clips, const std::string& name);

/// The BVH clip of frames `range` of clip `clip` (a number in `clips`;
/// std::out_of_range otherwise; std::invalid_argument for first > last). A
/// range past the clip's end throws InputError(option, 0, ...) naming the
/// clip and its frame count (`option`: where the range came from, e.g.
/// "--frames"). Its RawClip::source reads "CLIP_PATH frames S-E".
RawClip partial_motion_clip(const ClipSource& clips, std::size_t clip, FrameRange range,
                            const std::string& option);

}  // namespace mocap
