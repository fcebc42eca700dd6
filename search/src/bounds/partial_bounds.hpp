#pragma once
// Internal to mocap_search: per-frame lower bounds of h(Q_F -> F) for
// partial query frames (a heading, a root position with joint rotations,
// joint rotations; docs/search.md "Partial queries" proves them). A frame is
// first made into a plan (make_partial_bound_plan); a plan of joint
// rotations only also gets per-joint columns (attach_columns) and is then
// bounded in float, vectorised (partial_bounds_columns), else in double from
// the frame arrays (partial_frame_bounds_reference).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/io/index.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// What the bound of one partial query frame needs, precomputed per query.
struct PartialBoundPlan {
  bool whole = false;               // root position / heading given: every segment is static in Q_F
  std::vector<std::size_t> segs;    // affected segments (model.segments index)
  std::vector<double> rot_coef;     // per listed segment: 1/2 lambda_min / T^2 (slightly reduced)
  std::vector<std::uint8_t> turns;  // per listed segment: rotated by the heading turn
  std::vector<int> sub_slot;  // per listed segment: slot in sub_joints whose angle applies, -1
  bool heading = false;
  double psi_q = 0.0;
  // Joint-rotation subtrees (not whole-body): composite rotations per slot.
  std::vector<int> sub_joints, sub_parent_slot;
  std::vector<const Eigen::Quaterniond*> sub_given;  // the query's local rotation, null if F's
  // Per slot: the query's composite rotation and its squared norm when every
  // joint from the subtree's top down to the slot is given (the same for all
  // frames), else not fixed.
  std::vector<std::uint8_t> mq_fixed;
  std::vector<Eigen::Quaterniond> mq;
  std::vector<double> nq;
  // Per listed segment whose joint tops a given subtree (its parent is F's,
  // its rotation given): the parent joint, else -1; COM offset, m g, m / (2 T^2).
  // Its translational term is computed exactly (subtree_energy's arithmetic).
  std::vector<int> top_parent;
  std::vector<Eigen::Vector3d> top_com;
  std::vector<double> top_mg, top_mh;
  // Whole-body COM term (no joint rotations): root position components.
  bool com_term = false;
  std::array<bool, 3> given{false, false, false};
  Eigen::Vector3d root_q = Eigen::Vector3d::Zero();
  double mass = 0.0, gravity = 0.0, half_inv_t2 = 0.0;
  // Joint rotations only (not whole): the same bound in float from per-joint
  // columns (attach_columns, partial_bounds_columns); empty otherwise.
  struct ColumnSlot {
    // F's local rotation column of the slot's joint; null: not computed.
    const float* lrot = nullptr;
    int parent = -1;  // parent slot, -1 at the top of a subtree
    // The query's composite: 0 fixed (mq), 1 the parent's times the given
    // local rotation, 2 the parent's times F's.
    std::uint8_t mq_mode = 0;
    std::array<float, 4> given{};  // the given local rotation (w x y z), its squared norm
    float ngiven = 0.0f;
    std::array<float, 4> mq{};  // the fixed composite, its squared norm
    float nq = 0.0f;
  };
  struct ColumnSegment {
    const float *kb = nullptr, *kr = nullptr;  // scan-table fields 3 and 8
    float rot_coef = 0.0f;
    std::size_t slot = 0;
    // A subtree's top segment (its translational term): its parent's world
    // rotation column, the COM offset c and L_Q c (L_Q the given local
    // rotation), m g, m / (2 T^2).
    bool top = false;
    const float* parent_rot = nullptr;
    std::array<float, 3> c{}, lq_c{};
    float mg = 0.0f, mh = 0.0f;
  };
  std::vector<ColumnSlot> col_slots;
  std::vector<ColumnSegment> col_segs;
  std::size_t col_stride = 0;
};

// The plan of partial query frame q with transition time t (s).
PartialBoundPlan make_partial_bound_plan(const ResolvedFrame& q, const SkeletonTables& tables,
                                         double t);

// For a plan of joint rotations only: the columns and float constants
// partial_bounds_columns reads (the frame columns are streamed on first use:
// throws what the index read throws). Other plans are left as they are.
void attach_columns(PartialBoundPlan& p, const SkeletonData& skeleton, const Index& index);

// Lower bound of h(Q_F -> F) (J) for skeleton frames [g0, g1) into
// out[0, g1 - g0), in double from the frame arrays `fa` (frame_arrays; every
// kind of partial frame; the reference for the float column bound).
void partial_frame_bounds_reference(const PartialBoundPlan& p, const SkeletonTables& tables,
                                    const FrameArrays& fa, std::size_t g0, std::size_t g1,
                                    double* out, Scratch& scratch);

// The same from the columns where the plan has them (attach_columns), else
// the reference (fa: the frame arrays, needed then; may be null otherwise).
void partial_frame_bounds(const PartialBoundPlan& p, const SkeletonTables& tables,
                          const FrameArrays* fa, std::size_t g0, std::size_t g1, double* out,
                          Scratch& scratch);

}  // namespace mocap::search_detail
