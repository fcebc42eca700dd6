#include "mocap/common/dynamics/dynamics.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>

#include "dynamics/lanes.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/multiversion.hpp"

namespace mocap {

namespace {

bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

// a * b^-1 for unit quaternions (the rotation from b to a, world frame).
inline Eigen::Quaterniond mul_conj(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a * b.conjugate();
}

}  // namespace

namespace {
// log(q) = theta * axis with theta = 2 atan2(|v|, w) after choosing w >= 0
// (the short way round). For small rotations (x = |v| / w < 1/8, i.e. theta
// < 14 degrees: every per-frame step of a capture) the series
// atan(x) / x = sum_k (-1)^k x^2k / (2k + 1) to k = 9 (truncation < 1e-19)
// avoids atan2 and the square root: log(q) = 2 v / w * atan(x) / x.
inline Eigen::Vector3d log_unit_quaternion(const Eigen::Quaterniond& q) {
  double w = q.w();
  Eigen::Vector3d v = q.vec();
  if (w < 0.0) {
    w = -w;
    v = -v;
  }
  const double s2 = v.squaredNorm();
  if (s2 < 0.015625 * w * w) {
    constexpr double c[10] = {1.0,         -1.0 / 3.0, 1.0 / 5.0,   -1.0 / 7.0, 1.0 / 9.0,
                              -1.0 / 11.0, 1.0 / 13.0, -1.0 / 15.0, 1.0 / 17.0, -1.0 / 19.0};
    const double y = s2 / (w * w);
    double p = c[9];
    for (int k = 8; k >= 0; --k) p = c[k] + y * p;
    return v * (2.0 * p / w);
  }
  const double s = std::sqrt(s2);
  return v * (2.0 * std::atan2(s, w) / s);
}

}  // namespace

Eigen::Vector3d rotation_vector(const Eigen::Quaterniond& q) {
  return log_unit_quaternion(q);
}

Eigen::Vector3d rotation_step(const Eigen::Quaterniond& from, const Eigen::Quaterniond& to) {
  return log_unit_quaternion(to * from.conjugate());
}

// Swing-twist about world Y: q = q_yaw(psi) * q_swing with q_swing's axis
// horizontal gives q.w = cos(psi/2) a, q.y = sin(psi/2) a, so
// psi = 2 atan2(q.y, q.w), wrapped to (-pi, pi].
double heading_rad(const Eigen::Quaterniond& q) {
  double psi = 2.0 * std::atan2(q.y(), q.w());
  if (psi > std::numbers::pi) psi -= 2.0 * std::numbers::pi;
  if (psi <= -std::numbers::pi) psi += 2.0 * std::numbers::pi;
  return psi;
}

// Model from skeleton + body: copies the per-joint segment data, diagonalises
// each inertia (I = P D P^T, for the vectorised h) and derives the segment
// lists: segments = joints with mass; body roots = segments with no massive
// ancestor; term joints = segments and the massless joints that transmit
// forces to a segment below them, minus the ancestors of body roots.
DynamicsModel build_dynamics_model(const Skeleton& skel, const Body& body,
                                   const EnergyParams& params) {
  const std::size_t n = skel.joint_count();
  const std::string src = "<body>";
  if (body.segments.size() != n)
    throw InputError(src, 0,
                     "body has " + std::to_string(body.segments.size()) +
                         " segments for a skeleton of " + std::to_string(n) + " joints");
  if (!(params.gravity_mps2 >= 0.0) || !std::isfinite(params.gravity_mps2) ||
      !(params.contact_height_m >= 0.0) || !(params.contact_speed_mps >= 0.0) ||
      !(params.friction_coefficient >= 0.0) || !(params.contact_patch_radius_m >= 0.0) ||
      !std::isfinite(params.ground_height_m))
    throw InputError("<energy parameters>", 0, "parameters must be finite and non-negative");
  DynamicsModel m;
  m.names = skel.names;
  m.parents = skel.parents;
  m.params = params;
  m.masses_kg.resize(n);
  m.coms_local_m.resize(n);
  m.tips_local_m.resize(n);
  m.inertias_local_kgm2.resize(n);
  m.principal_frames.resize(n);
  m.principal_moments_kgm2.resize(n);
  m.is_term_joint.assign(n, 0);
  m.is_body_root.assign(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const Segment& s = body.segments[j];
    if (s.joint >= 0 && static_cast<std::size_t>(s.joint) != j)
      throw InputError(
          src, 0, "segment " + std::to_string(j) + " belongs to joint " + std::to_string(s.joint));
    if (!(s.mass_kg >= 0.0) || !std::isfinite(s.mass_kg))
      throw InputError(src, 0, "segment '" + skel.names[j] + "' has a negative or non-finite mass");
    if (!finite(s.com_local_m) || !finite(s.tip_local_m) || !s.inertia_local_kgm2.allFinite())
      throw InputError(src, 0,
                       "segment '" + skel.names[j] + "' has a non-finite COM, tip or inertia");
    m.masses_kg[j] = s.mass_kg;
    m.coms_local_m[j] = s.com_local_m;
    m.tips_local_m[j] = s.tip_local_m;
    const Eigen::Matrix3d inertia = 0.5 * (s.inertia_local_kgm2 + s.inertia_local_kgm2.transpose());
    m.inertias_local_kgm2[j] = inertia;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
    Eigen::Matrix3d p = eig.eigenvectors();
    if (p.determinant() < 0.0) p.col(2) = -p.col(2);
    m.principal_frames[j] = Eigen::Quaterniond(p).normalized();
    m.principal_moments_kgm2[j] = eig.eigenvalues().cwiseMax(0.0);
    if (eig.eigenvalues().minCoeff() < -1e-9 * (1.0 + eig.eigenvalues().cwiseAbs().maxCoeff()))
      throw InputError(
          src, 0,
          "segment '" + skel.names[j] + "' has an inertia that is not positive semi-definite");
    if (s.mass_kg > 0.0) {
      m.segments.push_back(static_cast<int>(j));
      m.total_mass_kg += s.mass_kg;
    }
  }
  // Massive ancestors / descendants.
  std::vector<std::uint8_t> massive_above(n, 0), massive_below(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = m.parents[j];
    if (p >= 0)
      massive_above[j] = static_cast<std::uint8_t>(massive_above[p] || m.masses_kg[p] > 0.0);
  }
  for (std::size_t j = n; j-- > 0;) {
    const int p = m.parents[j];
    if (p >= 0 && (massive_below[j] || m.masses_kg[j] > 0.0)) massive_below[p] = 1;
  }
  // Tips that coincide with a massive child's origin belong to the child.
  m.tip_contacts.assign(n, 1);
  for (std::size_t c = 0; c < n; ++c) {
    const int p = m.parents[c];
    if (p < 0 || !(m.masses_kg[c] > 0.0)) continue;
    const auto pp = static_cast<std::size_t>(p);
    const double scale = skel.translation_scales.empty() ? 1.0 : skel.translation_scales[c];
    const Eigen::Vector3d origin = skel.offsets_m[c] * scale;
    const double tol = 1e-3 + 0.01 * m.tips_local_m[pp].norm();
    if ((origin - m.tips_local_m[pp]).norm() <= tol) m.tip_contacts[pp] = 0;
  }
  for (std::size_t j = 0; j < n; ++j) {
    const bool massive = m.masses_kg[j] > 0.0;
    if (massive && !massive_above[j]) {
      m.body_roots.push_back(static_cast<int>(j));
      m.is_body_root[j] = 1;
    }
    // A massless joint with no massive ancestor sits above the body roots.
    const bool above_roots = !massive && !massive_above[j];
    if ((massive || massive_below[j]) && !above_roots) {
      m.term_joints.push_back(static_cast<int>(j));
      m.is_term_joint[j] = 1;
    }
  }
  return m;
}

void BodyState::resize(std::size_t joints) {
  joint_positions_m.resize(joints, Eigen::Vector3d::Zero());
  rotations.resize(joints, Eigen::Quaterniond::Identity());
  coms_m.resize(joints, Eigen::Vector3d::Zero());
  com_velocities_mps.resize(joints, Eigen::Vector3d::Zero());
  com_accelerations_mps2.resize(joints, Eigen::Vector3d::Zero());
  angular_velocities_radps.resize(joints, Eigen::Vector3d::Zero());
  angular_accelerations_radps2.resize(joints, Eigen::Vector3d::Zero());
}

void BodyState::set_rates_zero() {
  for (auto* v : {&com_velocities_mps, &com_accelerations_mps2, &angular_velocities_radps,
                  &angular_accelerations_radps2})
    for (auto& x : *v) x.setZero();
}

StateView BodyState::view() const {
  return {joint_positions_m.size(),
          joint_positions_m.data(),
          rotations.data(),
          coms_m.data(),
          com_velocities_mps.data(),
          com_accelerations_mps2.data(),
          angular_velocities_radps.data(),
          angular_accelerations_radps2.data()};
}

StateView ClipDynamics::state(std::size_t f) const {
  const std::size_t b = f * joint_count;
  return {joint_count,
          &joint_positions_m[b],
          &rotations[b],
          &coms_m[b],
          &com_velocities_mps[b],
          &com_accelerations_mps2[b],
          &angular_velocities_radps[b],
          &angular_accelerations_radps2[b]};
}

void set_state_pose(const DynamicsModel& model, PoseView pose, BodyState& out) {
  const std::size_t n = model.joint_count();
  out.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    out.joint_positions_m[j] = pose.joint_positions_m[j];
    out.rotations[j] = pose.rotations[j];
    out.coms_m[j] = pose.joint_positions_m[j] + pose.rotations[j] * model.coms_local_m[j];
  }
}

void static_state(const DynamicsModel& model, PoseView pose, BodyState& out) {
  set_state_pose(model, pose, out);
  out.set_rates_zero();
}

// Same differences as compute_clip_dynamics, on up to three poses:
// v = (c_next - c_prev) / (2 dt), a = (c_next - 2 c + c_prev) / dt^2 (and the
// rotation-vector analogues); one neighbour: v = one-sided, a = 0.
void sequence_state(const DynamicsModel& model, const PoseView* prev, PoseView cur,
                    const PoseView* next, double dt_s, BodyState& out) {
  set_state_pose(model, cur, out);
  out.set_rates_zero();
  if ((prev == nullptr && next == nullptr) || !(dt_s > 0.0)) return;
  const std::size_t n = model.joint_count();
  const double inv_dt = 1.0 / dt_s;
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d& c = out.coms_m[j];
    const Eigen::Quaterniond& r = cur.rotations[j];
    Eigen::Vector3d v_lo = Eigen::Vector3d::Zero(), v_hi = Eigen::Vector3d::Zero();
    Eigen::Vector3d w_lo = Eigen::Vector3d::Zero(), w_hi = Eigen::Vector3d::Zero();
    if (prev != nullptr) {
      const Eigen::Vector3d cp =
          prev->joint_positions_m[j] + prev->rotations[j] * model.coms_local_m[j];
      v_lo = (c - cp) * inv_dt;
      w_lo = rotation_vector(mul_conj(r, prev->rotations[j])) * inv_dt;
    }
    if (next != nullptr) {
      const Eigen::Vector3d cn =
          next->joint_positions_m[j] + next->rotations[j] * model.coms_local_m[j];
      v_hi = (cn - c) * inv_dt;
      w_hi = rotation_vector(mul_conj(next->rotations[j], r)) * inv_dt;
    }
    if (prev != nullptr && next != nullptr) {
      out.com_velocities_mps[j] = 0.5 * (v_lo + v_hi);
      out.angular_velocities_radps[j] = 0.5 * (w_lo + w_hi);
      out.com_accelerations_mps2[j] = (v_hi - v_lo) * inv_dt;
      out.angular_accelerations_radps2[j] = (w_hi - w_lo) * inv_dt;
    } else {
      out.com_velocities_mps[j] = prev != nullptr ? v_lo : v_hi;
      out.angular_velocities_radps[j] = prev != nullptr ? w_lo : w_hi;
    }
  }
}

namespace {

// The streaming pass of compute_clip_dynamics for frames 0 .. last-1 (FMA
// clone where the CPU has it), four joints of a frame at a time (lanes.hpp;
// the last group's extra lanes repeat its first joint and are not stored).
// The quaternion log is log_unit_quaternion's series, lane-wise; larger
// rotations take the scalar path, and bitwise equal rotations give exactly 0.
MOCAP_MULTIVERSION_V3
void dynamics_kernel(std::size_t n, std::size_t last, double inv_dt,
                     const Eigen::Vector3d* joint_positions_m, const Eigen::Quaterniond* rotations,
                     const Eigen::Vector3d* com_local, Eigen::Vector3d* c, Eigen::Vector3d* v,
                     Eigen::Vector3d* a, Eigen::Vector3d* w, Eigen::Vector3d* al) {
  using lanes::v4d;
  for (std::size_t f = 0; f < last; ++f) {
    const std::size_t b = f * n, b1 = b + n;
    for (std::size_t j0 = 0; j0 < n; j0 += 4) {
      const std::size_t count = std::min<std::size_t>(4, n - j0);
      const std::size_t k0 = j0, k1 = count > 1 ? j0 + 1 : j0, k2 = count > 2 ? j0 + 2 : j0,
                        k3 = count > 3 ? j0 + 3 : j0;
#define MOCAP_LANES(arr, base, part) \
  v4d{arr[base + k0].part(), arr[base + k1].part(), arr[base + k2].part(), arr[base + k3].part()}
      lanes::Quat4 q0, q1;
      lanes::load(rotations, {b + k0, b + k1, b + k2, b + k3}, q0);
      lanes::load(rotations, {b1 + k0, b1 + k1, b1 + k2, b1 + k3}, q1);
      // c1 = x1 + R(q1) c^: t = 2 u x c^, c^ + w t + u x t (u = q1's vector part).
      const v4d lx = MOCAP_LANES(com_local, 0, x), ly = MOCAP_LANES(com_local, 0, y),
                lz = MOCAP_LANES(com_local, 0, z);
      const v4d tx = 2.0 * (q1.y * lz - q1.z * ly), ty = 2.0 * (q1.z * lx - q1.x * lz),
                tz = 2.0 * (q1.x * ly - q1.y * lx);
      const v4d c1x =
          MOCAP_LANES(joint_positions_m, b1, x) + (lx + q1.w * tx + (q1.y * tz - q1.z * ty));
      const v4d c1y =
          MOCAP_LANES(joint_positions_m, b1, y) + (ly + q1.w * ty + (q1.z * tx - q1.x * tz));
      const v4d c1z =
          MOCAP_LANES(joint_positions_m, b1, z) + (lz + q1.w * tz + (q1.x * ty - q1.y * tx));
      const v4d hvx = (c1x - MOCAP_LANES(c, b, x)) * inv_dt;
      const v4d hvy = (c1y - MOCAP_LANES(c, b, y)) * inv_dt;
      const v4d hvz = (c1z - MOCAP_LANES(c, b, z)) * inv_dt;
      lanes::Quat4 q;
      v4d rx, ry, rz;
      lanes::v4i series, same;
      lanes::rotation_steps(q0, q1, q, rx, ry, rz, series, same);
      for (std::size_t l = 0; l < count; ++l) {
        Eigen::Vector3d r(rx[l], ry[l], rz[l]);
        if (same[l])
          r.setZero();
        else if (!series[l])
          r = log_unit_quaternion(Eigen::Quaterniond(q.w[l], q.x[l], q.y[l], q.z[l]));
        const std::size_t j = j0 + l;
        const Eigen::Vector3d hv(hvx[l], hvy[l], hvz[l]);
        const Eigen::Vector3d hw = r * inv_dt;
        c[b1 + j] = Eigen::Vector3d(c1x[l], c1y[l], c1z[l]);
        if (f == 0) {
          v[j] = hv;
          w[j] = hw;
        } else {
          // v[b + j] holds h_{f-1} (stored below at the previous frame).
          const Eigen::Vector3d hv0 = v[b + j], hw0 = w[b + j];
          v[b + j] = 0.5 * (hv0 + hv);
          w[b + j] = 0.5 * (hw0 + hw);
          a[b + j] = (hv - hv0) * inv_dt;
          al[b + j] = (hw - hw0) * inv_dt;
        }
        // Park h_f in frame f+1's slots until frame f+1 is processed (the last
        // frame keeps it: its one-sided rate).
        v[b1 + j] = hv;
        w[b1 + j] = hw;
      }
#undef MOCAP_LANES
    }
  }
}

}  // namespace

// Finite differences over a clip in one streaming pass (each output written
// once): at frame f the half-step rates h_{f-1} (kept from the previous frame)
// and h_f = rate over [f, f+1] give v_f = (h_{f-1} + h_f) / 2 and
// a_f = (h_f - h_{f-1}) / dt; one quaternion log per joint and frame. See the
// header for the end rules.
void compute_clip_dynamics(const DynamicsModel& model, std::size_t frame_count, double frame_time_s,
                           const Eigen::Vector3d* joint_positions_m,
                           const Eigen::Quaterniond* rotations, ClipDynamics& out) {
  const std::size_t n = model.joint_count();
  const std::size_t total = frame_count * n;
  out.frame_count = frame_count;
  out.joint_count = n;
  out.frame_time_s = frame_time_s;
  // Eigen's fixed-size types are plain arrays of doubles: copy them as bytes
  // (vector::assign would copy element by element, a fifth of this function).
  out.joint_positions_m.resize(total);
  out.rotations.resize(total);
  if (total > 0) {
    std::memcpy(static_cast<void*>(out.joint_positions_m.data()), joint_positions_m,
                total * sizeof(Eigen::Vector3d));
    std::memcpy(static_cast<void*>(out.rotations.data()), rotations,
                total * sizeof(Eigen::Quaterniond));
  }
  out.coms_m.resize(total);
  out.com_velocities_mps.resize(total);
  out.com_accelerations_mps2.resize(total);
  out.angular_velocities_radps.resize(total);
  out.angular_accelerations_radps2.resize(total);
  const Eigen::Vector3d* com_local = model.coms_local_m.data();
  for (std::size_t j = 0; j < n && frame_count > 0; ++j)
    out.coms_m[j] = joint_positions_m[j] + rotations[j] * com_local[j];
  if (frame_count < 2 || !(frame_time_s > 0.0)) {
    for (auto* v : {&out.com_velocities_mps, &out.com_accelerations_mps2,
                    &out.angular_velocities_radps, &out.angular_accelerations_radps2})
      std::fill(v->begin(), v->end(), Eigen::Vector3d::Zero());
    return;
  }
  const double inv_dt = 1.0 / frame_time_s;
  const std::size_t last = frame_count - 1;
  dynamics_kernel(n, last, inv_dt, joint_positions_m, rotations, com_local, out.coms_m.data(),
                  out.com_velocities_mps.data(), out.com_accelerations_mps2.data(),
                  out.angular_velocities_radps.data(), out.angular_accelerations_radps2.data());
  Eigen::Vector3d* a = out.com_accelerations_mps2.data();
  Eigen::Vector3d* al = out.angular_accelerations_radps2.data();
  // Accelerations at the ends copy their neighbour's (the one-sided second
  // difference equals it); a 2-frame clip has none.
  for (std::size_t j = 0; j < n; ++j) {
    if (frame_count == 2) {
      a[j] = a[n + j] = al[j] = al[n + j] = Eigen::Vector3d::Zero();
    } else {
      a[j] = a[n + j];
      al[j] = al[n + j];
      a[last * n + j] = a[(last - 1) * n + j];
      al[last * n + j] = al[(last - 1) * n + j];
    }
  }
}
ClipDynamics compute_clip_dynamics(const DynamicsModel& model, const ClipMotion& motion) {
  if (motion.joint_count() != model.joint_count())
    throw InputError("<clip>", 0,
                     "clip has " + std::to_string(motion.joint_count()) +
                         " joints, the character model " + std::to_string(model.joint_count()));
  ClipDynamics d;
  compute_clip_dynamics(model, motion.frame_count, motion.frame_time_s,
                        motion.world_positions_m.data(), motion.world_rotations.data(), d);
  return d;
}

}  // namespace mocap
