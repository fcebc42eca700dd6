#pragma once
// A motion written in the format its output path names (`--out` of
// `mocap-synth` and `mocap-search export`; docs/cli.md "Motion formats"):
//
//  - .glb: glTF 2.0 binary, metres, +Y up (the engine's axes). One node per
//    joint, named after it, the tree as children; each node's translation is
//    the joint's rest OFFSET and its rotation the identity. One skin lists
//    every joint (inverse bind matrices of that rest pose) and no mesh uses
//    it: Blender makes an armature of it, three.js Bones (a clip of several
//    ROOTs gets no skin: a skin's joints share one root). One animation,
//    "motion": per joint a rotation channel (local unit quaternions x, y, z,
//    w, signs made continuous), and per joint with position channels (the
//    root) a translation channel; one LINEAR sampler per channel, keyframe
//    times f * frame_time_s seconds (float32).
//  - .npz: NumPy arrays (npz.hpp), C order, float64 unless said:
//      positions     (F, J, 3)  world joint origins, metres, +Y up
//      rotations     (F, J, 4)  local rotations (from the parent) as unit
//                               quaternions x, y, z, w (w LAST: scipy's
//                               Rotation.from_quat and glTF's order)
//      translations  (F, J, 3)  local translations (from the parent), metres:
//                               world = parent world * T(translation) * R(rotation)
//      names         (J,)       joint names (numpy str)
//      parents       (J,)       int32 parent index, -1 for a root; < own index
//      fps           ()         frames per second, 1 / frame_time_s
//  - anything else: BVH (write_bvh_file), as the clip holds it (its own
//    length unit).
//
// The clip must be Y up, as every clip of an index is (units.hpp: a Z-up file
// is rotated when indexed); its axes are written as they are. Joints are the
// clip's, in its order. glTF and npz take the clip's poses by
// the engine's forward kinematics (clip_motion_from_raw, kinematics.hpp:
// position channels replace the OFFSET), so their world positions are those
// of the BVH read back by `mocap-index inspect`.
#include <filesystem>
#include <string>

#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/util/output_path.hpp"

namespace mocap {

enum class MotionFormat { bvh, glb, npz };

/// By the path's extension, case-insensitive: ".glb" glb, ".npz" npz, any
/// other (or none) bvh.
MotionFormat motion_format(const std::filesystem::path& path);
/// "BVH", "glTF binary", "NumPy .npz".
const char* motion_format_name(MotionFormat format);
/// The output kind (output_path.hpp) a motion file of that format is.
OutputKind motion_output_kind(MotionFormat format);

/// The .glb bytes of a clip whose file unit is `scale_m` metres. A clip of a
/// broken shape throws as write_bvh does; a clip with no frames, a
/// non-finite value, or a frame time that is not positive and finite throws
/// InputError(clip.source, 0, ...); scale_m not positive and finite throws
/// std::invalid_argument.
std::string motion_glb(const RawClip& clip, double scale_m);
/// The .npz bytes of a clip (same checks as motion_glb).
std::string motion_npz(const RawClip& clip, double scale_m);

/// Writes the clip to `path` in motion_format(path): BVH with write_bvh_file,
/// glb and npz through write_file_atomically (atomic_file.hpp). `path` is
/// the one to replace (checked_output_path's answer for
/// motion_output_kind(motion_format(path))). Throws as the functions above,
/// and InputError(path, 0, ...) when the file cannot be written.
void write_motion_file(const RawClip& clip, double scale_m, const std::filesystem::path& path);

}  // namespace mocap
