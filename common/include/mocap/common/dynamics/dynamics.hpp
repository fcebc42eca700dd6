#pragma once
// Rigid-body model of a character and the per-frame kinematics of its segments.
//
// This is the Model half of the energy model (Pinocchio's Model/Data split):
// DynamicsModel is the immutable description every stage takes its physics
// from (masses, COMs, inertias, tree, contact and gravity parameters);
// BodyState / ClipDynamics hold states. The energies themselves are in
// energy.hpp (h, retrieval) and newton_euler.hpp (g, supplementation); the
// formulas and their physical meaning are in docs/energy.md.
//
// Conventions (everywhere in this header):
//  - SI units: metres, kilograms, seconds, radians; world is Y up, gravity
//    (0, -g, 0) with g = EnergyParams::gravity_mps2.
//  - One segment per joint (Body, body.hpp): segment j is rigidly attached to
//    joint j's frame; joints with mass 0 are not segments (they still carry
//    poses and transmit forces between massive relatives).
//  - "world" vectors are expressed in the world frame; "local" ones in the
//    joint's own frame. Angular velocities and accelerations are world vectors.
//  - Quaternions are unit, world-from-joint (R_j maps joint-local vectors to
//    world vectors), as in kinematics.hpp.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"

namespace mocap {

/// Physical constants and the contact model of g (docs/energy.md, "Contact").
struct EnergyParams {
  /// Magnitude of gravity, m/s^2 (acts along -Y).
  double gravity_mps2 = 9.81;
  /// Height of the ground plane (world Y), metres.
  double ground_height_m = 0.0;
  /// A segment can be in contact when the lower of its contact points (its
  /// joint origin, and its bone tip unless that is a massive child's origin;
  /// DynamicsModel::tip_contacts) is at most this far above the ground, metres.
  double contact_height_m = 0.10;
  /// ... and that end moves at most this fast, m/s.
  double contact_speed_mps = 0.8;
  /// Coulomb friction coefficient of the ground (caps the tangential contact
  /// force and prices sliding in contact).
  double friction_coefficient = 0.8;
  /// How far the centre of pressure may move from the contact points, metres:
  /// the free contact moment is capped at normal force x this radius.
  double contact_patch_radius_m = 0.15;
  bool operator==(const EnergyParams&) const = default;
};

/// The immutable rigid-body description of a character on a skeleton.
/// Arrays are indexed by joint (size joint_count()); parents[j] < j.
struct DynamicsModel {
  std::vector<std::string> names;
  std::vector<int> parents;
  /// Segment mass, kg (0 = not a segment).
  std::vector<double> masses_kg;
  /// Segment COM in the joint frame, metres.
  std::vector<Eigen::Vector3d> coms_local_m;
  /// Bone end (child / mean of children / End Site) in the joint frame, metres.
  std::vector<Eigen::Vector3d> tips_local_m;
  /// Inertia about the COM, joint frame, kg m^2 (symmetric PSD).
  std::vector<Eigen::Matrix3d> inertias_local_kgm2;
  /// Principal axes: I_local = P diag(D) P^T with P = principal_frames[j]
  /// (joint-from-principal rotation) and D = principal_moments_kgm2[j].
  std::vector<Eigen::Quaterniond> principal_frames;
  std::vector<Eigen::Vector3d> principal_moments_kgm2;
  /// Joints with mass > 0 (the segments b of docs/energy.md), in index order.
  std::vector<int> segments;
  /// Joints that carry a "joint" energy term: every joint that is a segment
  /// or has a segment below it, except the massless ancestors of body roots
  /// (BVH dummies such as Bandai Namco's joint_Root). Index order.
  std::vector<int> term_joints;
  /// Body roots: segments none of whose ancestors is a segment (the pelvis,
  /// canonical Hips). Usually exactly one. The root residual acts there.
  std::vector<int> body_roots;
  /// 1 when the segment's bone tip is one of its contact points: the tip is
  /// not the origin of a massive child (a point belongs to the most distal
  /// segment that has it, so the ankle is the foot's, not the shank's).
  std::vector<std::uint8_t> tip_contacts;
  /// 1 for joints in term_joints / body_roots.
  std::vector<std::uint8_t> is_term_joint;
  std::vector<std::uint8_t> is_body_root;
  double total_mass_kg = 0.0;
  EnergyParams params;

  std::size_t joint_count() const { return parents.size(); }
  /// The first body root (the character's root for positions and heading), -1 if massless.
  int root() const { return body_roots.empty() ? -1 : body_roots.front(); }
  Eigen::Vector3d gravity() const { return {0.0, -params.gravity_mps2, 0.0}; }
};

/// Builds the model from a skeleton and its body (body.segments[j] belongs to
/// joint j). Throws InputError("<body>", 0, ...) when the body does not fit the
/// skeleton or has a negative / non-finite mass or inertia.
DynamicsModel build_dynamics_model(const Skeleton& skel, const Body& body,
                                   const EnergyParams& params = {});

/// Read-only view of one state's per-joint arrays (each joint_count long).
/// Rate pointers may be null only where documented (static_state etc. always
/// fill them). All world frame.
struct StateView {
  std::size_t joint_count = 0;
  const Eigen::Vector3d* joint_positions_m = nullptr;             // x_j, joint origins
  const Eigen::Quaterniond* rotations = nullptr;                  // R_j, world from joint
  const Eigen::Vector3d* coms_m = nullptr;                        // c_j = x_j + R_j c^_j
  const Eigen::Vector3d* com_velocities_mps = nullptr;            // v_j
  const Eigen::Vector3d* com_accelerations_mps2 = nullptr;        // a_j
  const Eigen::Vector3d* angular_velocities_radps = nullptr;      // omega_j
  const Eigen::Vector3d* angular_accelerations_radps2 = nullptr;  // alpha_j
};

/// One state with storage (a query frame, a supplementation state). Reuse one
/// BodyState per thread: the setters below allocate only on the first call for
/// a given joint count.
struct BodyState {
  std::vector<Eigen::Vector3d> joint_positions_m;
  std::vector<Eigen::Quaterniond> rotations;
  std::vector<Eigen::Vector3d> coms_m;
  std::vector<Eigen::Vector3d> com_velocities_mps;
  std::vector<Eigen::Vector3d> com_accelerations_mps2;
  std::vector<Eigen::Vector3d> angular_velocities_radps;
  std::vector<Eigen::Vector3d> angular_accelerations_radps2;

  void resize(std::size_t joints);
  /// Sets all velocities and accelerations to zero.
  void set_rates_zero();
  StateView view() const;
};

/// A world pose (joint origins and world rotations), e.g. a WorldPose or one
/// frame of a ClipMotion.
struct PoseView {
  const Eigen::Vector3d* joint_positions_m = nullptr;
  const Eigen::Quaterniond* rotations = nullptr;
};
inline PoseView pose_view(const WorldPose& w) {
  return {w.positions_m.data(), w.rotations.data()};
}
inline PoseView pose_view(const ClipMotion& m, std::size_t f) {
  return {&m.world_positions_m[f * m.joint_count()], &m.world_rotations[f * m.joint_count()]};
}

/// Copies the pose into `out` and computes segment COMs c_j = x_j + R_j c^_j;
/// rates are left as they are (resize() zero-fills new storage).
void set_state_pose(const DynamicsModel& model, PoseView pose, BodyState& out);
/// A static state (hand-written query frame): pose + COMs, all rates zero.
void static_state(const DynamicsModel& model, PoseView pose, BodyState& out);
/// A state inside a sequence ... prev, cur, next ... (frame time dt_s), with
/// rates by the same finite differences as compute_clip_dynamics: central
/// when both neighbours are given; one-sided velocity and zero acceleration
/// when only one is (a 2-state sequence has no curvature); all zero when none.
void sequence_state(const DynamicsModel& model, const PoseView* prev, PoseView cur,
                    const PoseView* next, double dt_s, BodyState& out);

/// Per-frame dynamics of a whole clip for one character, flat frame-major
/// ([f * J + j]), world frame. Immutable after compute_clip_dynamics.
struct ClipDynamics {
  std::size_t frame_count = 0;
  std::size_t joint_count = 0;
  double frame_time_s = 0.0;
  std::vector<Eigen::Vector3d> joint_positions_m;
  std::vector<Eigen::Quaterniond> rotations;
  std::vector<Eigen::Vector3d> coms_m;
  std::vector<Eigen::Vector3d> com_velocities_mps;
  std::vector<Eigen::Vector3d> com_accelerations_mps2;
  std::vector<Eigen::Vector3d> angular_velocities_radps;
  std::vector<Eigen::Vector3d> angular_accelerations_radps2;

  /// View of frame f (f < frame_count).
  StateView state(std::size_t f) const;
};

/// Per-frame dynamics by finite differences at the frame time dt (no
/// smoothing; docs/energy.md "States and per-frame dynamics"):
///   half-step rates  v_{f+1/2} = (c_{f+1} - c_f) / dt,
///                    w_{f+1/2} = log(R_{f+1} R_f^T) / dt   (world rotation vector)
///   frame rates      v_f = (v_{f-1/2} + v_{f+1/2}) / 2 = (c_{f+1} - c_{f-1}) / (2 dt)
///                    a_f = (v_{f+1/2} - v_{f-1/2}) / dt,  same for w and alpha.
/// One-sided at the ends: frame 0 takes the first half-step rate and frame 1's
/// acceleration, the last frame likewise; a 1-frame clip has zero rates, a
/// 2-frame clip zero accelerations. Exact for constant linear and angular
/// accelerations / velocities respectively (second order in dt otherwise).
/// `joint_positions_m` / `rotations`: frame-major world pose, frame_count x J.
void compute_clip_dynamics(const DynamicsModel& model, std::size_t frame_count, double frame_time_s,
                           const Eigen::Vector3d* joint_positions_m,
                           const Eigen::Quaterniond* rotations, ClipDynamics& out);
ClipDynamics compute_clip_dynamics(const DynamicsModel& model, const ClipMotion& motion);

/// Rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion:
/// log(q) = 2 atan2(|v|, w) v / |v| with the sign of q chosen so that w >= 0.
Eigen::Vector3d rotation_vector(const Eigen::Quaterniond& q);

/// rotation_vector(to * from^-1): the world rotation vector taking `from` to
/// `to`. Exactly zero when from == to (computed without FMA contraction).
Eigen::Vector3d rotation_step(const Eigen::Quaterniond& from, const Eigen::Quaterniond& to);

/// Heading of a world rotation: the angle (radians, (-pi, pi]) of its twist
/// about world +Y in the swing-twist split R = R_y(psi) R_tilt, i.e.
/// psi = 2 atan2(q.y, q.w). 0 for the rest orientation.
double heading_rad(const Eigen::Quaterniond& q);

}  // namespace mocap
