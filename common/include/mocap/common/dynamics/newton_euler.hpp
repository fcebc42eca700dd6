#pragma once
// Recursive Newton-Euler inverse dynamics with ground contact, and the full
// energy change g (supplementation, paper eq. 2; docs/energy.md).
//
// Inverse dynamics of one state (world frame, SI):
//  - each segment b needs the non-gravity wrench
//      F_b = m_b (a_b - g),  tau_b = I_b alpha_b + omega_b x I_b omega_b  (about c_b, I_b world);
//  - contact: a segment is in contact when the lower of its contact points
//    (joint origin; bone tip unless a massive child starts there) is within
//    EnergyParams::contact_height_m of the ground and that point moves slower
//    than contact_speed_mps. The contacts together supply the whole-body
//    requirement (F_req, M_req about the body COM) as far as the ground can:
//    normal component >= 0, tangential capped by friction (mu F_n), shared
//    equally, applied at the contact points, plus a free moment capped at
//    F_n * contact_patch_radius_m (centre of pressure inside the patch);
//  - backward pass (leaves -> root): f_j, n_j = force and torque the parent
//    applies to segment j at / about its joint origin x_j:
//      f_j = F_j - F_contact,j + sum_children f_c
//      n_j = tau_j + (c_j - x_j) x F_j - tau_contact,j - (p_j - x_j) x F_contact,j
//            + sum_children [n_c + (x_c - x_j) x f_c]
//    At a body root (the pelvis) f, n are the root residual: the wrench the
//    contacts could not supply (zero for a well-supported, physical motion).
// rnea_forward computes segment kinematics from joint-space rates (root ->
// leaves) for states that are given as joint angles and their derivatives.
//
// Full energy change of a step A -> B in time T, each force's work over the
// step by the trapezoid rule (mean of its value in A and B) through the
// displacement of what it acts on (dc_b = c_b(B) - c_b(A),
// dphi_b = log(R_b(B) R_b(A)^T)):
//   g_b = h_b + |W_adj,b| + |W_contact,b|        (+ residual terms at the root)
//     W_adj,b     = F_adj,b . dc_b               (F_adj,b = f_b - sum_children f_c)
//     W_contact,b = F_contact,b . dc_b + tau_contact,b(about c_b) . dphi_b
//                   + mu |F_n,b| |dp_horizontal|  (friction of a sliding contact)
//     root:         + |F_res . dc_root + M_res(about c_root) . dphi_root|
//                   + T^2/2 (|F_res|^2 / M + M_res^T I_G^-1 M_res)  (energy the residual
//                     impulse would inject: an unsupported body pays for it)
//   g_j = h_j + |n_j . (dphi_j - dphi_parent(j))| (work of the joint torque
//                                                  through the joint's rotation)
//   g = sum_b g_b + sum_j g_j  >=  h  (same states, same T; by construction).
// States carry their own rates (v, a, omega, alpha): for steps inside a
// sequence they come from the neighbours (sequence_state, ClipDynamics).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"

namespace mocap {

/// Joint-space rates of one state (world coordinates), input of rnea_forward.
/// For a joint j with parent p, local offset t_j(t) and local rotation Q_j(t):
///  relative_angular_velocities  = R_p w_Q     (w_Q: angular velocity of Q_j in p's frame)
///  relative_angular_accelerations = R_p dw_Q/dt
///  relative_linear_velocities     = R_p dt_j/dt   (0 for fixed bones)
///  relative_linear_accelerations  = R_p d2t_j/dt2
/// For a tree root (parent -1) the values are absolute (world) rates of its
/// origin and frame.
struct JointMotion {
  std::vector<Eigen::Vector3d> relative_angular_velocities_radps;
  std::vector<Eigen::Vector3d> relative_angular_accelerations_radps2;
  std::vector<Eigen::Vector3d> relative_linear_velocities_mps;
  std::vector<Eigen::Vector3d> relative_linear_accelerations_mps2;
  /// Resizes to n joints, all zero.
  void resize(std::size_t n);
};

/// Results and scratch of inverse_dynamics for one state (allocated once,
/// reused). All world frame; index = joint.
struct NewtonEulerData {
  /// f_j: force on segment j from its parent at x_j, N. At a body root: the residual force.
  std::vector<Eigen::Vector3d> joint_forces_N;
  /// n_j: torque on segment j from its parent about x_j, N m. At a body root: the residual torque.
  std::vector<Eigen::Vector3d> joint_torques_Nm;
  /// Ground reaction on segment j (0 when not in contact), applied at contact_points_m[j].
  /// The three contact arrays are zero wherever in_contact is 0 (inverse_dynamics
  /// relies on it to clear only the previous call's contacts: do not write them).
  std::vector<Eigen::Vector3d> contact_forces_N;
  std::vector<Eigen::Vector3d> contact_points_m;
  /// Free contact moment on segment j, N m.
  std::vector<Eigen::Vector3d> contact_torques_Nm;
  std::vector<std::uint8_t> in_contact;
  /// R_j P_j: rotation of segment j's principal axes (world from principal;
  /// I_world = R P diag(D) (R P)^T); 1/2 w^T I_world w and 1/2 m |v|^2, its
  /// rotational and translational kinetic energies in J. Identity / 0 for
  /// massless joints. full_energy takes its kinetic energies from them (one
  /// code path for both states: identical states give bitwise equal energies,
  /// so h(A, A) = 0 exactly whatever the compiler fuses).
  std::vector<Eigen::Matrix3d> principal_rotations;
  std::vector<double> rotational_energies_J;
  std::vector<double> translational_energies_J;
  /// F_j = m (a - g) and tau_j (about c_j): what segment j needs from all non-gravity forces.
  std::vector<Eigen::Vector3d> required_forces_N;
  std::vector<Eigen::Vector3d> required_torques_Nm;
  /// Whole body: COM and the residual wrench about it (sum over body roots).
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d residual_force_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d residual_torque_Nm = Eigen::Vector3d::Zero();
  std::size_t contact_count = 0;
  /// |F_res|^2 / M + M_res^T I_G^-1 M_res (J/s^2, I_G = composite_inertia about
  /// com_m): times T^2/2 it is the kinetic energy the residual impulse would
  /// inject over a step of T seconds (full_energy). I_G is only formed when
  /// M_res is above round-off (1e-9 M g x 1 m), so this costs nothing for a
  /// well-supported state.
  double residual_impulse_coefficient_Jps2 = 0.0;
  // Forward-pass scratch: joint origin velocity / acceleration.
  std::vector<Eigen::Vector3d> origin_velocities_mps;
  std::vector<Eigen::Vector3d> origin_accelerations_mps2;

  void resize(std::size_t n);
};

/// Root -> leaves: segment kinematics from joint-space rates:
///   w_j = w_p + w_rel,  alpha_j = alpha_p + alpha_rel + w_p x w_rel,
///   r = x_j - x_p,  v_xj = v_xp + w_p x r + v_rel,
///   a_xj = a_xp + alpha_p x r + w_p x (w_p x r) + 2 w_p x v_rel + a_rel,
///   c_j = x_j + R_j c^_j, v_j = v_xj + w_j x (c_j - x_j),
///   a_j = a_xj + alpha_j x (c_j - x_j) + w_j x (w_j x (c_j - x_j)).
/// `out` gets the pose and all rates; `scratch` holds origin rates.
void rnea_forward(const DynamicsModel& model, PoseView pose, const JointMotion& motion,
                  NewtonEulerData& scratch, BodyState& out);

/// Contacts + leaves -> root pass for one state with rates (see the header).
void inverse_dynamics(const DynamicsModel& model, const StateView& state, NewtonEulerData& data);

/// Composite inertia of all segments about `com` (world, kg m^2):
/// sum_b R_b I_b R_b^T + m_b (|r|^2 1 - r r^T), r = c_b - com.
Eigen::Matrix3d composite_inertia(const DynamicsModel& model, const StateView& state,
                                  const Eigen::Vector3d& com);

/// g broken down (joules, index = joint).
struct FullEnergyTerms {
  EnergyTerms h;                        // the h part (same states, same T)
  EnergyTerms g;                        // g_b in segment_J, g_j in joint_J
  std::vector<double> adjacent_work_J;  // |W_adj,b|
  std::vector<double> contact_work_J;   // |W_contact,b| (friction included)
  std::vector<double> joint_work_J;     // |n_j . (dphi_j - dphi_p)|
  double residual_work_J = 0.0;         // |F_res . dc + M_res . dphi| summed over body roots
  double residual_impulse_J = 0.0;  // T^2/2 (|F_res|^2/M + M_res^T I_G^-1 M_res), mean of A and B
};

/// Per-thread workspace of full_energy (two inverse dynamics + step scratch).
struct NewtonEulerWorkspace {
  NewtonEulerData a;
  NewtonEulerData b;
  std::vector<Eigen::Vector3d> rotation_steps;
  EnergyTerms h;
  /// Joules; 0 (the default): the exact g. > 0: a smooth under-estimate for
  /// gradient-based optimisation (synth's refinement): every |x| of the step
  /// becomes sqrt(x^2 + s^2) - s and every max(a, b) (a + b + |a - b|) / 2.
  double smoothing_J = 0.0;
};

/// g(A -> B) in joules, running inverse dynamics on both states (into ws.a, ws.b).
double full_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, NewtonEulerWorkspace& ws,
                   FullEnergyTerms* terms = nullptr);
/// g(A -> B) from inverse dynamics already computed for A and B (e.g. once per clip frame).
double full_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, const NewtonEulerData& id_a,
                   const NewtonEulerData& id_b, NewtonEulerWorkspace& ws,
                   FullEnergyTerms* terms = nullptr);

/// The clip's own per-step energies g(F^i -> F^{i+1}), i = 0 .. K-2, with T =
/// the frame time and each frame's rates from the clip (one inverse dynamics
/// per frame). Empty for clips of fewer than 2 frames.
std::vector<double> clip_step_energies(const DynamicsModel& model, const ClipDynamics& clip);

/// P[0] = 0, P[i+1] = P[i] + steps[i] (size K = steps + 1), accumulated in
/// double: the energy of the partial motion F^s .. F^e (s <= e) is P[e] - P[s].
std::vector<double> energy_prefix_sums(const std::vector<double>& steps);

}  // namespace mocap
