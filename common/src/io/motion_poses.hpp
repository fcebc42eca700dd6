#pragma once
// The poses the glTF and npz writers share (motion_file.hpp).
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/raw_clip.hpp"

namespace mocap::detail {

/// clip_motion_from_raw of a clip checked for writing: its shape (as
/// write_bvh), at least one frame, finite values, scale_m positive and finite
/// (motion_glb's contract, motion_file.hpp).
ClipMotion checked_motion(const RawClip& clip, double scale_m);

}  // namespace mocap::detail
