#include "mocap/newton_euler.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "multiversion.hpp"

namespace mocap {

void JointMotion::resize(std::size_t n) {
  for (auto* v : {&relative_angular_velocities_radps, &relative_angular_accelerations_radps2,
                  &relative_linear_velocities_mps, &relative_linear_accelerations_mps2})
    v->assign(n, Eigen::Vector3d::Zero());
}

void NewtonEulerData::resize(std::size_t n) {
  for (auto* v : {&joint_forces_N, &joint_torques_Nm, &contact_forces_N, &contact_points_m,
                  &contact_torques_Nm, &required_forces_N, &required_torques_Nm,
                  &origin_velocities_mps, &origin_accelerations_mps2})
    v->resize(n, Eigen::Vector3d::Zero());
  in_contact.resize(n, 0);
}

// Root -> leaves propagation of velocities and accelerations (formulas in the
// header): each joint's frame rates from its parent's plus the joint's own
// relative rates, then the segment COM rates from its frame's.
void rnea_forward(const DynamicsModel& model, PoseView pose, const JointMotion& motion,
                  NewtonEulerData& scratch, BodyState& out) {
  const std::size_t n = model.joint_count();
  if (motion.relative_angular_velocities_radps.size() != n ||
      motion.relative_angular_accelerations_radps2.size() != n ||
      motion.relative_linear_velocities_mps.size() != n ||
      motion.relative_linear_accelerations_mps2.size() != n)
    throw std::invalid_argument("joint motion does not match the character model");
  scratch.resize(n);
  set_state_pose(model, pose, out);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = model.parents[j];
    const Eigen::Vector3d& w_rel = motion.relative_angular_velocities_radps[j];
    const Eigen::Vector3d& al_rel = motion.relative_angular_accelerations_radps2[j];
    const Eigen::Vector3d& v_rel = motion.relative_linear_velocities_mps[j];
    const Eigen::Vector3d& a_rel = motion.relative_linear_accelerations_mps2[j];
    Eigen::Vector3d w, al, vx, ax;
    if (p < 0) {
      w = w_rel;
      al = al_rel;
      vx = v_rel;
      ax = a_rel;
    } else {
      const auto pp = static_cast<std::size_t>(p);
      const Eigen::Vector3d& wp = out.angular_velocities_radps[pp];
      const Eigen::Vector3d& alp = out.angular_accelerations_radps2[pp];
      const Eigen::Vector3d r = out.joint_positions_m[j] - out.joint_positions_m[pp];
      w = wp + w_rel;
      al = alp + al_rel + wp.cross(w_rel);
      vx = scratch.origin_velocities_mps[pp] + wp.cross(r) + v_rel;
      ax = scratch.origin_accelerations_mps2[pp] + alp.cross(r) + wp.cross(wp.cross(r)) +
           2.0 * wp.cross(v_rel) + a_rel;
    }
    scratch.origin_velocities_mps[j] = vx;
    scratch.origin_accelerations_mps2[j] = ax;
    out.angular_velocities_radps[j] = w;
    out.angular_accelerations_radps2[j] = al;
    const Eigen::Vector3d rc = out.coms_m[j] - out.joint_positions_m[j];
    out.com_velocities_mps[j] = vx + w.cross(rc);
    out.com_accelerations_mps2[j] = ax + al.cross(rc) + w.cross(w.cross(rc));
  }
}

// Inverse dynamics of one state (see the header):
//  1. per segment F_j = m (a - g), tau_j = I alpha + w x I w (I = R I_local R^T);
//     whole-body F_req = sum F_j, M_req = sum tau_j + (c_j - c_G) x F_j, I_G;
//  2. contacts (lower end near the ground and slow) share the part of F_req the
//     ground can push (F_n >= 0, |F_t| <= mu F_n) equally, plus a free moment
//     M_req - sum (p_k - c_G) x F_k capped at F_n * patch radius;
//  3. leaves -> root: f_j, n_j accumulate children; a body root keeps its
//     (f, n) as the residual.
MOCAP_MULTIVERSION_V3
void inverse_dynamics(const DynamicsModel& model, const StateView& s, NewtonEulerData& d) {
  const std::size_t n = model.joint_count();
  if (s.joint_count != n || s.com_accelerations_mps2 == nullptr ||
      s.angular_accelerations_radps2 == nullptr || s.com_velocities_mps == nullptr ||
      s.angular_velocities_radps == nullptr)
    throw std::invalid_argument(
        "state does not match the character model (joint count or missing rates)");
  d.resize(n);
  const EnergyParams& prm = model.params;
  const Eigen::Vector3d gravity = model.gravity();

  // 1. Requirements and whole-body totals. Euler's equation in the body
  // frame (I_local constant): tau = R (I w_l' + w_l x I w_l), w_l = R^T w.
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < n; ++j) {
    d.required_forces_N[j].setZero();  // massless joints keep zero requirements
    d.required_torques_Nm[j].setZero();
    d.contact_forces_N[j].setZero();
    d.contact_torques_Nm[j].setZero();
    d.contact_points_m[j].setZero();
    d.in_contact[j] = 0;
    d.joint_forces_N[j].setZero();
    d.joint_torques_Nm[j].setZero();
  }
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const double m = model.masses_kg[j];
    const Eigen::Quaterniond qc = s.rotations[j].conjugate();
    const Eigen::Matrix3d& inertia = model.inertias_local_kgm2[j];
    const Eigen::Vector3d wl = qc * s.angular_velocities_radps[j];
    const Eigen::Vector3d al = qc * s.angular_accelerations_radps2[j];
    d.required_forces_N[j] = m * (s.com_accelerations_mps2[j] - gravity);
    d.required_torques_Nm[j] =
        s.rotations[j] * Eigen::Vector3d(inertia * al + wl.cross(inertia * wl));
    mass += m;
    com += m * s.coms_m[j];
  }
  if (mass > 0.0) com /= mass;
  Eigen::Vector3d f_req = Eigen::Vector3d::Zero(), m_req = Eigen::Vector3d::Zero();
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    f_req += d.required_forces_N[j];
    m_req += d.required_torques_Nm[j] + (s.coms_m[j] - com).cross(d.required_forces_N[j]);
  }
  d.com_m = com;

  // 2. Contacts.
  std::size_t contacts = 0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d& x = s.joint_positions_m[j];
    // Far above the ground even at the tip's reach: no contact (skips the rotation).
    const double above = x.y() - prm.ground_height_m - prm.contact_height_m;
    if (above > 0.0 && above * above > model.tips_local_m[j].squaredNorm()) continue;
    const Eigen::Vector3d tip = x + s.rotations[j] * model.tips_local_m[j];
    const Eigen::Vector3d& p = (model.tip_contacts[j] && tip.y() < x.y()) ? tip : x;
    if (p.y() - prm.ground_height_m > prm.contact_height_m) continue;
    const Eigen::Vector3d vp =
        s.com_velocities_mps[j] + s.angular_velocities_radps[j].cross(p - s.coms_m[j]);
    if (vp.norm() > prm.contact_speed_mps) continue;
    d.in_contact[j] = 1;
    d.contact_points_m[j] = p;
    ++contacts;
  }
  d.contact_count = contacts;
  if (contacts > 0 && f_req.y() > 0.0) {
    const double fn = f_req.y();
    Eigen::Vector3d ft(f_req.x(), 0.0, f_req.z());
    const double ft_norm = ft.norm();
    const double ft_max = prm.friction_coefficient * fn;
    if (ft_norm > ft_max) ft *= ft_max / ft_norm;
    const double share = 1.0 / static_cast<double>(contacts);
    const Eigen::Vector3d fk = share * (ft + Eigen::Vector3d(0.0, fn, 0.0));
    Eigen::Vector3d m_points = Eigen::Vector3d::Zero();
    for (int jj : model.segments) {
      const auto j = static_cast<std::size_t>(jj);
      if (!d.in_contact[j]) continue;
      d.contact_forces_N[j] = fk;
      m_points += (d.contact_points_m[j] - com).cross(fk);
    }
    Eigen::Vector3d m_free = m_req - m_points;
    const double m_max = fn * prm.contact_patch_radius_m;
    const double m_norm = m_free.norm();
    if (m_norm > m_max) m_free *= m_max / m_norm;
    for (int jj : model.segments) {
      const auto j = static_cast<std::size_t>(jj);
      if (d.in_contact[j]) d.contact_torques_Nm[j] = share * m_free;
    }
  }

  // 3. Leaves -> root (children have larger indices and are done first; their
  // contributions already sit in joint_forces_N / joint_torques_Nm[j]).
  Eigen::Vector3d f_res = Eigen::Vector3d::Zero(), m_res = Eigen::Vector3d::Zero();
  for (std::size_t j = n; j-- > 0;) {
    if (!model.is_term_joint[j]) continue;
    const Eigen::Vector3d& x = s.joint_positions_m[j];
    const Eigen::Vector3d& fj = d.required_forces_N[j];
    const Eigen::Vector3d& fc = d.contact_forces_N[j];
    const Eigen::Vector3d f = fj - fc + d.joint_forces_N[j];
    Eigen::Vector3d t = d.required_torques_Nm[j] + (s.coms_m[j] - x).cross(fj) -
                        d.contact_torques_Nm[j] + d.joint_torques_Nm[j];
    if (d.in_contact[j]) t -= (d.contact_points_m[j] - x).cross(fc);
    d.joint_forces_N[j] = f;
    d.joint_torques_Nm[j] = t;
    if (model.is_body_root[j]) {
      f_res += f;
      m_res += t + (x - com).cross(f);
      continue;
    }
    const int p = model.parents[j];
    if (p >= 0) {
      const auto pp = static_cast<std::size_t>(p);
      d.joint_forces_N[pp] += f;
      d.joint_torques_Nm[pp] += t + (x - s.joint_positions_m[pp]).cross(f);
    }
  }
  d.residual_force_N = f_res;
  d.residual_torque_Nm = m_res;
}

namespace {}  // namespace

Eigen::Matrix3d composite_inertia(const DynamicsModel& model, const StateView& s,
                                  const Eigen::Vector3d& com) {
  Eigen::Matrix3d i_g = Eigen::Matrix3d::Zero();
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d r = s.coms_m[j] - com;
    const Eigen::Matrix3d rot = s.rotations[j].toRotationMatrix();
    i_g += rot * model.inertias_local_kgm2[j] * rot.transpose() +
           model.masses_kg[j] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  return i_g;
}

namespace {

// T^2/2 (|F|^2 / M + M^T I_G^-1 M): kinetic energy the residual impulse
// (F T, M T) would give the whole body (translation + rotation about its COM).
// I_G is only formed when the residual torque is above round-off
// (1e-9 M g x 1 m; below it the term is < 1e-18 J for any T of interest).
double residual_impulse_energy(const DynamicsModel& model, const StateView& s,
                               const NewtonEulerData& d, double t) {
  const double mass = model.total_mass_kg;
  if (!(mass > 0.0)) return 0.0;
  double e = d.residual_force_N.squaredNorm() / mass;
  const double negligible = 1e-9 * mass * model.params.gravity_mps2;
  if (d.residual_torque_Nm.squaredNorm() > negligible * negligible) {
    const Eigen::Matrix3d i_g = composite_inertia(model, s, d.com_m);
    const double tr = i_g.trace();
    if (tr > 0.0) {
      const Eigen::Matrix3d reg = i_g + 1e-9 * tr * Eigen::Matrix3d::Identity();
      e += d.residual_torque_Nm.dot(reg.ldlt().solve(d.residual_torque_Nm));
    }
  }
  return 0.5 * t * t * e;
}

// Contact wrench of segment j about its COM: (F_c, tau_c + (p - c) x F_c).
inline Eigen::Vector3d contact_moment_about_com(const NewtonEulerData& d, const StateView& s,
                                                std::size_t j) {
  return d.contact_torques_Nm[j] +
         (d.contact_points_m[j] - s.coms_m[j]).cross(d.contact_forces_N[j]);
}

}  // namespace

double full_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, NewtonEulerWorkspace& ws, FullEnergyTerms* terms) {
  inverse_dynamics(model, a, ws.a);
  inverse_dynamics(model, b, ws.b);
  return full_energy(model, a, b, transition_time_s, ws.a, ws.b, ws, terms);
}

// g = h + work of adjacent, contact and residual forces and of joint torques
// over the step (trapezoid rule); formulas in the header.
MOCAP_MULTIVERSION_V3
double full_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                   double transition_time_s, const NewtonEulerData& da, const NewtonEulerData& db,
                   NewtonEulerWorkspace& ws, FullEnergyTerms* terms) {
  const std::size_t n = model.joint_count();
  if (da.joint_forces_N.size() != n || db.joint_forces_N.size() != n)
    throw std::invalid_argument("inverse dynamics results do not match the character model");
  ws.rotation_steps.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    ws.rotation_steps[j] = rotation_step(a.rotations[j], b.rotations[j]);
  const double h_total = detail::approximate_energy_given_rotations(
      model, a, b, transition_time_s, ws.rotation_steps.data(), &ws.h);
  if (terms != nullptr) {
    terms->h = ws.h;
    terms->g.reset(n);
    terms->adjacent_work_J.assign(n, 0.0);
    terms->contact_work_J.assign(n, 0.0);
    terms->joint_work_J.assign(n, 0.0);
    terms->residual_work_J = 0.0;
  }
  const double mu = model.params.friction_coefficient;
  double extra = 0.0;
  for (int jj : model.term_joints) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d& dphi = ws.rotation_steps[j];
    double g_seg = 0.0;
    if (model.masses_kg[j] > 0.0) {
      const Eigen::Vector3d dc = b.coms_m[j] - a.coms_m[j];
      const bool root = model.is_body_root[j] != 0;
      // Adjacent force: what the segment needs minus contact minus (at a root) the residual.
      Eigen::Vector3d fa_a = da.required_forces_N[j] - da.contact_forces_N[j];
      Eigen::Vector3d fa_b = db.required_forces_N[j] - db.contact_forces_N[j];
      if (root) {
        fa_a -= da.joint_forces_N[j];
        fa_b -= db.joint_forces_N[j];
      }
      const double w_adj = std::abs(0.5 * (fa_a + fa_b).dot(dc));
      double w_contact = 0.0;
      if (da.in_contact[j] || db.in_contact[j]) {
        const Eigen::Vector3d fc = 0.5 * (da.contact_forces_N[j] + db.contact_forces_N[j]);
        const Eigen::Vector3d tc =
            0.5 * (contact_moment_about_com(da, a, j) + contact_moment_about_com(db, b, j));
        w_contact = std::abs(fc.dot(dc) + tc.dot(dphi));
        // Sliding: the contact point carried rigidly from the state where it
        // touches to the other one; friction mu F_n over its horizontal path.
        Eigen::Vector3d slide;
        if (da.in_contact[j]) {
          const Eigen::Vector3d& p = da.contact_points_m[j];
          slide =
              b.coms_m[j] + (b.rotations[j] * a.rotations[j].conjugate()) * (p - a.coms_m[j]) - p;
        } else {
          const Eigen::Vector3d& p = db.contact_points_m[j];
          slide =
              p - (a.coms_m[j] + (a.rotations[j] * b.rotations[j].conjugate()) * (p - b.coms_m[j]));
        }
        const double normal = std::max(0.0, fc.y());
        w_contact += mu * normal * std::hypot(slide.x(), slide.z());
      }
      double w_res = 0.0;
      if (root) {
        // Residual wrench of this root about its COM, mean of A and B.
        const Eigen::Vector3d fr = 0.5 * (da.joint_forces_N[j] + db.joint_forces_N[j]);
        const Eigen::Vector3d mr =
            0.5 * (da.joint_torques_Nm[j] +
                   (a.joint_positions_m[j] - a.coms_m[j]).cross(da.joint_forces_N[j]) +
                   db.joint_torques_Nm[j] +
                   (b.joint_positions_m[j] - b.coms_m[j]).cross(db.joint_forces_N[j]));
        w_res = std::abs(fr.dot(dc) + mr.dot(dphi));
      }
      g_seg = w_adj + w_contact + w_res;
      if (terms != nullptr) {
        terms->adjacent_work_J[j] = w_adj;
        terms->contact_work_J[j] = w_contact;
        terms->residual_work_J += w_res;
      }
    }
    double g_joint = 0.0;
    if (!model.is_body_root[j]) {
      const int p = model.parents[j];
      const Eigen::Vector3d rel =
          p >= 0 ? Eigen::Vector3d(dphi - ws.rotation_steps[static_cast<std::size_t>(p)]) : dphi;
      g_joint = std::abs(0.5 * (da.joint_torques_Nm[j] + db.joint_torques_Nm[j]).dot(rel));
      if (terms != nullptr) terms->joint_work_J[j] = g_joint;
    }
    extra += g_seg + g_joint;
    if (terms != nullptr) {
      terms->g.segment_J[j] = ws.h.segment_J[j] + g_seg;
      terms->g.joint_J[j] = ws.h.joint_J[j] + g_joint;
    }
  }
  const double impulse = 0.5 * (residual_impulse_energy(model, a, da, transition_time_s) +
                                residual_impulse_energy(model, b, db, transition_time_s));
  if (terms != nullptr) {
    terms->residual_impulse_J = impulse;
    if (model.root() >= 0) terms->g.segment_J[static_cast<std::size_t>(model.root())] += impulse;
  }
  return h_total + extra + impulse;
}

std::vector<double> clip_step_energies(const DynamicsModel& model, const ClipDynamics& clip) {
  std::vector<double> steps;
  if (clip.frame_count < 2) return steps;
  if (clip.joint_count != model.joint_count())
    throw std::invalid_argument("clip dynamics do not match the character model");
  steps.resize(clip.frame_count - 1);
  NewtonEulerWorkspace ws;
  NewtonEulerData ids[2];
  inverse_dynamics(model, clip.state(0), ids[0]);
  for (std::size_t f = 0; f + 1 < clip.frame_count; ++f) {
    NewtonEulerData& cur = ids[f % 2];
    NewtonEulerData& next = ids[(f + 1) % 2];
    inverse_dynamics(model, clip.state(f + 1), next);
    steps[f] =
        full_energy(model, clip.state(f), clip.state(f + 1), clip.frame_time_s, cur, next, ws);
  }
  return steps;
}

std::vector<double> energy_prefix_sums(const std::vector<double>& steps) {
  std::vector<double> p(steps.size() + 1, 0.0);
  for (std::size_t i = 0; i < steps.size(); ++i) p[i + 1] = p[i] + steps[i];
  return p;
}

}  // namespace mocap
