#include "mocap/common/dynamics/work_energy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dynamics/step_geometry.hpp"
#include "mocap/common/dynamics/energy.hpp"

namespace mocap {

double WorkEnergyTerms::total() const {
  double s = residual_work_J + unsupported_J;
  for (const double v : joint_J) s += v;
  for (const double v : ground_J) s += v;
  return s;
}

namespace {

// The joint torque's work over the joint's own rotation step (J): term
// joints below a body root.
void joint_work(const DynamicsModel& model, const StateView& a, const StateView& b,
                const NewtonEulerData& da, const NewtonEulerData& db,
                std::vector<Eigen::Vector3d>& steps, std::vector<double>& out) {
  const std::size_t n = model.joint_count();
  steps.resize(n);
  for (std::size_t j = 0; j < n; ++j) steps[j] = rotation_step(a.rotations[j], b.rotations[j]);
  for (int jj : model.term_joints) {
    const auto j = static_cast<std::size_t>(jj);
    if (model.is_body_root[j]) continue;
    const int p = model.parents[j];
    const Eigen::Vector3d rel =
        p >= 0 ? Eigen::Vector3d(steps[j] - steps[static_cast<std::size_t>(p)]) : steps[j];
    out[j] = std::abs(0.5 * (da.joint_torques_Nm[j] + db.joint_torques_Nm[j]).dot(rel));
  }
}

// The ground's work at segment j's contact (J): its mean normal force through
// the contact point's rise or fall, and friction over its horizontal slide.
double ground_work(const DynamicsModel& model, const StateView& a, const StateView& b,
                   const NewtonEulerData& da, const NewtonEulerData& db, std::size_t j) {
  const Eigen::Vector3d slide = detail::contact_slide(a, b, da, db, j);
  const double normal =
      std::max(0.0, 0.5 * (da.contact_forces_N[j].y() + db.contact_forces_N[j].y()));
  return normal * (std::abs(slide.y()) +
                   model.params.friction_coefficient * std::hypot(slide.x(), slide.z()));
}

// The body roots' residual wrench: its work over the step (as g's), through
// each root's COM displacement and rotation step (steps[j], rad).
double residual_work(const DynamicsModel& model, const StateView& a, const StateView& b,
                     const NewtonEulerData& da, const NewtonEulerData& db,
                     const std::vector<Eigen::Vector3d>& steps) {
  double w = 0.0;
  for (int jj : model.body_roots) {
    const auto j = static_cast<std::size_t>(jj);
    const detail::MeanWrench r = detail::mean_residual_wrench(a, b, da, db, j);
    const Eigen::Vector3d dc = b.coms_m[j] - a.coms_m[j];
    w += std::abs(r.force_N.dot(dc) + r.moment_Nm.dot(steps[j]));
  }
  return w;
}

}  // namespace

double work_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, const NewtonEulerData& da, const NewtonEulerData& db,
                   const WorkEnergyParams& params, WorkEnergyTerms* terms) {
  const std::size_t n = model.joint_count();
  if (da.joint_forces_N.size() != n || db.joint_forces_N.size() != n)
    throw std::invalid_argument("inverse dynamics results do not match the character model");
  detail::check_transition_time(transition_time_s);
  if (!(params.unsupported_speed_mps >= 0.0) || !std::isfinite(params.unsupported_speed_mps))
    throw std::invalid_argument("work_energy: unsupported_speed_mps must be finite and >= 0");
  WorkEnergyTerms local;
  WorkEnergyTerms& t = terms != nullptr ? *terms : local;
  t.joint_J.assign(n, 0.0);
  t.ground_J.assign(n, 0.0);
  joint_work(model, a, b, da, db, t.rotation_steps, t.joint_J);
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    if (da.in_contact[j] || db.in_contact[j]) t.ground_J[j] = ground_work(model, a, b, da, db, j);
  }
  t.residual_work_J = residual_work(model, a, b, da, db, t.rotation_steps);
  t.unsupported_J = params.unsupported_speed_mps * transition_time_s * 0.5 *
                    (da.residual_force_N.norm() + db.residual_force_N.norm());
  return t.total();
}

}  // namespace mocap
