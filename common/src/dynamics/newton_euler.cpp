#include "mocap/common/dynamics/newton_euler.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dynamics/lanes.hpp"
#include "mocap/common/util/multiversion.hpp"

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

using lanes::v4d;

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
  // Every array through a local pointer: the stores below (uint8_t in_contact
  // is a character type and may alias anything) would otherwise make the
  // compiler reload each std::vector's data pointer on every access.
  Eigen::Vector3d* const __restrict jf = d.joint_forces_N.data();
  Eigen::Vector3d* const __restrict jt = d.joint_torques_Nm.data();
  Eigen::Vector3d* const __restrict cf = d.contact_forces_N.data();
  Eigen::Vector3d* const __restrict cp = d.contact_points_m.data();
  Eigen::Vector3d* const __restrict ct = d.contact_torques_Nm.data();
  std::uint8_t* const __restrict inc = d.in_contact.data();
  Eigen::Matrix3d* const __restrict prot = d.principal_rotations.data();
  double* const __restrict erot = d.rotational_energies_J.data();
  double* const __restrict etr = d.translational_energies_J.data();
  Eigen::Vector3d* const __restrict rf = d.required_forces_N.data();
  Eigen::Vector3d* const __restrict rt = d.required_torques_Nm.data();
  const Eigen::Vector3d* const xs = s.joint_positions_m;
  const Eigen::Quaterniond* const qs = s.rotations;
  const Eigen::Vector3d* const cs = s.coms_m;
  const Eigen::Vector3d* const vs = s.com_velocities_mps;
  const Eigen::Vector3d* const acs = s.com_accelerations_mps2;
  const Eigen::Vector3d* const ws = s.angular_velocities_radps;
  const Eigen::Vector3d* const als = s.angular_accelerations_radps2;
  const double* const mass_of = model.masses_kg.data();
  const Eigen::Quaterniond* const pf = model.principal_frames.data();
  const Eigen::Vector3d* const pm = model.principal_moments_kgm2.data();
  const Eigen::Vector3d* const tips = model.tips_local_m.data();
  const std::uint8_t* const tipc = model.tip_contacts.data();
  const std::uint8_t* const term = model.is_term_joint.data();
  const std::uint8_t* const broot = model.is_body_root.data();
  const int* const par = model.parents.data();
  const EnergyParams& prm = model.params;

  // 1. Requirements and whole-body totals, in one pass. Euler's equation in
  // the segment's principal frame (rotation R P, I_local = P diag(D) P^T,
  // where the inertia is diagonal): tau = R P (D al_p + w_p x D w_p), w_p =
  // (R P)^T w. Moments and the composite inertia are accumulated about a
  // reference point o near the body (the first segment's COM) and moved to
  // the COM at the end:
  //   M_req = sum tau_j + sum (c_j - o) x F_j - (c_G - o) x F_req,
  //   I_G = sum R P D (R P)^T + S - M (|r_G|^2 1 - r_G r_G^T),
  //   S = sum m_j (|r_j|^2 1 - r_j r_j^T),  r = c - o.
  // Contact arrays are zero wherever in_contact is 0 (resize() starts them at
  // zero and every call restores it), so only the previous call's contacts
  // need clearing; f_j, n_j start at zero (pass 3 accumulates the children's).
  for (std::size_t j = 0; j < n; ++j) {
    if (inc[j]) {
      cf[j].setZero();
      ct[j].setZero();
      cp[j].setZero();
      inc[j] = 0;
    }
    jf[j].setZero();
    jt[j].setZero();
    if (!(mass_of[j] > 0.0)) {
      rf[j].setZero();
      rt[j].setZero();
      prot[j].setIdentity();
      erot[j] = 0.0;
      etr[j] = 0.0;
    }
  }
  const Eigen::Vector3d origin =
      model.segments.empty() ? Eigen::Vector3d::Zero()
                             : Eigen::Vector3d(cs[static_cast<std::size_t>(model.segments[0])]);
  // Four segments at a time in the lanes of a 4-double vector (AVX2 in the
  // x86-64-v3 clone, two SSE2 halves in the baseline one); the last group is
  // padded with a copy of its first segment whose mass and moments are zeroed,
  // so the padding adds exactly nothing. Sums are kept per lane and added in
  // lane order at the end (deterministic).
  const std::size_t nseg = model.segments.size();
  const int* const seg = model.segments.data();
  const double ox = origin.x(), oy = origin.y(), oz = origin.z();
  const double g_up = prm.gravity_mps2;  // a - gravity = (a_x, a_y + g, a_z)
  v4d s_mass{}, s_fm0{}, s_fm1{}, s_fm2{}, s_f0{}, s_f1{}, s_f2{}, s_m0{}, s_m1{}, s_m2{};
  v4d s_s00{}, s_s01{}, s_s02{}, s_s11{}, s_s12{}, s_s22{};  // sum m r r^T (upper)
  v4d s_i00{}, s_i01{}, s_i02{}, s_i11{}, s_i12{}, s_i22{};  // sum R P D (R P)^T (upper)
  for (std::size_t k0 = 0; k0 < nseg; k0 += 4) {
    lanes::Group grp;
    lanes::group(seg, nseg, k0, grp);
    const std::size_t i0 = grp.idx[0], i1 = grp.idx[1], i2 = grp.idx[2], i3 = grp.idx[3];
    const v4d live = grp.live;
    lanes::Quat4 qq, pp;
    lanes::load(qs, grp.idx, qq);
    lanes::load(pf, grp.idx, pp);
    const v4d qw = qq.w, qx = qq.x, qy = qq.y, qz = qq.z;
    const v4d pw = pp.w, px = pp.x, py = pp.y, pz = pp.z;
    const v4d m = live * v4d{mass_of[i0], mass_of[i1], mass_of[i2], mass_of[i3]};
    const v4d d0 = live * v4d{pm[i0].x(), pm[i1].x(), pm[i2].x(), pm[i3].x()};
    const v4d d1 = live * v4d{pm[i0].y(), pm[i1].y(), pm[i2].y(), pm[i3].y()};
    const v4d d2 = live * v4d{pm[i0].z(), pm[i1].z(), pm[i2].z(), pm[i3].z()};
    const v4d wx = v4d{ws[i0].x(), ws[i1].x(), ws[i2].x(), ws[i3].x()};
    const v4d wy = v4d{ws[i0].y(), ws[i1].y(), ws[i2].y(), ws[i3].y()};
    const v4d wz = v4d{ws[i0].z(), ws[i1].z(), ws[i2].z(), ws[i3].z()};
    const v4d lx = v4d{als[i0].x(), als[i1].x(), als[i2].x(), als[i3].x()};
    const v4d ly = v4d{als[i0].y(), als[i1].y(), als[i2].y(), als[i3].y()};
    const v4d lz = v4d{als[i0].z(), als[i1].z(), als[i2].z(), als[i3].z()};
    const v4d ax = v4d{acs[i0].x(), acs[i1].x(), acs[i2].x(), acs[i3].x()};
    const v4d ay = v4d{acs[i0].y(), acs[i1].y(), acs[i2].y(), acs[i3].y()};
    const v4d az = v4d{acs[i0].z(), acs[i1].z(), acs[i2].z(), acs[i3].z()};
    const v4d cx{cs[i0].x(), cs[i1].x(), cs[i2].x(), cs[i3].x()};
    const v4d cy{cs[i0].y(), cs[i1].y(), cs[i2].y(), cs[i3].y()};
    const v4d cz{cs[i0].z(), cs[i1].z(), cs[i2].z(), cs[i3].z()};
    const v4d rx = cx - ox, ry = cy - oy, rz = cz - oz;
    const v4d vx = v4d{vs[i0].x(), vs[i1].x(), vs[i2].x(), vs[i3].x()};
    const v4d vy = v4d{vs[i0].y(), vs[i1].y(), vs[i2].y(), vs[i3].y()};
    const v4d vz = v4d{vs[i0].z(), vs[i1].z(), vs[i2].z(), vs[i3].z()};
    // R P as a quaternion (Hamilton product q p), then its matrix in nine
    // registers (no Eigen matrix in memory: its wide stores would stall the
    // narrow loads that follow).
    const v4d w = qw * pw - qx * px - qy * py - qz * pz;
    const v4d x = qw * px + qx * pw + qy * pz - qz * py;
    const v4d y = qw * py + qy * pw + qz * px - qx * pz;
    const v4d z = qw * pz + qz * pw + qx * py - qy * px;
    const v4d tx = 2.0 * x, ty = 2.0 * y, tz = 2.0 * z;
    const v4d twx = tx * w, twy = ty * w, twz = tz * w;
    const v4d txx = tx * x, txy = ty * x, txz = tz * x;
    const v4d tyy = ty * y, tyz = tz * y, tzz = tz * z;
    const v4d m00 = 1.0 - (tyy + tzz), m01 = txy - twz, m02 = txz + twy;
    const v4d m10 = txy + twz, m11 = 1.0 - (txx + tzz), m12 = tyz - twx;
    const v4d m20 = txz - twy, m21 = tyz + twx, m22 = 1.0 - (txx + tyy);
    // w_p = (R P)^T w, al_p = (R P)^T al; tau = R P (D al_p + w_p x D w_p).
    const v4d wp0 = m00 * wx + m10 * wy + m20 * wz;
    const v4d wp1 = m01 * wx + m11 * wy + m21 * wz;
    const v4d wp2 = m02 * wx + m12 * wy + m22 * wz;
    const v4d al0 = m00 * lx + m10 * ly + m20 * lz;
    const v4d al1 = m01 * lx + m11 * ly + m21 * lz;
    const v4d al2 = m02 * lx + m12 * ly + m22 * lz;
    const v4d iw0 = d0 * wp0, iw1 = d1 * wp1, iw2 = d2 * wp2;
    const v4d e0 = d0 * al0 + (wp1 * iw2 - wp2 * iw1);
    const v4d e1 = d1 * al1 + (wp2 * iw0 - wp0 * iw2);
    const v4d e2 = d2 * al2 + (wp0 * iw1 - wp1 * iw0);
    const v4d t0 = m00 * e0 + m01 * e1 + m02 * e2;
    const v4d t1 = m10 * e0 + m11 * e1 + m12 * e2;
    const v4d t2 = m20 * e0 + m21 * e1 + m22 * e2;
    const v4d f0 = m * ax, f1 = m * (ay + g_up), f2 = m * az;
    const v4d erot_l = 0.5 * (wp0 * iw0 + wp1 * iw1 + wp2 * iw2);
    const v4d etr_l = 0.5 * m * (vx * vx + vy * vy + vz * vz);
    s_mass += m;
    const v4d mrx = m * rx, mry = m * ry, mrz = m * rz;
    s_fm0 += mrx;
    s_fm1 += mry;
    s_fm2 += mrz;
    s_f0 += f0;
    s_f1 += f1;
    s_f2 += f2;
    s_m0 += t0 + (ry * f2 - rz * f1);
    s_m1 += t1 + (rz * f0 - rx * f2);
    s_m2 += t2 + (rx * f1 - ry * f0);
    s_s00 += mrx * rx;
    s_s01 += mrx * ry;
    s_s02 += mrx * rz;
    s_s11 += mry * ry;
    s_s12 += mry * rz;
    s_s22 += mrz * rz;
    // entry (a, b) of R P D (R P)^T = sum_k D_k rp(a, k) rp(b, k)
    s_i00 += d0 * m00 * m00 + d1 * m01 * m01 + d2 * m02 * m02;
    s_i01 += d0 * m00 * m10 + d1 * m01 * m11 + d2 * m02 * m12;
    s_i02 += d0 * m00 * m20 + d1 * m01 * m21 + d2 * m02 * m22;
    s_i11 += d0 * m10 * m10 + d1 * m11 * m11 + d2 * m12 * m12;
    s_i12 += d0 * m10 * m20 + d1 * m11 * m21 + d2 * m12 * m22;
    s_i22 += d0 * m20 * m20 + d1 * m21 * m21 + d2 * m22 * m22;
    for (std::size_t l = 0; l < grp.count; ++l) {
      const std::size_t j = grp.idx[l];
      rf[j] = Eigen::Vector3d(f0[l], f1[l], f2[l]);
      rt[j] = Eigen::Vector3d(t0[l], t1[l], t2[l]);
      Eigen::Matrix3d& r = prot[j];
      r(0, 0) = m00[l];
      r(0, 1) = m01[l];
      r(0, 2) = m02[l];
      r(1, 0) = m10[l];
      r(1, 1) = m11[l];
      r(1, 2) = m12[l];
      r(2, 0) = m20[l];
      r(2, 1) = m21[l];
      r(2, 2) = m22[l];
      erot[j] = erot_l[l];
      etr[j] = etr_l[l];
    }
  }
  const double mass = lanes::sum(s_mass);
  const Eigen::Vector3d first_moment(lanes::sum(s_fm0), lanes::sum(s_fm1), lanes::sum(s_fm2));
  const Eigen::Vector3d f_req(lanes::sum(s_f0), lanes::sum(s_f1), lanes::sum(s_f2));
  const Eigen::Vector3d m_req_o(lanes::sum(s_m0), lanes::sum(s_m1), lanes::sum(s_m2));
  // The symmetric matrix of six upper-triangle lane sums.
  const auto symmetric = [](const v4d& a00, const v4d& a01, const v4d& a02, const v4d& a11,
                            const v4d& a12, const v4d& a22) {
    const double x01 = lanes::sum(a01), x02 = lanes::sum(a02), x12 = lanes::sum(a12);
    Eigen::Matrix3d m;
    m << lanes::sum(a00), x01, x02, x01, lanes::sum(a11), x12, x02, x12, lanes::sum(a22);
    return m;
  };
  const Eigen::Matrix3d second_moment =  // sum m r r^T
      symmetric(s_s00, s_s01, s_s02, s_s11, s_s12, s_s22);
  const Eigen::Matrix3d rotational_inertia =  // sum R P D (R P)^T
      symmetric(s_i00, s_i01, s_i02, s_i11, s_i12, s_i22);
  const Eigen::Vector3d r_g =
      mass > 0.0 ? Eigen::Vector3d(first_moment / mass) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d com = origin + r_g;
  const Eigen::Vector3d m_req = m_req_o - r_g.cross(f_req);
  d.com_m = com;

  // 2. Contacts.
  std::size_t contacts = 0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d& x = xs[j];
    // Far above the ground even at the tip's reach: no contact (skips the rotation).
    const double above = x.y() - prm.ground_height_m - prm.contact_height_m;
    if (above > 0.0 && above * above > tips[j].squaredNorm()) continue;
    const Eigen::Vector3d tip = x + qs[j] * tips[j];
    const Eigen::Vector3d& p = (tipc[j] && tip.y() < x.y()) ? tip : x;
    if (p.y() - prm.ground_height_m > prm.contact_height_m) continue;
    const Eigen::Vector3d vp = vs[j] + ws[j].cross(p - cs[j]);
    if (vp.norm() > prm.contact_speed_mps) continue;
    inc[j] = 1;
    cp[j] = p;
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
      if (!inc[j]) continue;
      cf[j] = fk;
      m_points += (cp[j] - com).cross(fk);
    }
    Eigen::Vector3d m_free = m_req - m_points;
    const double m_max = fn * prm.contact_patch_radius_m;
    const double m_norm = m_free.norm();
    if (m_norm > m_max) m_free *= m_max / m_norm;
    for (int jj : model.segments) {
      const auto j = static_cast<std::size_t>(jj);
      if (!inc[j]) continue;
      ct[j] = share * m_free;
    }
  }

  // 3. Leaves -> root (children have larger indices and are done first;
  // f_j, n_j already hold the segment's own and its contacts' parts).
  Eigen::Vector3d f_res = Eigen::Vector3d::Zero(), m_res = Eigen::Vector3d::Zero();
  for (std::size_t j = n; j-- > 0;) {
    if (!term[j]) continue;
    const Eigen::Vector3d& x = xs[j];
    const Eigen::Vector3d& fj = rf[j];
    const Eigen::Vector3d& fc = cf[j];
    const Eigen::Vector3d f = fj - fc + jf[j];
    Eigen::Vector3d t = rt[j] + (cs[j] - x).cross(fj) - ct[j] + jt[j];
    if (inc[j]) t -= (cp[j] - x).cross(fc);
    jf[j] = f;
    jt[j] = t;
    if (broot[j]) {
      f_res += f;
      m_res += t + (x - com).cross(f);
      continue;
    }
    const int p = par[j];
    if (p >= 0) {
      const auto pp = static_cast<std::size_t>(p);
      jf[pp] += f;
      jt[pp] += t + (x - xs[pp]).cross(f);
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
    i_g += rotational_inertia;
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
  Eigen::Vector3d* const __restrict steps = ws.rotation_steps.data();
  const Eigen::Quaterniond* const qa = a.rotations;
  const Eigen::Quaterniond* const qb = b.rotations;
  // Rotation steps log(q_B q_A^-1) of every joint, four at a time: the same
  // series as rotation_step() (x = |v| / w < 1/8, atan(x) / x to x^18), the
  // rare larger steps through rotation_vector(). Bitwise equal rotations give
  // exactly zero (selected, so whatever the compiler fuses).
  for (std::size_t j0 = 0; j0 < n; j0 += 4) {
    const std::size_t idx[4] = {j0, std::min(j0 + 1, n - 1), std::min(j0 + 2, n - 1),
                                std::min(j0 + 3, n - 1)};
    lanes::Quat4 from, to;
    lanes::load(qa, idx, from);
    lanes::load(qb, idx, to);
    lanes::Quat4 q;
    v4d x, y, z;
    lanes::v4i series, same;
    lanes::rotation_steps(from, to, q, x, y, z, series, same);
    const std::size_t count = std::min<std::size_t>(4, n - j0);
    for (std::size_t l = 0; l < count; ++l) {
      if (same[l])
        steps[j0 + l].setZero();
      else if (series[l])
        steps[j0 + l] = Eigen::Vector3d(x[l], y[l], z[l]);
      else
        steps[j0 + l] = rotation_vector(Eigen::Quaterniond(q.w[l], q.x[l], q.y[l], q.z[l]));
    }
  }
  // The h part (energy.hpp), with the kinetic energies taken from the inverse
  // dynamics (rotational: principal axes, 1/2 sum D_k w_k^2), four segments at
  // a time (padding lanes as in inverse_dynamics: massless, discarded). Equal
  // to approximate_energy(a, b) up to round-off (1e-15 relative).
  const double inv_t = 1.0 / transition_time_s;
  const double smooth = ws.smoothing_J;
  const auto sabs = [smooth](double x) {
    return smooth > 0.0 ? std::sqrt(x * x + smooth * smooth) - smooth : std::abs(x);
  };
  const auto smax = [&sabs](double u, double v) { return 0.5 * (u + v + sabs(u - v)); };
  ws.h.reset(n);
  double* const __restrict h_seg_out = ws.h.segment_J.data();
  double* const __restrict h_joint_out = ws.h.joint_J.data();
  const std::size_t nseg = model.segments.size();
  const int* const seg = model.segments.data();
  const Eigen::Vector3d* const ca = a.coms_m;
  const Eigen::Vector3d* const cb = b.coms_m;
  const double* const mass_of = model.masses_kg.data();
  const Eigen::Vector3d* const pm = model.principal_moments_kgm2.data();
  const Eigen::Matrix3d* const prot_a = da.principal_rotations.data();
  const double* const eta = da.translational_energies_J.data();
  const double* const etb = db.translational_energies_J.data();
  const double* const era = da.rotational_energies_J.data();
  const double* const erb = db.rotational_energies_J.data();
  const double g_acc = model.params.gravity_mps2;
  v4d h_sum{};
  for (std::size_t k0 = 0; k0 < nseg; k0 += 4) {
    lanes::Group grp;
    lanes::group(seg, nseg, k0, grp);
    const std::size_t i0 = grp.idx[0], i1 = grp.idx[1], i2 = grp.idx[2], i3 = grp.idx[3];
    const v4d live = grp.live;
    const v4d m = live * v4d{mass_of[i0], mass_of[i1], mass_of[i2], mass_of[i3]};
    const v4d dcx = v4d{cb[i0].x(), cb[i1].x(), cb[i2].x(), cb[i3].x()} -
                    v4d{ca[i0].x(), ca[i1].x(), ca[i2].x(), ca[i3].x()};
    const v4d dcy = v4d{cb[i0].y(), cb[i1].y(), cb[i2].y(), cb[i3].y()} -
                    v4d{ca[i0].y(), ca[i1].y(), ca[i2].y(), ca[i3].y()};
    const v4d dcz = v4d{cb[i0].z(), cb[i1].z(), cb[i2].z(), cb[i3].z()} -
                    v4d{ca[i0].z(), ca[i1].z(), ca[i2].z(), ca[i3].z()};
    const v4d grav_signed = m * g_acc * dcy;
    const v4d grav = grav_signed < 0.0 ? -grav_signed : grav_signed;
    const v4d k_u = 0.5 * m * (dcx * dcx + dcy * dcy + dcz * dcz) * inv_t * inv_t;
    const v4d ka = live * v4d{eta[i0], eta[i1], eta[i2], eta[i3]};
    const v4d kb = live * v4d{etb[i0], etb[i1], etb[i2], etb[i3]};
    // transition_kinetic_change, lane-wise
    const v4d dk = kb - ka;
    const v4d adk = dk < 0.0 ? -dk : dk;
    const v4d through = 2.0 * k_u - ka - kb;
    v4d h_seg = grav + (adk > through ? adk : through);
    // w^ in A's principal axes: (R P)_A^T dphi / T.
    const v4d sx = inv_t * v4d{steps[i0].x(), steps[i1].x(), steps[i2].x(), steps[i3].x()};
    const v4d sy = inv_t * v4d{steps[i0].y(), steps[i1].y(), steps[i2].y(), steps[i3].y()};
    const v4d sz = inv_t * v4d{steps[i0].z(), steps[i1].z(), steps[i2].z(), steps[i3].z()};
    v4d k_w{};
    for (int k = 0; k < 3; ++k) {  // column k of R P: principal axis k
      const v4d px{prot_a[i0](0, k), prot_a[i1](0, k), prot_a[i2](0, k), prot_a[i3](0, k)};
      const v4d py{prot_a[i0](1, k), prot_a[i1](1, k), prot_a[i2](1, k), prot_a[i3](1, k)};
      const v4d pz{prot_a[i0](2, k), prot_a[i1](2, k), prot_a[i2](2, k), prot_a[i3](2, k)};
      const v4d dk_m = live * v4d{pm[i0][k], pm[i1][k], pm[i2][k], pm[i3][k]};
      const v4d wk = px * sx + py * sy + pz * sz;
      k_w += dk_m * wk * wk;
    }
    k_w *= 0.5;
    const v4d ra = live * v4d{era[i0], era[i1], era[i2], era[i3]};
    const v4d rb = live * v4d{erb[i0], erb[i1], erb[i2], erb[i3]};
    const v4d dr = rb - ra;
    const v4d adr = dr < 0.0 ? -dr : dr;
    const v4d through_r = 2.0 * k_w - ra - rb;
    v4d h_joint = adr > through_r ? adr : through_r;
    if (smooth > 0.0) {
      // Smoothed (refinement only): |x| -> sqrt(x^2 + s^2) - s, max(a, b) -> (a + b + |a - b|) / 2.
      for (std::size_t l = 0; l < grp.count; ++l) {
        h_seg[l] = sabs(grav_signed[l]) + smax(sabs(dk[l]), through[l]);
        h_joint[l] = smax(sabs(dr[l]), through_r[l]);
      }
    }
    h_sum += h_seg + h_joint;
    for (std::size_t l = 0; l < grp.count; ++l) {
      h_seg_out[grp.idx[l]] = h_seg[l];
      h_joint_out[grp.idx[l]] = h_joint[l];
    }
  }
  const double h_total = lanes::sum(h_sum);
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
    const Eigen::Vector3d& dphi = steps[j];
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
      const double w_adj = sabs(0.5 * (fa_a + fa_b).dot(dc));
      double w_contact = 0.0;
      if (da.in_contact[j] || db.in_contact[j]) {
        const Eigen::Vector3d fc = 0.5 * (da.contact_forces_N[j] + db.contact_forces_N[j]);
        const Eigen::Vector3d tc =
            0.5 * (contact_moment_about_com(da, a, j) + contact_moment_about_com(db, b, j));
        w_contact = sabs(fc.dot(dc) + tc.dot(dphi));
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
        const double friction = mu * normal;
        w_contact +=
            smooth > 0.0
                ? std::sqrt(friction * friction * (slide.x() * slide.x() + slide.z() * slide.z()) +
                            smooth * smooth) -
                      smooth
                : friction * std::sqrt(slide.x() * slide.x() + slide.z() * slide.z());
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
        w_res = sabs(fr.dot(dc) + mr.dot(dphi));
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
          p >= 0 ? Eigen::Vector3d(dphi - steps[static_cast<std::size_t>(p)]) : dphi;
      g_joint = sabs(0.5 * (da.joint_torques_Nm[j] + db.joint_torques_Nm[j]).dot(rel));
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
