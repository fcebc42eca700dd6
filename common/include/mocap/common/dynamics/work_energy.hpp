#pragma once
// W, the work energy of a step A -> B: the mechanical work a body does,
// counted once, plus a price for what physics forbids (docs/energy.md "W:
// the work energy"). It is measured beside the paper's g (newton_euler.hpp)
// by `mocap-search energy` and scripts/energy-realism; synthesis minimises
// g by default and W with `mocap-synth --energy w` (SearchEnergy::work).
//
// From the same inverse dynamics as g (the same contacts, joint wrenches and
// residual), each force's work by the trapezoid rule (mean of its value in A
// and B), joules:
//   W = sum_j |n_j . (dphi_j - dphi_parent(j))|            joint work (not at a body root)
//     + sum_c F_n,c (|dp_c,y| + mu |dp_c,horizontal|)      ground: the normal force through
//                                                          the contact point's rise, and
//                                                          friction of its sliding
//     + |F_res . dc_root + M_res(about c_root) . dphi_root| residual work (as in g)
//     + v_u T |F_res|                                      unsupported force, priced as a
//                                                          violation (v_u: WorkEnergyParams)
// with dphi_j = log(R_j(B) R_j(A)^T), dp_c the contact point's displacement
// carried rigidly with its segment from the state where it touches, F_n,c >= 0
// its mean normal force, F_res the whole-body residual force (the mean of the
// magnitudes in A and B).
//
// Why: the joint-power method counts the energy a segment passes to its
// neighbours through a joint once, where a joint torque does work, and
// energy that flows from potential to kinetic within a segment (a swinging
// leg) not at all, where g counts every segment's kinetic and potential
// change and the adjacent forces' work on top. Supporting a body costs no
// work at a planted foot, and a sliding one dissipates mu F_n per metre; a
// body no contact holds pays v_u per newton-second of the support it lacks,
// instead of the few joules the residual impulse would inject.
//
// Properties (tested): W >= 0; W(A, A) = 0 for a static pose the ground
// supports, v_u T M g for one held in the air; invariant under horizontal
// moves and turns about the vertical; the joint terms equal g's joint work
// (FullEnergyTerms::joint_work_J); the same in centimetres and metres.
// W is not bounded below by h: h is no A* estimate of it (the search on W
// costs its completions exactly).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"

namespace mocap {

struct WorkEnergyParams {
  /// v_u, m/s: the price of unsupported force, joules per newton-second of
  /// residual impulse (the work the residual force would do at this speed).
  /// 5 m/s: the least value at which W ranks every held-out locomotion gap's
  /// capture below its interpolation (docs/energy.md "Realism").
  double unsupported_speed_mps = 5.0;
};

/// W broken down, joules (index = joint).
struct WorkEnergyTerms {
  std::vector<double> joint_J;   // |n_j . (dphi_j - dphi_p)|, 0 at body roots and non-term joints
  std::vector<double> ground_J;  // F_n (|dp_y| + mu |dp_h|), 0 where no contact in A or B
  double residual_work_J = 0.0;  // |F_res . dc + M_res . dphi| summed over body roots
  double unsupported_J = 0.0;    // v_u T (|F_res(A)| + |F_res(B)|) / 2
  /// dphi_j, each joint's world rotation step A -> B (rad; scratch of the
  /// joint terms, kept so that a reused WorkEnergyTerms allocates nothing).
  std::vector<Eigen::Vector3d> rotation_steps;
  double total() const;
};

/// W(A -> B) in joules from inverse dynamics already computed for A and B
/// (inverse_dynamics, e.g. once per frame of a clip). T > 0 (seconds;
/// std::invalid_argument otherwise, and when `da`/`db` do not match the
/// model).
double work_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, const NewtonEulerData& da, const NewtonEulerData& db,
                   const WorkEnergyParams& params = {}, WorkEnergyTerms* terms = nullptr);

}  // namespace mocap
