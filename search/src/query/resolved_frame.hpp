#pragma once
// Internal to mocap_search: query frames resolved against one index skeleton,
// with what the engine precomputes for them (scan queries, kd features). The
// degrees of freedom themselves come from the public resolver
// (mocap/search/query_pose.hpp), which synthesis uses too.
#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/placement.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_pose.hpp"

namespace mocap::search_detail {

/// The public query-frame resolver's BVH cache (mocap/search/query_pose.hpp).
using LoadedBvh = QueryBvhFile;
using BvhCache = QueryBvhCache;

/// How a query frame is evaluated against database frames.
enum class FrameKind { full, root_only, partial };

/// A key pose's context on one side (docs/queries.md "Context frames"):
/// what the context energy compares a database frame's neighbours with.
struct FrameContext {
  /// `steps` rows of one body-frame segment COM velocity (m/s) per segment
  /// of the model (model.segments order): ResolvedQueryPose's
  /// context_before_mps or context_after_mps.
  std::vector<Eigen::Vector3d> rows;
  std::size_t steps = 0;
  /// The query file's frame time (s): row j is j of them from the key pose.
  double frame_time_s = 0.0;
  /// Before the key pose (its frame starts a pair: backward differences
  /// ending at F^s and earlier) or after it (it ends a pair: forward
  /// differences from F^e on).
  bool before = true;
  /// The multiplier of the context energy (QueryFrameSpec::context_weight).
  double weight = 1.0;
  /// Per segment: its mass (kg) times 1 where compared (a frame from
  /// another rig compares only its mapped segments), else 0.
  std::vector<double> masses_kg;
};

/// One query frame on one skeleton.
struct ResolvedFrame {
  FrameKind kind = FrameKind::partial;
  /// full: the state (with the file's velocities), its scan query, the
  /// translational kinetic energy of each segment (model.segments order).
  BodyState state;
  HScanQuery scan;
  std::vector<double> segment_ke_J;
  /// full: kd feature with the index's T (approx mode candidates).
  std::vector<float> kd;
  /// full, retargeted from another rig (ResolvedQueryPose::cross_rig): per
  /// joint, 1 where the segment is compared (the scan query's mask); empty:
  /// every segment. Such a frame has no box, sketch or relative bounds (they
  /// sum over every segment): it is scanned whole.
  std::vector<std::uint8_t> compared;
  /// root_only: scan query; partial: prepared partial query.
  HScanRootQuery root_scan;
  PartialQuery partial;
  /// World root (pelvis) position where known (full: the state's; otherwise
  /// the given components), metres; `given` says which axes constrain.
  Eigen::Vector3d root_m = Eigen::Vector3d::Zero();
  std::array<bool, 3> given{false, false, false};
  /// What placements read from the frame (mocap/search/placement.hpp).
  FrameRoot root;
  /// partial: the joints of a database frame that partial_approximate_energy
  /// reads (empty = all: whole-body queries) and those whose local
  /// translation it needs (the given subtrees); set by the engine.
  std::vector<int> need_joints, local_joints;
  /// partial with joint rotations only (no root position, no heading): the
  /// given subtrees prepared for the engine's subtree evaluation (set by the
  /// engine; empty otherwise). Joints in index order (parents first); the
  /// parent of the first ones is outside the subtrees (F's world pose).
  struct SubtreeJoint {
    std::size_t joint = 0, parent = 0;
    int parent_slot = -1;  // slot of the parent in `subtree`, -1 outside
    bool given = false;    // the query's local rotation, else F's
    Eigen::Quaterniond local = Eigen::Quaterniond::Identity();
    // The engine's per-joint columns of F's frame arrays (rows of the
    // skeleton's column stride): the parent's world rotation, the joint's
    // local rotation (null when given), position, and the parent's position.
    const float *parent_rot = nullptr, *lrot = nullptr, *pos = nullptr, *parent_pos = nullptr;
  };
  /// Segments of the subtrees (joints with mass), with their h-scan constants.
  struct SubtreeSegment {
    std::size_t slot = 0, segment = 0;  // joint slot; model.segments index
    double mg = 0.0, mh = 0.0;          // m g, m / (2 T^2)
    Eigen::Vector3d com_local = Eigen::Vector3d::Zero();
    Eigen::Quaterniond principal = Eigen::Quaterniond::Identity();
    std::array<double, 3> d{0.0, 0.0, 0.0};  // principal moments / (2 T^2)
  };
  std::vector<SubtreeJoint> subtree;
  std::vector<SubtreeSegment> subtree_segments;
  /// The frame's body-frame constraints, whether it is completed per
  /// database frame, its per-joint term weights and its weight
  /// (ResolvedQueryPose's fields of those names).
  std::vector<PoseConstraint> constraints;
  /// Database frames that miss one of the named constraints (verdict of
  /// ConstraintResidual: residual above max(tolerance, floor)) score +inf
  /// (evaluate_h): the pass of a ranking that wants met results only
  /// (QueryRunner::set_require_met, docs/queries.md "Residuals and
  /// verdicts"). Lower bounds stay bounds.
  bool require_met = false;
  bool solve = false;
  std::vector<double> joint_weights;
  double weight = 1.0;
  /// The query frame's ResolvedQueryPose as solve_given reads it (solve only).
  std::shared_ptr<const ResolvedQueryPose> pose;
  /// full frames with "context": each side's context (null: none given),
  /// shared by the frame's copies; `context` is the side the pair being
  /// searched reads (the runner sets it: before for Q^h, after for Q^h+1),
  /// null for none. evaluate_h adds its context energy to h.
  std::shared_ptr<const FrameContext> context_before, context_after;
  const FrameContext* context = nullptr;
  /// The query's style term per clip row of the skeleton (weighted, joules;
  /// docs/style.md "Asking for a style"), which evaluate_h adds where the
  /// frame starts the pair being searched (the runner sets it for Q^h);
  /// null: none.
  const double* style_rows = nullptr;
};

/// Resolves query frame `i` of `q` on skeleton `sk` with model `model`
/// (resolve_query_pose, then the engine's precomputation). Throws InputError ("frames[i]...: ...")
/// for unknown joints (listing the valid names), unreadable files, frames out of range, skeletons
/// of another rig that cannot be retargeted. `file`, `typical_pose`: as resolve_query_pose's.
ResolvedFrame resolve_frame(const Query& q, std::size_t i, const IndexSkeleton& sk,
                            const DynamicsModel& model, double transition_time_s,
                            double index_transition_time_s, BvhCache& cache,
                            const std::string& unit_option,
                            std::shared_ptr<const QueryBvhFile>* file = nullptr,
                            const TypicalPoseFn& typical_pose = {});

}  // namespace mocap::search_detail
