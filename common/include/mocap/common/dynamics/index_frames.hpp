#pragma once
// The per-frame arrays of an index (docs/index-format.md
// "/skeletons/<k>/frames", "Versions") from a clip's dynamics. The build
// stores float32 local rotations and joint positions, computes the clip's
// dynamics from those stored rows (clip_dynamics_from_rows) and from them
// its kd features, bounds, energy prefix sums and (schema 2) h scan values
// (derived_frame_rows). A reader derives the arrays the file does not store
// (kIndexDerivedFrameFields: world rotations, segment COMs and their
// velocities, angular velocities; from schema 3 also h_scan and kd_features)
// the same way, so a schema-3 reader's h scan and kd features are bit for
// bit those the build made its bounds from. Changing the arithmetic of this
// derivation (clip_dynamics_from_rows, compute_clip_dynamics, kd_feature,
// h_scan_row) changes what readers derive from schema-3 files already
// built: keep it bit for bit, or bump the schema version.
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

/// Frames as an index stores them: each local rotation (w, x, y, z) with
/// w >= 0 and each joint position, rounded to float32, into `local_out`
/// (count x 4) and `positions_out` (count x 3), count = local.size() =
/// positions.size() (std::invalid_argument otherwise).
void stored_rows(std::span<const Eigen::Quaterniond> local,
                 std::span<const Eigen::Vector3d> positions, float* local_out,
                 float* positions_out);

/// The dynamics of frames given in double precision as an index holds them:
/// stored_rows, then clip_dynamics_from_rows. A query frame taken from a
/// file (with its neighbours) then has bit for bit the state of that frame
/// in an index built from the file, so self-retrieval scores 0. `local` and
/// `positions` hold frame_count x J values (J = model.parents.size()).
ClipDynamics clip_dynamics_as_stored(const DynamicsModel& model, std::size_t frame_count,
                                     double frame_time_s, std::span<const Eigen::Quaterniond> local,
                                     std::span<const Eigen::Vector3d> positions);

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
