#pragma once
// A clip's per-frame dynamics from the frame arrays an index stores
// (docs/index-format.md "/skeletons/<k>/frames", "Versions"): the local
// rotations and the joint positions, float32. The build derives every other
// per-frame array from them (world rotations, segment COMs and their
// velocities, angular velocities, the h scan values, the kd features, the
// clip's own energy), after rounding them to float32 as they are stored;
// a reader of a schema-2 index derives the arrays the file does not store
// (kIndexDerivedFrameFields) with the same functions from the same floats,
// so the values are the build's bit for bit and the stored bounds (kd boxes
// and the h scan's inputs) hold for them exactly.
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

/// The frame fields derived from the stored ones (index.hpp kFrameFields),
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

/// Whether derived_frame_rows derives `field`.
bool is_derived_frame_field(std::string_view field);

}  // namespace mocap
