#pragma once
// The approximate energy change h (retrieval, paper eq. 1; docs/energy.md).
//
// Transition A -> B in time T: every segment b moves with the constant
// transition velocities u_b = (c_b(B) - c_b(A)) / T and
// w^_b = log(R_b(B) R_b(A)^T) / T. Each segment is alone: only gravity and its
// own inertia act on it. With the kinetic energies
//   K_A = 1/2 m |v_b(A)|^2,  K_u = 1/2 m |u_b|^2,  K_B = 1/2 m |v_b(B)|^2
//   (rotational: 1/2 w^T I_world w, I_world = R I_local R^T of that state)
// the per-segment terms (joules) are
//   h_b = |m g . (c_b(B) - c_b(A))| + dK(K_A, K_u, K_B)     ("segment" term)
//   h_j = dK(K_A^rot, K_w^^rot, K_B^rot)                     ("joint" term of joint j = b)
//   dK(K_A, K_u, K_B) = max(|K_B - K_A|, 2 K_u - K_A - K_B)
// dK is the least total variation of kinetic energy over any path from
// (c_A, v_A) to (c_B, v_B) of duration T (docs/energy.md derives it). It equals
// the start-plus-stop sum |K_u - K_A| + |K_B - K_u| whenever K_u >= min(K_A, K_B) (always
// when A or B is static) and drops only its "stop-and-go" charge
// 2 (min(K_A, K_B) - K_u) otherwise, which makes h(A, A) = 0 for moving states
// and makes segments that a partial query leaves alone cost nothing.
// h = sum_b h_b + sum_j h_j >= 0, symmetric in A and B.
//
// Three evaluations, which agree (tests):
//  - approximate_energy: the double-precision reference, with per-term output;
//  - partial_approximate_energy: partial query Q completed with frame F (Q_F),
//    touching only the joints the query moves;
//  - scan_approximate_energy: float32 structure-of-arrays scan over many frames
//    for one full query state (and scan_root_translation_energy for queries
//    that give only the root position).
// kd_feature gives the vector whose squared distance lower-bounds h for static
// queries (docs/energy.md proves it).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/body/ground_pose.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/h_scan_layout.hpp"

namespace mocap {

/// Per-joint energy terms, joules (index = joint; 0 where a joint has no term).
/// segment_J[j]: the term of segment j (translation: gravity work, kinetic
/// energy changes; in g also forces of adjacent segments and contact).
/// joint_J[j]: the term of joint j (rotation of its segment; in g also the
/// work of the torque transmitted through the joint).
struct EnergyTerms {
  std::vector<double> segment_J;
  std::vector<double> joint_J;
  /// Resizes to n joints and zeroes.
  void reset(std::size_t n);
  double total() const;
};

/// dK of the header: least total kinetic-energy variation from K_a through a
/// transition at K_u to K_b, joules.
inline double transition_kinetic_change(double k_a, double k_u, double k_b) {
  const double d = k_b - k_a;
  const double through = 2.0 * k_u - k_a - k_b;
  const double ad = d < 0.0 ? -d : d;
  return ad > through ? ad : through;
}

/// Reference h(A -> B) in joules; `transition_time_s` = T > 0 (throws
/// std::invalid_argument otherwise). Uses positions, rotations and velocities
/// of both states (accelerations are not needed). `terms` (optional) receives
/// h_b in segment_J and h_j in joint_J.
double approximate_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                          double transition_time_s, EnergyTerms* terms = nullptr);

namespace detail {
/// Throws std::invalid_argument unless 0 < t < infinity (seconds): the check
/// of every energy that takes a transition time (h, g, bounds, features).
void check_transition_time(double t);
}  // namespace detail

// ---------------------------------------------------------------------------
// Partial query frames

/// Which DOFs a partial query frame gives; everything else is taken from the
/// database frame F it is compared with (Q_F). All world frame, SI.
struct PartialPoseSpec {
  /// World position of the character's root joint origin (DynamicsModel::root(),
  /// the pelvis), per axis x, y, z; nullopt = not given.
  std::array<std::optional<double>, 3> root_position_m;
  /// Heading of the root (heading_rad(): twist about world +Y), radians.
  std::optional<double> root_heading_rad;
  /// Local rotations (relative to the parent joint) by joint index; they
  /// replace F's local rotation of that joint.
  std::vector<std::pair<int, Eigen::Quaterniond>> joint_rotations;
};

/// A prepared partial query: the spec plus the joints it moves.
struct PartialQuery {
  PartialPoseSpec spec;
  /// True when the root position or heading is given: the whole body moves.
  bool moves_whole_body = false;
  /// Joints whose world pose depends on a given DOF (subtrees of the given
  /// joints; all joints when moves_whole_body), in index order.
  std::vector<int> affected_joints;
  /// Per joint: 1 if affected.
  std::vector<std::uint8_t> affected;
  /// Joints under a given joint rotation (their world pose needs forward
  /// kinematics), in index order; a subset of affected_joints.
  std::vector<int> subtree_joints;
  /// Per joint: 1 if in subtree_joints.
  std::vector<std::uint8_t> in_subtree;
  /// Per joint: index into spec.joint_rotations, -1 if not given.
  std::vector<int> given_rotation;
  /// Per joint: 1 when an affected joint keeps F's rates instead of being
  /// static (joints moved only by body-frame constraints, which give a pose
  /// and no rates: pose_constraints.hpp); empty = none. Set by the caller
  /// after prepare_partial_query.
  std::vector<std::uint8_t> keep_rates;
};

/// Validates (joint indices in range and unique, quaternions finite and
/// non-zero, values finite; InputError("<query>", 0, ...) otherwise) and
/// prepares. Quaternions are normalised.
PartialQuery prepare_partial_query(const DynamicsModel& model, PartialPoseSpec spec);

/// A database frame with its local pose (ClipMotion's local arrays at frame f).
struct FrameRef {
  StateView state;                                        // world pose + rates (ClipDynamics)
  const Eigen::Vector3d* local_translations_m = nullptr;  // per joint, from the parent
  const Eigen::Quaterniond* local_rotations = nullptr;    // per joint, from the parent
};

/// Q_F: F's local pose with the given joint rotations replaced (forward
/// kinematics of the affected subtrees), then turned about the vertical
/// through the root to the given heading, then translated so that the root
/// has the given position components. Affected joints are static (the query
/// gives values, not rates: velocities and accelerations 0), but for those
/// PartialQuery::keep_rates marks; unaffected joints keep F's rates.
void complete_partial_query(const DynamicsModel& model, const PartialQuery& query,
                            const FrameRef& frame, BodyState& out);

/// h(Q_F -> F) (= h(F -> Q_F)), equal to approximate_energy on the completed
/// state but computing forward kinematics and terms only for affected joints
/// (the others contribute exactly 0). `scratch` is per-thread.
double partial_approximate_energy(const DynamicsModel& model, const PartialQuery& query,
                                  const FrameRef& frame, double transition_time_s,
                                  BodyState& scratch, EnergyTerms* terms = nullptr);

// ---------------------------------------------------------------------------
// kd-tree feature (static queries)

/// 3 x number of segments.
std::size_t kd_feature_dimension(const DynamicsModel& model);
/// f = (sqrt(m_b / 2) / T) c_b over model.segments, x y z each. For a static A
/// (v = w = 0) and any B, or any A and a static B:
///   |f(A) - f(B)|^2 = sum_b 1/2 m_b |c_b(B) - c_b(A)|^2 / T^2 <= h(A, B).
/// `out` has kd_feature_dimension() floats.
void kd_feature(const DynamicsModel& model, const StateView& state, double transition_time_s,
                float* out);

/// For queries giving only root position components: sqrt(M/2)/T times the
/// given components of the root position (M = total mass), one float per
/// given axis; the squared distance lower-bounds h(Q_F, F) (docs/energy.md).
void kd_root_feature(const DynamicsModel& model, const std::array<bool, 3>& axes,
                     const Eigen::Vector3d& root_m, double transition_time_s, float* out);

// ---------------------------------------------------------------------------
// Vectorised h over many frames (structure of arrays, float32)

/// Per-frame, per-segment values h needs, float32, frame-contiguous:
/// value(s, k, f) = values[(s * kFields + k) * stride + f] with the fields k
/// of HScanField (h_scan_layout.hpp): COM x y z (m), translational KE
/// 1/2 m |v|^2 (J), segment orientation in its principal axes q = R P
/// (w x y z), rotational KE 1/2 w^T I w (J); and root_positions[k * stride +
/// f] (root joint origin, k = x y z). Frames are whatever the caller
/// concatenated (e.g. all clips of an index).
struct HScanTable {
  static constexpr std::size_t kFields = HScanField::count;
  std::size_t frame_count = 0;
  /// Row length >= frame_count, a multiple of 16.
  std::size_t stride = 0;
  /// Number of segments (model.segments.size()).
  std::size_t segment_count = 0;
  std::vector<float> values;
  std::vector<float> root_positions;

  const float* field(std::size_t segment, std::size_t k) const {
    return values.data() + (segment * kFields + k) * stride;
  }
  /// The table as a view (below).
  struct HScanView view() const;
};

/// HScanTable's layout over storage kept elsewhere (one block of a larger
/// array, say): the same fields, rows of `stride` floats; read-only. The
/// root rows are `root_stride` floats apart (0: `stride`), so they may lie
/// in another array of another length.
struct HScanView {
  const float* values = nullptr;          // segment_count * kFields rows
  const float* root_positions = nullptr;  // 3 rows
  std::size_t frame_count = 0;
  std::size_t stride = 0;
  std::size_t segment_count = 0;
  std::size_t root_stride = 0;
};

inline HScanView HScanTable::view() const {
  return {values.data(), root_positions.data(), frame_count, stride, segment_count, stride};
}

/// Allocates a zeroed table for `frame_count` frames.
void init_h_scan_table(const DynamicsModel& model, std::size_t frame_count, HScanTable& table);
/// Writes frame f of the table from a state (with velocities).
void set_h_scan_frame(const DynamicsModel& model, const StateView& state, std::size_t f,
                      HScanTable& table);
/// The same values for one frame, row-major (an index's h_scan row: per
/// segment its kFields values; S x kFields floats at `out`), bit for bit
/// what set_h_scan_frame writes into the table's column f.
void h_scan_row(const DynamicsModel& model, const StateView& state, float* out);

/// theta^2 / sin^2(theta / 2) as a function of t = 1 - |w| = 1 - cos(theta / 2)
/// in [0, 1], for a unit quaternion (w, v) of angle theta: 4 acos(1 - t)^2 /
/// (1 - (1 - t)^2) by a degree-10 polynomial (interpolation at Chebyshev
/// nodes; maximum relative error 1.6e-8). |log q|^2 = log_norm_factor(1 - |w|) |v|^2,
/// so the h scan's rotational transition energy needs no acos or atan2.
/// Evaluated in T (float in the scan kernel, double elsewhere).
template <class T>
inline T log_norm_factor(T t) {
  constexpr double c[] = {4.000000061686637,   2.666651769534008,   1.511700742838962,
                          0.803679891497636,   0.49665062823084916, -0.09152589691698841,
                          0.9679826583910828,  -1.4020223308477227, 1.5628066920237862,
                          -0.9032807260483232, 0.25696078661431665};
  T p = static_cast<T>(c[10]);
  for (int i = 9; i >= 0; --i) p = p * t + static_cast<T>(c[i]);
  return p;
}

/// One full query state prepared for scanning (float constants per segment).
struct HScanQuery {
  static constexpr std::size_t kConstants = HScanConstant::count;
  std::size_t segment_count = 0;
  /// [s * kConstants + i], i of HScanConstant (h_scan_layout.hpp): COM x y z,
  /// KE_A, m g, m / (2 T^2), conj(q_A P) w x y z, KE_A^rot, D_k / (2 T^2)
  /// k = 0..2, and left_out: 0 when the segment is summed, 1 when it is left
  /// out (a segment mask: make_h_scan_query's compared_joints).
  std::vector<float> constants;
};
/// Prepares h(state -> frame) for a full query state (static or with
/// velocities). `compared_joints` (per joint; empty: every segment) restricts
/// h to the segments b with compared_joints[b] != 0: the scan sums only their
/// terms, exactly the sum of approximate_energy's terms of those segments
/// (segment_J[b] + joint_J[b]). A query frame retargeted from another rig
/// compares only the segments the rigs share (retarget.hpp).
HScanQuery make_h_scan_query(const DynamicsModel& model, const StateView& state,
                             double transition_time_s,
                             std::span<const std::uint8_t> compared_joints = {});
/// `body` moved by the ground pose g (ground_pose.hpp): the query of the
/// state placed by g (COM x, z turned and moved, orientations turned; kinetic
/// energies and heights unchanged), computed in double from body's floats.
/// `out` is resized as needed (reused without allocating).
void place_h_scan_query(const HScanQuery& body, const GroundPose& g, HScanQuery& out);
/// out[i] = h(query, frame begin + i) for frames [begin, end), joules (float).
/// Agrees with approximate_energy to float precision (test).
void scan_approximate_energy(const HScanView& table, const HScanQuery& query, std::size_t begin,
                             std::size_t end, float* out);
inline void scan_approximate_energy(const HScanTable& table, const HScanQuery& query,
                                    std::size_t begin, std::size_t end, float* out) {
  scan_approximate_energy(table.view(), query, begin, end, out);
}

/// A partial query giving only root position components (no heading, no joint
/// rotations): Q_F is F translated by delta = given components of
/// (p_Q - p_root(F)), every segment moved and static, so
///   h = sum_b [ m_b g |delta_y| + max(K_b, m_b |delta|^2 / T^2 - K_b) + K_b^rot ].
struct HScanRootQuery {
  std::array<float, 3> position{0.0f, 0.0f, 0.0f};
  std::array<float, 3> given{0.0f, 0.0f, 0.0f};  // 1 for given axes
  float inv_t2 = 0.0f;
  float gravity = 0.0f;
  std::vector<float> masses;
};
HScanRootQuery make_h_scan_root_query(const DynamicsModel& model,
                                      const std::array<std::optional<double>, 3>& root_position_m,
                                      double transition_time_s);
void scan_root_translation_energy(const HScanView& table, const HScanRootQuery& query,
                                  std::size_t begin, std::size_t end, float* out);
inline void scan_root_translation_energy(const HScanTable& table, const HScanRootQuery& query,
                                         std::size_t begin, std::size_t end, float* out) {
  scan_root_translation_energy(table.view(), query, begin, end, out);
}

// ---------------------------------------------------------------------------
// Naming terms (reports, the energy command)

struct NamedEnergyTerm {
  std::string name;       // joint name
  bool is_joint = false;  // false: "segment" term, true: "joint" term
  int joint = -1;
};
/// The terms a report lists: a "segment" term per segment and a "joint" term
/// per term joint, joint-index order (segment before joint for the same index).
std::vector<NamedEnergyTerm> energy_term_names(const DynamicsModel& model);

}  // namespace mocap
