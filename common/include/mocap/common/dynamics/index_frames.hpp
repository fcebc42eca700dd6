#pragma once
// The per-frame arrays of an index (docs/index-format.md
// "/skeletons/<k>/frames", "Versions") from a clip's dynamics. The build
// writes h_scan and kd_features from its double-precision dynamics of the
// file (derived_frame_rows); a reader of a schema-2 index derives the arrays
// the file does not store (kIndexDerivedFrameFields: world rotations,
// segment COMs and their velocities, angular velocities) from the stored
// float32 local rotations and joint positions (clip_dynamics_from_rows, then
// derived_frame_rows): within float precision of what schema 1 stored.
#include <cstddef>
#include <span>
#include <string_view>

#include "mocap/common/dynamics/dynamics.hpp"

namespace mocap {

/// One clip's rows of the stored arrays: frame_count frames of the model's
/// joints (J = model.parents.size()), frame-major.
struct StoredClipRows {
  /// Local rotations, (w, x, y, z) per joint, frame_count x J x 4.
  std::span<const float> local_rotations;
  /// World joint origins, metres, frame_count x J x 3.
  std::span<const float> joint_positions_m;
  std::size_t frame_count = 0;
  /// The clip's frame time, seconds (> 0 when frame_count > 1).
  double frame_time_s = 0.0;
};

/// The clip's dynamics from its stored rows: each local rotation widened to
/// double and normalised, world rotations composed down the skeleton
/// (R_j = R_parent(j) q_j, R_root = q_root), joint positions as stored, and
/// the rates of compute_clip_dynamics. std::invalid_argument when the spans
/// do not hold frame_count rows or frame_count is 0.
ClipDynamics clip_dynamics_from_rows(const DynamicsModel& model, const StoredClipRows& rows);

/// A frame field computed from a clip's dynamics (index.hpp kFrameFields),
/// in the schema's units and layout:
///   world_rotations                 J x 4, (w, x, y, z) with w >= 0
///   segment_com_m                   J x 3
///   segment_com_velocity_mps        J x 3
///   segment_angular_velocity_radps  J x 3
///   h_scan                          S x 9 (energy.hpp HScanTable values)
///   kd_features                     S x 3 (energy.hpp kd_feature at transition_time_s)
/// Writes dyn.frame_count rows of `field` into `out`. std::invalid_argument
/// for any other name.
void derived_frame_rows(const DynamicsModel& model, const ClipDynamics& dyn, std::string_view field,
                        double transition_time_s, float* out);

}  // namespace mocap
