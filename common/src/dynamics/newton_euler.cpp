#include "mocap/common/dynamics/newton_euler.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dynamics/lanes.hpp"
#include "dynamics/step_geometry.hpp"
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

namespace {

// x, y and z of four segments, lane-wise.
struct Vec4 {
  v4d x, y, z;
};

// A 3x3 matrix of four segments, lane-wise, in nine registers (no Eigen
// matrix in memory: its wide stores would stall the narrow loads that follow).
struct Mat4 {
  v4d m00, m01, m02, m10, m11, m12, m20, m21, m22;
};

// GCC 12 reports false maybe-uninitialized warnings on vectors built lane by
// lane into a struct member (as lanes.hpp's).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
// The vectors v[i[0]] .. v[i[3]], lane-wise.
[[gnu::always_inline]] inline void gather(const Eigen::Vector3d* v, const std::size_t (&i)[4],
                                          Vec4& out) {
  out.x = v4d{v[i[0]].x(), v[i[1]].x(), v[i[2]].x(), v[i[3]].x()};
  out.y = v4d{v[i[0]].y(), v[i[1]].y(), v[i[2]].y(), v[i[3]].y()};
  out.z = v4d{v[i[0]].z(), v[i[1]].z(), v[i[2]].z(), v[i[3]].z()};
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

// The matrix of R P, the segment's principal axes in the world: the
// quaternion q p (Hamilton product) as a rotation matrix.
[[gnu::always_inline]] inline void principal_rotation(const lanes::Quat4& q, const lanes::Quat4& p,
                                                      Mat4& r) {
  const v4d w = q.w * p.w - q.x * p.x - q.y * p.y - q.z * p.z;
  const v4d x = q.w * p.x + q.x * p.w + q.y * p.z - q.z * p.y;
  const v4d y = q.w * p.y + q.y * p.w + q.z * p.x - q.x * p.z;
  const v4d z = q.w * p.z + q.z * p.w + q.x * p.y - q.y * p.x;
  const v4d tx = 2.0 * x, ty = 2.0 * y, tz = 2.0 * z;
  const v4d twx = tx * w, twy = ty * w, twz = tz * w;
  const v4d txx = tx * x, txy = ty * x, txz = tz * x;
  const v4d tyy = ty * y, tyz = tz * y, tzz = tz * z;
  r.m00 = 1.0 - (tyy + tzz);
  r.m01 = txy - twz;
  r.m02 = txz + twy;
  r.m10 = txy + twz;
  r.m11 = 1.0 - (txx + tzz);
  r.m12 = tyz - twx;
  r.m20 = txz - twy;
  r.m21 = tyz + twx;
  r.m22 = 1.0 - (txx + tyy);
}

// Euler's equation in the principal frame (rotation r = R P, moments d):
// w_p = r^T w, al_p = r^T al, tau = r (D al_p + w_p x D w_p) (N m), and the
// rotational kinetic energy 1/2 w_p^T D w_p (J).
[[gnu::always_inline]] inline void euler_torque(const Mat4& r, const Vec4& d, const Vec4& w,
                                                const Vec4& al, Vec4& tau, v4d& energy) {
  const v4d wp0 = r.m00 * w.x + r.m10 * w.y + r.m20 * w.z;
  const v4d wp1 = r.m01 * w.x + r.m11 * w.y + r.m21 * w.z;
  const v4d wp2 = r.m02 * w.x + r.m12 * w.y + r.m22 * w.z;
  const v4d al0 = r.m00 * al.x + r.m10 * al.y + r.m20 * al.z;
  const v4d al1 = r.m01 * al.x + r.m11 * al.y + r.m21 * al.z;
  const v4d al2 = r.m02 * al.x + r.m12 * al.y + r.m22 * al.z;
  const v4d iw0 = d.x * wp0, iw1 = d.y * wp1, iw2 = d.z * wp2;
  const v4d e0 = d.x * al0 + (wp1 * iw2 - wp2 * iw1);
  const v4d e1 = d.y * al1 + (wp2 * iw0 - wp0 * iw2);
  const v4d e2 = d.z * al2 + (wp0 * iw1 - wp1 * iw0);
  tau.x = r.m00 * e0 + r.m01 * e1 + r.m02 * e2;
  tau.y = r.m10 * e0 + r.m11 * e1 + r.m12 * e2;
  tau.z = r.m20 * e0 + r.m21 * e1 + r.m22 * e2;
  energy = 0.5 * (wp0 * iw0 + wp1 * iw1 + wp2 * iw2);
}

// The whole-body totals of pass 1, about the reference point o (the first
// segment's COM): mass (kg), first moment sum m r (kg m), F_req (N), M_req
// about o (N m), second moment S = sum m r r^T and sum R P D (R P)^T (kg m^2).
struct BodyTotals {
  double mass = 0.0;
  Eigen::Vector3d first_moment, f_req, m_req_o;
  Eigen::Matrix3d second_moment, rotational_inertia;
};

// BodyTotals kept per lane, four segments at a time; totals() adds the lanes
// in lane order (deterministic).
struct RequirementSums {
  v4d mass{}, fm0{}, fm1{}, fm2{}, f0{}, f1{}, f2{}, m0{}, m1{}, m2{};
  v4d s00{}, s01{}, s02{}, s11{}, s12{}, s22{};  // sum m r r^T (upper)
  v4d i00{}, i01{}, i02{}, i11{}, i12{}, i22{};  // sum R P D (R P)^T (upper)

  // Four segments of mass m at r = c - o, needing force f and torque t,
  // principal axes rp and moments d.
  [[gnu::always_inline]] void add(const v4d& m, const Vec4& r, const Vec4& f, const Vec4& t,
                                  const Mat4& rp, const Vec4& d) {
    mass += m;
    const v4d mrx = m * r.x, mry = m * r.y, mrz = m * r.z;
    fm0 += mrx;
    fm1 += mry;
    fm2 += mrz;
    f0 += f.x;
    f1 += f.y;
    f2 += f.z;
    m0 += t.x + (r.y * f.z - r.z * f.y);
    m1 += t.y + (r.z * f.x - r.x * f.z);
    m2 += t.z + (r.x * f.y - r.y * f.x);
    s00 += mrx * r.x;
    s01 += mrx * r.y;
    s02 += mrx * r.z;
    s11 += mry * r.y;
    s12 += mry * r.z;
    s22 += mrz * r.z;
    // entry (a, b) of R P D (R P)^T = sum_k D_k rp(a, k) rp(b, k)
    i00 += d.x * rp.m00 * rp.m00 + d.y * rp.m01 * rp.m01 + d.z * rp.m02 * rp.m02;
    i01 += d.x * rp.m00 * rp.m10 + d.y * rp.m01 * rp.m11 + d.z * rp.m02 * rp.m12;
    i02 += d.x * rp.m00 * rp.m20 + d.y * rp.m01 * rp.m21 + d.z * rp.m02 * rp.m22;
    i11 += d.x * rp.m10 * rp.m10 + d.y * rp.m11 * rp.m11 + d.z * rp.m12 * rp.m12;
    i12 += d.x * rp.m10 * rp.m20 + d.y * rp.m11 * rp.m21 + d.z * rp.m12 * rp.m22;
    i22 += d.x * rp.m20 * rp.m20 + d.y * rp.m21 * rp.m21 + d.z * rp.m22 * rp.m22;
  }

  [[gnu::always_inline]] void totals(BodyTotals& out) const {
    out.mass = lanes::sum(mass);
    out.first_moment = Eigen::Vector3d(lanes::sum(fm0), lanes::sum(fm1), lanes::sum(fm2));
    out.f_req = Eigen::Vector3d(lanes::sum(f0), lanes::sum(f1), lanes::sum(f2));
    out.m_req_o = Eigen::Vector3d(lanes::sum(m0), lanes::sum(m1), lanes::sum(m2));
    out.second_moment = symmetric(s00, s01, s02, s11, s12, s22);
    out.rotational_inertia = symmetric(i00, i01, i02, i11, i12, i22);
  }

  // The symmetric matrix of six upper-triangle lane sums.
  static Eigen::Matrix3d symmetric(const v4d& a00, const v4d& a01, const v4d& a02, const v4d& a11,
                                   const v4d& a12, const v4d& a22) {
    const double x01 = lanes::sum(a01), x02 = lanes::sum(a02), x12 = lanes::sum(a12);
    Eigen::Matrix3d m;
    m << lanes::sum(a00), x01, x02, x01, lanes::sum(a11), x12, x02, x12, lanes::sum(a22);
    return m;
  }
};

// Checks the state against the model, sizes d, and clears what the previous
// call left: the contact arrays are zero wherever in_contact is 0 (resize()
// starts them at zero and every call restores it), so only the previous
// call's contacts need clearing; f_j, n_j start at zero (the backward pass
// accumulates the children's); massless joints get zero requirements.
[[gnu::always_inline]] inline void start_inverse_dynamics(const DynamicsModel& model,
                                                          const StateView& s, NewtonEulerData& d) {
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
  const double* const mass_of = model.masses_kg.data();
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
}

// Pass 1, requirements and whole-body totals: per segment F_j = m (a - g)
// (N), tau_j = I alpha + w x I w (N m) by Euler's equation in the segment's
// principal frame (rotation R P, I_local = P diag(D) P^T), with its principal
// rotation and kinetic energies (J) into d; the totals about `origin`
// (BodyTotals). Four segments at a time in the lanes of a 4-double vector
// (AVX2 in the x86-64-v3 clone, two SSE2 halves in the baseline one); the
// last group is padded with a copy of its first segment whose mass and
// moments are zeroed, so the padding adds exactly nothing.
[[gnu::always_inline]] inline void segment_requirements(const DynamicsModel& model,
                                                        const StateView& s,
                                                        const Eigen::Vector3d& origin,
                                                        NewtonEulerData& d, BodyTotals& out) {
  Eigen::Matrix3d* const __restrict prot = d.principal_rotations.data();
  double* const __restrict erot = d.rotational_energies_J.data();
  double* const __restrict etr = d.translational_energies_J.data();
  Eigen::Vector3d* const __restrict rf = d.required_forces_N.data();
  Eigen::Vector3d* const __restrict rt = d.required_torques_Nm.data();
  const double* const mass_of = model.masses_kg.data();
  const std::size_t nseg = model.segments.size();
  const int* const seg = model.segments.data();
  const double ox = origin.x(), oy = origin.y(), oz = origin.z();
  const double g_up = model.params.gravity_mps2;  // a - gravity = (a_x, a_y + g, a_z)
  RequirementSums sums;
  for (std::size_t k0 = 0; k0 < nseg; k0 += 4) {
    lanes::Group grp;
    lanes::group(seg, nseg, k0, grp);
    const std::size_t i0 = grp.idx[0], i1 = grp.idx[1], i2 = grp.idx[2], i3 = grp.idx[3];
    const v4d live = grp.live;
    lanes::Quat4 qq, pp;
    lanes::load(s.rotations, grp.idx, qq);
    lanes::load(model.principal_frames.data(), grp.idx, pp);
    Vec4 dm, w, al, acc, c, v;
    gather(model.principal_moments_kgm2.data(), grp.idx, dm);
    dm.x = live * dm.x;
    dm.y = live * dm.y;
    dm.z = live * dm.z;
    gather(s.angular_velocities_radps, grp.idx, w);
    gather(s.angular_accelerations_radps2, grp.idx, al);
    gather(s.com_accelerations_mps2, grp.idx, acc);
    gather(s.coms_m, grp.idx, c);
    gather(s.com_velocities_mps, grp.idx, v);
    const v4d m = live * v4d{mass_of[i0], mass_of[i1], mass_of[i2], mass_of[i3]};
    const Vec4 r{c.x - ox, c.y - oy, c.z - oz};
    Mat4 rp;
    principal_rotation(qq, pp, rp);
    Vec4 t;
    v4d erot_l;
    euler_torque(rp, dm, w, al, t, erot_l);
    const Vec4 f{m * acc.x, m * (acc.y + g_up), m * acc.z};
    const v4d etr_l = 0.5 * m * (v.x * v.x + v.y * v.y + v.z * v.z);
    sums.add(m, r, f, t, rp, dm);
    for (std::size_t l = 0; l < grp.count; ++l) {
      const std::size_t j = grp.idx[l];
      rf[j] = Eigen::Vector3d(f.x[l], f.y[l], f.z[l]);
      rt[j] = Eigen::Vector3d(t.x[l], t.y[l], t.z[l]);
      Eigen::Matrix3d& pr = prot[j];
      pr(0, 0) = rp.m00[l];
      pr(0, 1) = rp.m01[l];
      pr(0, 2) = rp.m02[l];
      pr(1, 0) = rp.m10[l];
      pr(1, 1) = rp.m11[l];
      pr(1, 2) = rp.m12[l];
      pr(2, 0) = rp.m20[l];
      pr(2, 1) = rp.m21[l];
      pr(2, 2) = rp.m22[l];
      erot[j] = erot_l[l];
      etr[j] = etr_l[l];
    }
  }
  sums.totals(out);
}

// Pass 2a, contact detection: a segment touches the ground when its lower end
// (its tip where it has one below the joint, else the joint) is within
// contact_height_m of the ground and moves slower than contact_speed_mps.
// Marks in_contact and the contact point (m); returns how many touch.
[[gnu::always_inline]] inline std::size_t find_contacts(const DynamicsModel& model,
                                                        const StateView& s, NewtonEulerData& d) {
  std::uint8_t* const __restrict inc = d.in_contact.data();
  Eigen::Vector3d* const __restrict cp = d.contact_points_m.data();
  const Eigen::Vector3d* const tips = model.tips_local_m.data();
  const EnergyParams& prm = model.params;
  std::size_t contacts = 0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d& x = s.joint_positions_m[j];
    // Far above the ground even at the tip's reach: no contact (skips the rotation).
    const double above = x.y() - prm.ground_height_m - prm.contact_height_m;
    if (above > 0.0 && above * above > tips[j].squaredNorm()) continue;
    const Eigen::Vector3d tip = x + s.rotations[j] * tips[j];
    const Eigen::Vector3d& p = (model.tip_contacts[j] && tip.y() < x.y()) ? tip : x;
    if (p.y() - prm.ground_height_m > prm.contact_height_m) continue;
    const Eigen::Vector3d vp =
        s.com_velocities_mps[j] + s.angular_velocities_radps[j].cross(p - s.coms_m[j]);
    if (vp.norm() > prm.contact_speed_mps) continue;
    inc[j] = 1;
    cp[j] = p;
    ++contacts;
  }
  return contacts;
}

// Pass 2b, contact forces: the contacts share equally the part of F_req the
// ground can push (F_n >= 0, |F_t| <= mu F_n; N), plus a free moment M_req -
// sum (p_k - c_G) x F_k capped at F_n * patch radius (N m). Nothing when
// there is no contact or F_req does not push down.
[[gnu::always_inline]] inline void share_contact_wrench(const DynamicsModel& model,
                                                        const Eigen::Vector3d& f_req,
                                                        const Eigen::Vector3d& m_req,
                                                        const Eigen::Vector3d& com,
                                                        std::size_t contacts, NewtonEulerData& d) {
  if (!(contacts > 0 && f_req.y() > 0.0)) return;
  const std::uint8_t* const __restrict inc = d.in_contact.data();
  Eigen::Vector3d* const __restrict cf = d.contact_forces_N.data();
  const Eigen::Vector3d* const __restrict cp = d.contact_points_m.data();
  Eigen::Vector3d* const __restrict ct = d.contact_torques_Nm.data();
  const EnergyParams& prm = model.params;
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

// Pass 3, leaves -> root: f_j, n_j (N, N m about x_j) accumulate the
// segment's requirement less its contact wrench plus its children's
// (children have larger indices and are done first; f_j, n_j already hold
// the children's parts); a body root keeps its (f, n) as the residual, whose
// sum about the COM goes to residual_force_N / residual_torque_Nm.
[[gnu::always_inline]] inline void backward_force_pass(const DynamicsModel& model,
                                                       const StateView& s,
                                                       const Eigen::Vector3d& com,
                                                       NewtonEulerData& d) {
  Eigen::Vector3d* const __restrict jf = d.joint_forces_N.data();
  Eigen::Vector3d* const __restrict jt = d.joint_torques_Nm.data();
  const Eigen::Vector3d* const __restrict cf = d.contact_forces_N.data();
  const Eigen::Vector3d* const __restrict cp = d.contact_points_m.data();
  const Eigen::Vector3d* const __restrict ct = d.contact_torques_Nm.data();
  const std::uint8_t* const __restrict inc = d.in_contact.data();
  const Eigen::Vector3d* const __restrict rf = d.required_forces_N.data();
  const Eigen::Vector3d* const __restrict rt = d.required_torques_Nm.data();
  const Eigen::Vector3d* const xs = s.joint_positions_m;
  const Eigen::Vector3d* const cs = s.coms_m;
  const std::uint8_t* const term = model.is_term_joint.data();
  const std::uint8_t* const broot = model.is_body_root.data();
  const int* const par = model.parents.data();
  Eigen::Vector3d f_res = Eigen::Vector3d::Zero(), m_res = Eigen::Vector3d::Zero();
  for (std::size_t j = model.joint_count(); j-- > 0;) {
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
}

// Pass 4, what the residual impulse would inject per T^2/2 (J/s^2; see the
// header): |F_res|^2 / M + M_res^T I_G^-1 M_res, the moment term only where
// M_res is not negligible (1e-9 M g), I_G = sum R P D (R P)^T + S - M (|r_G|^2
// 1 - r_G r_G^T) regularised by 1e-9 of its trace; 0 for a massless model.
[[gnu::always_inline]] inline double residual_impulse_coefficient(const DynamicsModel& model,
                                                                  const BodyTotals& body,
                                                                  const Eigen::Vector3d& r_g,
                                                                  const Eigen::Vector3d& f_res,
                                                                  const Eigen::Vector3d& m_res) {
  const double total = model.total_mass_kg;
  double e = total > 0.0 ? f_res.squaredNorm() / total : 0.0;
  const double negligible = 1e-9 * total * model.params.gravity_mps2;
  if (total > 0.0 && m_res.squaredNorm() > negligible * negligible) {
    // S - M r_G r_G^T off the diagonal; the |r|^2 1 parts from the traces.
    const Eigen::Matrix3d shifted = body.second_moment - body.mass * r_g * r_g.transpose();
    Eigen::Matrix3d i_g = shifted.trace() * Eigen::Matrix3d::Identity() - shifted;
    i_g += body.rotational_inertia;
    const double tr = i_g.trace();
    if (tr > 0.0) {
      const Eigen::Matrix3d reg = i_g + 1e-9 * tr * Eigen::Matrix3d::Identity();
      e += m_res.dot(reg.ldlt().solve(m_res));
    }
  }
  return e;
}

}  // namespace

// Inverse dynamics of one state (see the header), pass by pass:
//  1. segment_requirements: per segment F_j = m (a - g), tau_j = I alpha +
//     w x I w; whole-body F_req = sum F_j, M_req = sum tau_j + (c_j - c_G) x
//     F_j, I_G. Moments and the composite inertia are accumulated about a
//     reference point o near the body (the first segment's COM) and moved to
//     the COM here: M_req = sum tau_j + sum (c_j - o) x F_j - (c_G - o) x F_req;
//  2. find_contacts, share_contact_wrench: contacts (lower end near the
//     ground and slow) share the part of F_req the ground can push;
//  3. backward_force_pass: leaves -> root, the residual at the body roots;
//  4. residual_impulse_coefficient.
MOCAP_MULTIVERSION_V3
void inverse_dynamics(const DynamicsModel& model, const StateView& s, NewtonEulerData& d) {
  start_inverse_dynamics(model, s, d);
  const Eigen::Vector3d origin =
      model.segments.empty()
          ? Eigen::Vector3d::Zero()
          : Eigen::Vector3d(s.coms_m[static_cast<std::size_t>(model.segments[0])]);
  BodyTotals body;
  segment_requirements(model, s, origin, d, body);
  const Eigen::Vector3d r_g =
      body.mass > 0.0 ? Eigen::Vector3d(body.first_moment / body.mass) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d com = origin + r_g;
  const Eigen::Vector3d m_req = body.m_req_o - r_g.cross(body.f_req);
  d.com_m = com;
  const std::size_t contacts = find_contacts(model, s, d);
  d.contact_count = contacts;
  share_contact_wrench(model, body.f_req, m_req, com, contacts, d);
  backward_force_pass(model, s, com, d);
  d.residual_impulse_coefficient_Jps2 =
      residual_impulse_coefficient(model, body, r_g, d.residual_force_N, d.residual_torque_Nm);
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

// full_energy's |x| and max(u, v): exact, or with smoothing s > 0 (J;
// NewtonEulerWorkspace::smoothing_J) |x| -> sqrt(x^2 + s^2) - s and max(u, v)
// -> (u + v + |u - v|) / 2.
struct Smoothing {
  double s;
  double abs(double x) const { return s > 0.0 ? std::sqrt(x * x + s * s) - s : std::abs(x); }
  double max(double u, double v) const { return 0.5 * (u + v + abs(u - v)); }
};

// Rotation steps log(q_B q_A^-1) of every joint (rad, world), four at a time:
// the same series as rotation_step() (x = |v| / w < 1/8, atan(x) / x to
// x^18), the rare larger steps through rotation_vector(). Bitwise equal
// rotations give exactly zero (selected, so whatever the compiler fuses).
[[gnu::always_inline]] inline void rotation_steps_of(std::size_t n, const Eigen::Quaterniond* qa,
                                                     const Eigen::Quaterniond* qb,
                                                     Eigen::Vector3d* __restrict steps) {
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
}

// One kinetic-energy term dK(K_A, K_u, K_B) = max(|K_B - K_A|, 2 K_u - K_A -
// K_B) of four segments (J), lane-wise, with its parts d = K_B - K_A and
// through = 2 K_u - K_A - K_B for the smoothed form.
struct KineticChange {
  v4d d, through, h;
};
[[gnu::always_inline]] inline void kinetic_change(const v4d& ka, const v4d& ku, const v4d& kb,
                                                  KineticChange& out) {
  out.d = kb - ka;
  const v4d ad = out.d < 0.0 ? -out.d : out.d;
  out.through = 2.0 * ku - ka - kb;
  out.h = ad > out.through ? ad : out.through;
}

// The h terms of four segments (grp) in full_energy, with the kinetic
// energies of the inverse dynamics: translational h_b = m g |dc_y| +
// dK(K_A, K_u, K_B), rotational h_j = dK(K_A^rot, K_w, K_B^rot) with w^ in
// A's principal axes (R P)_A^T dphi / T (J; padding lanes give 0).
[[gnu::always_inline]] inline void h_lanes(const DynamicsModel& model, const StateView& a,
                                           const StateView& b, const NewtonEulerData& da,
                                           const NewtonEulerData& db, const Eigen::Vector3d* steps,
                                           double inv_t, const Smoothing& sm,
                                           const lanes::Group& grp, v4d& h_seg, v4d& h_joint) {
  const std::size_t i0 = grp.idx[0], i1 = grp.idx[1], i2 = grp.idx[2], i3 = grp.idx[3];
  const v4d live = grp.live;
  const double* const mass_of = model.masses_kg.data();
  const v4d m = live * v4d{mass_of[i0], mass_of[i1], mass_of[i2], mass_of[i3]};
  Vec4 ca, cb, st;
  gather(a.coms_m, grp.idx, ca);
  gather(b.coms_m, grp.idx, cb);
  const v4d dcx = cb.x - ca.x, dcy = cb.y - ca.y, dcz = cb.z - ca.z;
  const v4d grav_signed = m * model.params.gravity_mps2 * dcy;
  const v4d grav = grav_signed < 0.0 ? -grav_signed : grav_signed;
  const v4d k_u = 0.5 * m * (dcx * dcx + dcy * dcy + dcz * dcz) * inv_t * inv_t;
  const double* const eta = da.translational_energies_J.data();
  const double* const etb = db.translational_energies_J.data();
  KineticChange tr;
  kinetic_change(live * v4d{eta[i0], eta[i1], eta[i2], eta[i3]}, k_u,
                 live * v4d{etb[i0], etb[i1], etb[i2], etb[i3]}, tr);
  h_seg = grav + tr.h;
  gather(steps, grp.idx, st);
  const v4d sx = inv_t * st.x, sy = inv_t * st.y, sz = inv_t * st.z;
  const Eigen::Matrix3d* const prot_a = da.principal_rotations.data();
  const Eigen::Vector3d* const pm = model.principal_moments_kgm2.data();
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
  const double* const era = da.rotational_energies_J.data();
  const double* const erb = db.rotational_energies_J.data();
  KineticChange rot;
  kinetic_change(live * v4d{era[i0], era[i1], era[i2], era[i3]}, k_w,
                 live * v4d{erb[i0], erb[i1], erb[i2], erb[i3]}, rot);
  h_joint = rot.h;
  if (sm.s > 0.0) {
    // Smoothed (refinement only): |x| -> sqrt(x^2 + s^2) - s, max(a, b) -> (a + b + |a - b|) / 2.
    for (std::size_t l = 0; l < grp.count; ++l) {
      h_seg[l] = sm.abs(grav_signed[l]) + sm.max(sm.abs(tr.d[l]), tr.through[l]);
      h_joint[l] = sm.max(sm.abs(rot.d[l]), rot.through[l]);
    }
  }
}

// The h part of full_energy (energy.hpp) into ws.h, four segments at a time
// (padding lanes as in inverse_dynamics: massless, discarded); returns its
// total (J), the lanes added in lane order. Equal to approximate_energy(a,
// b) up to round-off (1e-15 relative).
[[gnu::always_inline]] inline double h_part(const DynamicsModel& model, const StateView& a,
                                            const StateView& b, const NewtonEulerData& da,
                                            const NewtonEulerData& db, double inv_t,
                                            const Smoothing& sm, NewtonEulerWorkspace& ws) {
  ws.h.reset(model.joint_count());
  double* const __restrict h_seg_out = ws.h.segment_J.data();
  double* const __restrict h_joint_out = ws.h.joint_J.data();
  const Eigen::Vector3d* const steps = ws.rotation_steps.data();
  const std::size_t nseg = model.segments.size();
  v4d h_sum{};
  for (std::size_t k0 = 0; k0 < nseg; k0 += 4) {
    lanes::Group grp;
    lanes::group(model.segments.data(), nseg, k0, grp);
    v4d h_seg, h_joint;
    h_lanes(model, a, b, da, db, steps, inv_t, sm, grp, h_seg, h_joint);
    h_sum += h_seg + h_joint;
    for (std::size_t l = 0; l < grp.count; ++l) {
      h_seg_out[grp.idx[l]] = h_seg[l];
      h_joint_out[grp.idx[l]] = h_joint[l];
    }
  }
  return lanes::sum(h_sum);
}

// The work of segment j's contact over the step (J): the mean contact wrench
// over dc and dphi, plus friction mu F_n over the horizontal path of the
// contact point carried rigidly from the state where it touches to the other.
[[gnu::always_inline]] inline double contact_work(const DynamicsModel& model, const StateView& a,
                                                  const StateView& b, const NewtonEulerData& da,
                                                  const NewtonEulerData& db, std::size_t j,
                                                  const Eigen::Vector3d& dc,
                                                  const Eigen::Vector3d& dphi,
                                                  const Smoothing& sm) {
  const Eigen::Vector3d fc = 0.5 * (da.contact_forces_N[j] + db.contact_forces_N[j]);
  const Eigen::Vector3d tc =
      0.5 * (contact_moment_about_com(da, a, j) + contact_moment_about_com(db, b, j));
  double w_contact = sm.abs(fc.dot(dc) + tc.dot(dphi));
  const Eigen::Vector3d slide = detail::contact_slide(a, b, da, db, j);
  const double normal = std::max(0.0, fc.y());
  const double friction = model.params.friction_coefficient * normal;
  const double smooth = sm.s;
  w_contact +=
      smooth > 0.0
          ? std::sqrt(friction * friction * (slide.x() * slide.x() + slide.z() * slide.z()) +
                      smooth * smooth) -
                smooth
          : friction * std::sqrt(slide.x() * slide.x() + slide.z() * slide.z());
  return w_contact;
}

// The work of body root j's residual wrench about its COM (mean of A and B)
// over dc and dphi (J).
[[gnu::always_inline]] inline double residual_work(
    const StateView& a, const StateView& b, const NewtonEulerData& da, const NewtonEulerData& db,
    std::size_t j, const Eigen::Vector3d& dc, const Eigen::Vector3d& dphi, const Smoothing& sm) {
  const detail::MeanWrench r = detail::mean_residual_wrench(a, b, da, db, j);
  return sm.abs(r.force_N.dot(dc) + r.moment_Nm.dot(dphi));
}

// g_b - h_b of segment j (J): the work of the adjacent force (what the
// segment needs minus contact minus, at a root, the residual), of its
// contact and of its residual wrench (at a body root); by part into terms.
[[gnu::always_inline]] inline double segment_work(const DynamicsModel& model, const StateView& a,
                                                  const StateView& b, const NewtonEulerData& da,
                                                  const NewtonEulerData& db, std::size_t j,
                                                  const Eigen::Vector3d& dphi, const Smoothing& sm,
                                                  FullEnergyTerms* terms) {
  const Eigen::Vector3d dc = b.coms_m[j] - a.coms_m[j];
  const bool root = model.is_body_root[j] != 0;
  Eigen::Vector3d fa_a = da.required_forces_N[j] - da.contact_forces_N[j];
  Eigen::Vector3d fa_b = db.required_forces_N[j] - db.contact_forces_N[j];
  if (root) {
    fa_a -= da.joint_forces_N[j];
    fa_b -= db.joint_forces_N[j];
  }
  const double w_adj = sm.abs(0.5 * (fa_a + fa_b).dot(dc));
  const double w_contact = da.in_contact[j] || db.in_contact[j]
                               ? contact_work(model, a, b, da, db, j, dc, dphi, sm)
                               : 0.0;
  const double w_res = root ? residual_work(a, b, da, db, j, dc, dphi, sm) : 0.0;
  if (terms != nullptr) {
    terms->adjacent_work_J[j] = w_adj;
    terms->contact_work_J[j] = w_contact;
    terms->residual_work_J += w_res;
  }
  return w_adj + w_contact + w_res;
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
  rotation_steps_of(n, a.rotations, b.rotations, ws.rotation_steps.data());
  const Eigen::Vector3d* const steps = ws.rotation_steps.data();
  const Smoothing sm{ws.smoothing_J};
  const double h_total = h_part(model, a, b, da, db, 1.0 / transition_time_s, sm, ws);
  if (terms != nullptr) {
    terms->h = ws.h;
    terms->g.reset(n);
    terms->adjacent_work_J.assign(n, 0.0);
    terms->contact_work_J.assign(n, 0.0);
    terms->joint_work_J.assign(n, 0.0);
    terms->residual_work_J = 0.0;
  }
  double extra = 0.0;
  for (int jj : model.term_joints) {
    const auto j = static_cast<std::size_t>(jj);
    const Eigen::Vector3d& dphi = steps[j];
    const double g_seg =
        model.masses_kg[j] > 0.0 ? segment_work(model, a, b, da, db, j, dphi, sm, terms) : 0.0;
    double g_joint = 0.0;
    if (!model.is_body_root[j]) {  // the joint torque's work over the relative rotation step
      const int p = model.parents[j];
      const Eigen::Vector3d rel =
          p >= 0 ? Eigen::Vector3d(dphi - steps[static_cast<std::size_t>(p)]) : dphi;
      g_joint = sm.abs(0.5 * (da.joint_torques_Nm[j] + db.joint_torques_Nm[j]).dot(rel));
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
