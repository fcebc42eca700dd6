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
  if (joint_forces_N.size() == n && in_contact.size() == n) return;
  for (auto* v : {&joint_forces_N, &joint_torques_Nm, &contact_forces_N, &contact_points_m,
                  &contact_torques_Nm, &required_forces_N, &required_torques_Nm,
                  &origin_velocities_mps, &origin_accelerations_mps2})
    v->resize(n, Eigen::Vector3d::Zero());
  in_contact.resize(n, 0);
  principal_rotations.resize(n, Eigen::Matrix3d::Identity());
  rotational_energies_J.resize(n, 0.0);
  translational_energies_J.resize(n, 0.0);
}

namespace {

// A rotation matrix held in nine scalars (row-major names). Eigen's
// toRotationMatrix() builds the matrix in memory with wide stores that the
// following narrow loads cannot forward from (a ~15-cycle stall per segment
// on x86); nine named scalars stay in registers.
struct Rotation3 {
  double m00, m01, m02, m10, m11, m12, m20, m21, m22;
  explicit Rotation3(const Eigen::Quaterniond& q) {
    const double w = q.w(), x = q.x(), y = q.y(), z = q.z();
    const double tx = 2.0 * x, ty = 2.0 * y, tz = 2.0 * z;
    const double twx = tx * w, twy = ty * w, twz = tz * w;
    const double txx = tx * x, txy = ty * x, txz = tz * x;
    const double tyy = ty * y, tyz = tz * y, tzz = tz * z;
    m00 = 1.0 - (tyy + tzz);
    m01 = txy - twz;
    m02 = txz + twy;
    m10 = txy + twz;
    m11 = 1.0 - (txx + tzz);
    m12 = tyz - twx;
    m20 = txz - twy;
    m21 = tyz + twx;
    m22 = 1.0 - (txx + tyy);
  }
  Eigen::Vector3d operator*(const Eigen::Vector3d& v) const {
    return {m00 * v.x() + m01 * v.y() + m02 * v.z(), m10 * v.x() + m11 * v.y() + m12 * v.z(),
            m20 * v.x() + m21 * v.y() + m22 * v.z()};
  }
  /// R^T v
  Eigen::Vector3d transpose_times(const Eigen::Vector3d& v) const {
    return {m00 * v.x() + m10 * v.y() + m20 * v.z(), m01 * v.x() + m11 * v.y() + m21 * v.z(),
            m02 * v.x() + m12 * v.y() + m22 * v.z()};
  }
  Eigen::Matrix3d matrix() const {
    Eigen::Matrix3d r;
    r << m00, m01, m02, m10, m11, m12, m20, m21, m22;
    return r;
  }
};

}  // namespace

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

  // 1. Requirements and whole-body totals, in one pass. Euler's equation in
  // the segment's principal frame (rotation R P, I_local = P diag(D) P^T,
  // where the inertia is diagonal): tau = R P (D al_p + w_p x D w_p), w_p =
  // (R P)^T w. Moments and the composite inertia are accumulated about a
  // reference point o near the body (the first segment's COM) and moved to
  // the COM at the end:
  //   M_req = sum tau_j + sum (c_j - o) x F_j - (c_G - o) x F_req,
  //   I_G = sum R P D (R P)^T + S - M (|r_G|^2 1 - r_G r_G^T),
  //   S = sum m_j (|r_j|^2 1 - r_j r_j^T),  r = c - o.
  for (std::size_t j = 0; j < n; ++j) {
    if (!(model.masses_kg[j] > 0.0)) {  // massless joints keep zero requirements
      d.required_forces_N[j].setZero();
      d.required_torques_Nm[j].setZero();
      d.principal_rotations[j].setIdentity();
      d.rotational_energies_J[j] = 0.0;
      d.translational_energies_J[j] = 0.0;
    }
    d.contact_forces_N[j].setZero();
    d.contact_torques_Nm[j].setZero();
    d.contact_points_m[j].setZero();
    d.in_contact[j] = 0;
    d.joint_forces_N[j].setZero();
    d.joint_torques_Nm[j].setZero();
  }
  const Eigen::Vector3d origin =
      model.segments.empty()
          ? Eigen::Vector3d::Zero()
          : Eigen::Vector3d(s.coms_m[static_cast<std::size_t>(model.segments[0])]);
  double mass = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();  // sum m r
  Eigen::Vector3d f_req = Eigen::Vector3d::Zero(), m_req_o = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();  // sum m r r^T
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const double m = model.masses_kg[j];
    const Rotation3 rp(s.rotations[j] * model.principal_frames[j]);
    const Eigen::Vector3d& dm = model.principal_moments_kgm2[j];
    const Eigen::Vector3d wp = rp.transpose_times(s.angular_velocities_radps[j]);
    const Eigen::Vector3d alp = rp.transpose_times(s.angular_accelerations_radps2[j]);
    const Eigen::Vector3d iw = dm.cwiseProduct(wp);
    const Eigen::Vector3d fj = m * (s.com_accelerations_mps2[j] - gravity);
    const Eigen::Vector3d tj = rp * Eigen::Vector3d(dm.cwiseProduct(alp) + wp.cross(iw));
    d.required_forces_N[j] = fj;
    d.required_torques_Nm[j] = tj;
    const Eigen::Vector3d r = s.coms_m[j] - origin;
    mass += m;
    first_moment += m * r;
    f_req += fj;
    m_req_o += tj + r.cross(fj);
    d.principal_rotations[j] = rp.matrix();
    d.rotational_energies_J[j] = 0.5 * wp.dot(iw);
    d.translational_energies_J[j] = 0.5 * m * s.com_velocities_mps[j].squaredNorm();
    // Symmetric: only the upper triangle is accumulated here.
    const Eigen::Vector3d mr = m * r;
    second_moment(0, 0) += mr.x() * r.x();
    second_moment(0, 1) += mr.x() * r.y();
    second_moment(0, 2) += mr.x() * r.z();
    second_moment(1, 1) += mr.y() * r.y();
    second_moment(1, 2) += mr.y() * r.z();
    second_moment(2, 2) += mr.z() * r.z();
  }
  second_moment(1, 0) = second_moment(0, 1);
  second_moment(2, 0) = second_moment(0, 2);
  second_moment(2, 1) = second_moment(1, 2);
  const Eigen::Vector3d r_g =
      mass > 0.0 ? Eigen::Vector3d(first_moment / mass) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d com = origin + r_g;
  const Eigen::Vector3d m_req = m_req_o - r_g.cross(f_req);
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

  // 4. What the residual impulse would inject per T^2/2 (see the header).
  const double total = model.total_mass_kg;
  double e = total > 0.0 ? f_res.squaredNorm() / total : 0.0;
  const double negligible = 1e-9 * total * prm.gravity_mps2;
  if (total > 0.0 && m_res.squaredNorm() > negligible * negligible) {
    // S - M r_G r_G^T off the diagonal; the |r|^2 1 parts from the traces.
    const Eigen::Matrix3d shifted = second_moment - mass * r_g * r_g.transpose();
    Eigen::Matrix3d i_g = shifted.trace() * Eigen::Matrix3d::Identity() - shifted;
    // sum_j R P D (R P)^T, upper triangle in scalars: entry (a, b) = sum_k D_k rp(a, k) rp(b, k).
    double s00 = 0.0, s01 = 0.0, s02 = 0.0, s11 = 0.0, s12 = 0.0, s22 = 0.0;
    for (int jj : model.segments) {
      const auto j = static_cast<std::size_t>(jj);
      const Eigen::Matrix3d& rp = d.principal_rotations[j];
      const Eigen::Vector3d& dm = model.principal_moments_kgm2[j];
      for (int k = 0; k < 3; ++k) {
        const double x = rp(0, k), y = rp(1, k), z = rp(2, k), dk = dm[k];
        s00 += dk * x * x;
        s01 += dk * x * y;
        s02 += dk * x * z;
        s11 += dk * y * y;
        s12 += dk * y * z;
        s22 += dk * z * z;
      }
    }
    Eigen::Matrix3d rot;
    rot << s00, s01, s02, s01, s11, s12, s02, s12, s22;
    i_g += rot;
    const double tr = i_g.trace();
    if (tr > 0.0) {
      const Eigen::Matrix3d reg = i_g + 1e-9 * tr * Eigen::Matrix3d::Identity();
      e += m_res.dot(reg.ldlt().solve(m_res));
    }
  }
  d.residual_impulse_coefficient_Jps2 = e;
}

Eigen::Matrix3d composite_inertia(const DynamicsModel& model, const StateView& s,
                                  const Eigen::Vector3d& com) {
  Eigen::Matrix3d i_g = Eigen::Matrix3d::Zero();
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d r = s.coms_m[j] - com;
    // R I R^T = (R P) diag(D) (R P)^T
    const Eigen::Matrix3d rp = (s.rotations[j] * model.principal_frames[j]).toRotationMatrix();
    i_g.noalias() += rp * model.principal_moments_kgm2[j].asDiagonal() * rp.transpose();
    i_g += model.masses_kg[j] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  return i_g;
}

namespace {

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
  detail::check_transition_time(transition_time_s);
  ws.rotation_steps.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    ws.rotation_steps[j] = rotation_step(a.rotations[j], b.rotations[j]);
  // The h part (energy.hpp), with the rotational kinetic energies taken from
  // the inverse dynamics (principal axes: 1/2 sum D_k w_k^2). Equal to
  // approximate_energy(a, b) up to round-off (1e-15 relative).
  const double inv_t = 1.0 / transition_time_s;
  ws.h.reset(n);
  double h_total = 0.0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const double m = model.masses_kg[j];
    const Eigen::Vector3d dc = b.coms_m[j] - a.coms_m[j];
    const double grav = std::abs(m * model.params.gravity_mps2 * dc.y());
    const double k_u = 0.5 * m * dc.squaredNorm() * inv_t * inv_t;
    const double h_seg = grav + transition_kinetic_change(da.translational_energies_J[j], k_u,
                                                          db.translational_energies_J[j]);
    // w^ in A's principal axes (the transition's rotational KE uses A's frame).
    const Eigen::Vector3d w_hat =
        da.principal_rotations[j].transpose() * (ws.rotation_steps[j] * inv_t);
    const double h_joint = transition_kinetic_change(
        da.rotational_energies_J[j],
        0.5 * w_hat.dot(model.principal_moments_kgm2[j].cwiseProduct(w_hat)),
        db.rotational_energies_J[j]);
    ws.h.segment_J[j] = h_seg;
    ws.h.joint_J[j] = h_joint;
    h_total += h_seg + h_joint;
  }
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
        w_contact += mu * normal * std::sqrt(slide.x() * slide.x() + slide.z() * slide.z());
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
  // T^2/2 (|F_res|^2 / M + M_res^T I_G^-1 M_res), mean of A and B: kinetic
  // energy the residual impulse (F T, M T) would give the whole body.
  const double impulse =
      0.25 * transition_time_s * transition_time_s *
      (da.residual_impulse_coefficient_Jps2 + db.residual_impulse_coefficient_Jps2);
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
