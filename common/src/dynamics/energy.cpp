#include "mocap/common/dynamics/energy.hpp"

#include "mocap/common/body/ground_pose.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/multiversion.hpp"

namespace mocap {

void EnergyTerms::reset(std::size_t n) {
  segment_J.assign(n, 0.0);
  joint_J.assign(n, 0.0);
}

double EnergyTerms::total() const {
  return std::accumulate(segment_J.begin(), segment_J.end(), 0.0) +
         std::accumulate(joint_J.begin(), joint_J.end(), 0.0);
}

namespace {

void check_time(double t) {
  detail::check_transition_time(t);
}

// 1/2 w^T (R I R^T) w = 1/2 (R^T w)^T I (R^T w): rotational kinetic energy of
// a segment with world angular velocity w and orientation R.
inline double rotational_ke(const Eigen::Matrix3d& inertia_local, const Eigen::Quaterniond& r,
                            const Eigen::Vector3d& w_world) {
  const Eigen::Vector3d wl = r.conjugate() * w_world;
  return 0.5 * wl.dot(inertia_local * wl);
}

// One segment's h terms (see energy.hpp):
//   h_b = |m g . dc| + dK(1/2 m|v_A|^2, 1/2 m|dc/T|^2, 1/2 m|v_B|^2)
//   h_j = dK(K_A^rot, K_w^^rot, K_B^rot), w^ = log(R_B R_A^T)/T; the transition's
// rotational KE uses A's body frame (equal to B's: R_A^T w^ = R_B^T w^).
struct SegmentSide {
  const Eigen::Vector3d* com;
  const Eigen::Quaterniond* rot;
  const Eigen::Vector3d* vel;
  const Eigen::Vector3d* omega;
};

// A state's own translational and rotational kinetic energy of segment j.
// Out of line on purpose: both states go through the same compiled code, so
// identical states give bitwise identical energies and h(A, A) = 0 exactly
// even where the caller is compiled with FMA contraction.
struct SegmentKinetic {
  double translational;
  double rotational;
};
__attribute__((noinline)) SegmentKinetic segment_kinetic(const DynamicsModel& model, std::size_t j,
                                                         const Eigen::Quaterniond& rot,
                                                         const Eigen::Vector3d& vel,
                                                         const Eigen::Vector3d& omega) {
  return {0.5 * model.masses_kg[j] * vel.squaredNorm(),
          rotational_ke(model.inertias_local_kgm2[j], rot, omega)};
}

inline void segment_h(const DynamicsModel& model, std::size_t j, const SegmentSide& a,
                      const SegmentSide& b, const Eigen::Vector3d& rotation_step, double inv_t,
                      double& h_seg, double& h_joint) {
  const double m = model.masses_kg[j];
  const Eigen::Vector3d dc = *b.com - *a.com;
  const double grav = std::abs(m * model.params.gravity_mps2 * dc.y());
  const SegmentKinetic ka = segment_kinetic(model, j, *a.rot, *a.vel, *a.omega);
  const SegmentKinetic kb = segment_kinetic(model, j, *b.rot, *b.vel, *b.omega);
  const double k_u = 0.5 * m * dc.squaredNorm() * inv_t * inv_t;
  h_seg = grav + transition_kinetic_change(ka.translational, k_u, kb.translational);
  const Eigen::Vector3d w_hat = rotation_step * inv_t;
  h_joint = transition_kinetic_change(
      ka.rotational, rotational_ke(model.inertias_local_kgm2[j], *a.rot, w_hat), kb.rotational);
}

inline SegmentSide side(const StateView& s, std::size_t j) {
  return {&s.coms_m[j], &s.rotations[j], &s.com_velocities_mps[j], &s.angular_velocities_radps[j]};
}

void check_state(const DynamicsModel& model, const StateView& s) {
  if (s.joint_count != model.joint_count() || s.coms_m == nullptr || s.rotations == nullptr ||
      s.com_velocities_mps == nullptr || s.angular_velocities_radps == nullptr)
    throw std::invalid_argument(
        "state does not match the character model (joint count or missing arrays)");
}

}  // namespace

void detail::check_transition_time(double t) {
  if (!(t > 0.0) || !std::isfinite(t))
    throw std::invalid_argument("transition time must be a positive number of seconds");
}

MOCAP_MULTIVERSION_V3
double approximate_energy(const DynamicsModel& model, const StateView& a, const StateView& b,
                          double transition_time_s, EnergyTerms* terms) {
  check_time(transition_time_s);
  check_state(model, a);
  check_state(model, b);
  const double inv_t = 1.0 / transition_time_s;
  if (terms != nullptr) terms->reset(model.joint_count());
  double total = 0.0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    double hs = 0.0, hj = 0.0;
    segment_h(model, j, side(a, j), side(b, j), rotation_step(a.rotations[j], b.rotations[j]),
              inv_t, hs, hj);
    total += hs + hj;
    if (terms != nullptr) {
      terms->segment_J[j] = hs;
      terms->joint_J[j] = hj;
    }
  }
  return total;
}

// ---------------------------------------------------------------------------
// Partial queries

PartialQuery prepare_partial_query(const DynamicsModel& model, PartialPoseSpec spec) {
  const std::size_t n = model.joint_count();
  const std::string src = "<query>";
  for (const auto& p : spec.root_position_m)
    if (p && !std::isfinite(*p)) throw InputError(src, 0, "root position must be finite");
  if (spec.root_heading_rad && !std::isfinite(*spec.root_heading_rad))
    throw InputError(src, 0, "root heading must be finite");
  PartialQuery q;
  q.given_rotation.assign(n, -1);
  q.affected.assign(n, 0);
  for (std::size_t i = 0; i < spec.joint_rotations.size(); ++i) {
    auto& [joint, rot] = spec.joint_rotations[i];
    if (joint < 0 || static_cast<std::size_t>(joint) >= n)
      throw InputError(src, 0, "joint index " + std::to_string(joint) + " out of range");
    if (q.given_rotation[static_cast<std::size_t>(joint)] >= 0)
      throw InputError(src, 0,
                       "joint '" + model.names[static_cast<std::size_t>(joint)] + "' given twice");
    if (!rot.coeffs().allFinite() || rot.norm() < 1e-12)
      throw InputError(src, 0,
                       "rotation of joint '" + model.names[static_cast<std::size_t>(joint)] +
                           "' is not a valid quaternion");
    rot.normalize();
    q.given_rotation[static_cast<std::size_t>(joint)] = static_cast<int>(i);
  }
  if (model.root() < 0 && (spec.root_heading_rad || spec.root_position_m[0] ||
                           spec.root_position_m[1] || spec.root_position_m[2]))
    throw InputError(src, 0, "the character has no root segment to place");
  // Subtrees of the given joints (parents come first).
  q.in_subtree.assign(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = model.parents[j];
    q.in_subtree[j] =
        static_cast<std::uint8_t>(q.given_rotation[j] >= 0 || (p >= 0 && q.in_subtree[p]));
    if (q.in_subtree[j]) q.subtree_joints.push_back(static_cast<int>(j));
  }
  q.moves_whole_body = spec.root_heading_rad.has_value() || spec.root_position_m[0].has_value() ||
                       spec.root_position_m[1].has_value() || spec.root_position_m[2].has_value();
  for (std::size_t j = 0; j < n; ++j) {
    q.affected[j] = static_cast<std::uint8_t>(q.moves_whole_body || q.in_subtree[j]);
    if (q.affected[j]) q.affected_joints.push_back(static_cast<int>(j));
  }
  q.spec = std::move(spec);
  return q;
}

namespace {

// Writes the pose of Q_F for the affected joints into out (others untouched):
// FK of the given subtrees from F's local pose, then heading, then position.
void complete_pose(const DynamicsModel& model, const PartialQuery& q, const FrameRef& fr,
                   BodyState& out) {
  const StateView& f = fr.state;
  if (!q.subtree_joints.empty() &&
      (fr.local_translations_m == nullptr || fr.local_rotations == nullptr))
    throw std::invalid_argument(
        "a partial query with joint rotations needs the frame's local pose");
  for (int jj : q.subtree_joints) {
    const auto j = static_cast<std::size_t>(jj);
    const int gi = q.given_rotation[j];
    const Eigen::Quaterniond& local =
        gi >= 0 ? q.spec.joint_rotations[static_cast<std::size_t>(gi)].second
                : fr.local_rotations[j];
    const int p = model.parents[j];
    if (p < 0) {
      out.joint_positions_m[j] = fr.local_translations_m[j];
      out.rotations[j] = local;
    } else {
      // The parent is either in a given subtree (already computed, parents
      // come first) or untouched by the rotations (F's pose).
      const auto pp = static_cast<std::size_t>(p);
      const bool parent_in_subtree = q.in_subtree[pp] != 0;
      const Eigen::Vector3d& xp =
          parent_in_subtree ? out.joint_positions_m[pp] : f.joint_positions_m[pp];
      const Eigen::Quaterniond& rp = parent_in_subtree ? out.rotations[pp] : f.rotations[pp];
      out.joint_positions_m[j] = xp + rp * fr.local_translations_m[j];
      out.rotations[j] = rp * local;
    }
  }
  if (!q.moves_whole_body) return;
  // Whole-body moves: start from F's pose where no rotation was given.
  const std::size_t n = model.joint_count();
  for (std::size_t j = 0; j < n; ++j) {
    if (q.in_subtree[j]) continue;
    out.joint_positions_m[j] = f.joint_positions_m[j];
    out.rotations[j] = f.rotations[j];
  }
  const auto root = static_cast<std::size_t>(model.root());
  if (q.spec.root_heading_rad) {
    const double delta = *q.spec.root_heading_rad - heading_rad(out.rotations[root]);
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(delta, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d pivot = out.joint_positions_m[root];
    for (std::size_t j = 0; j < n; ++j) {
      out.joint_positions_m[j] = pivot + turn * (out.joint_positions_m[j] - pivot);
      out.rotations[j] = (turn * out.rotations[j]).normalized();
    }
  }
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k)
    if (q.spec.root_position_m[static_cast<std::size_t>(k)])
      shift[k] =
          *q.spec.root_position_m[static_cast<std::size_t>(k)] - out.joint_positions_m[root][k];
  if (!shift.isZero(0.0))
    for (std::size_t j = 0; j < n; ++j) out.joint_positions_m[j] += shift;
}

}  // namespace

void complete_partial_query(const DynamicsModel& model, const PartialQuery& query,
                            const FrameRef& frame, BodyState& out) {
  check_state(model, frame.state);
  const std::size_t n = model.joint_count();
  out.resize(n);
  const StateView& f = frame.state;
  for (std::size_t j = 0; j < n; ++j) {
    out.joint_positions_m[j] = f.joint_positions_m[j];
    out.rotations[j] = f.rotations[j];
  }
  complete_pose(model, query, frame, out);
  for (std::size_t j = 0; j < n; ++j) {
    out.coms_m[j] = out.joint_positions_m[j] + out.rotations[j] * model.coms_local_m[j];
    if (query.affected[j] && (query.keep_rates.empty() || !query.keep_rates[j])) {
      out.com_velocities_mps[j].setZero();
      out.com_accelerations_mps2[j].setZero();
      out.angular_velocities_radps[j].setZero();
      out.angular_accelerations_radps2[j].setZero();
    } else {
      out.com_velocities_mps[j] = f.com_velocities_mps[j];
      out.com_accelerations_mps2[j] = f.com_accelerations_mps2 != nullptr
                                          ? f.com_accelerations_mps2[j]
                                          : Eigen::Vector3d::Zero();
      out.angular_velocities_radps[j] = f.angular_velocities_radps[j];
      out.angular_accelerations_radps2[j] = f.angular_accelerations_radps2 != nullptr
                                                ? f.angular_accelerations_radps2[j]
                                                : Eigen::Vector3d::Zero();
    }
  }
}

double partial_approximate_energy(const DynamicsModel& model, const PartialQuery& query,
                                  const FrameRef& frame, double transition_time_s,
                                  BodyState& scratch, EnergyTerms* terms) {
  check_time(transition_time_s);
  check_state(model, frame.state);
  const std::size_t n = model.joint_count();
  if (scratch.joint_positions_m.size() != n) scratch.resize(n);
  complete_pose(model, query, frame, scratch);
  if (terms != nullptr) terms->reset(n);
  const double inv_t = 1.0 / transition_time_s;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  double total = 0.0;
  for (int jj : query.affected_joints) {
    const auto j = static_cast<std::size_t>(jj);
    if (!(model.masses_kg[j] > 0.0)) continue;
    scratch.coms_m[j] = scratch.joint_positions_m[j] + scratch.rotations[j] * model.coms_local_m[j];
    const bool keep = !query.keep_rates.empty() && query.keep_rates[j];
    const SegmentSide a{&scratch.coms_m[j], &scratch.rotations[j],
                        keep ? &frame.state.com_velocities_mps[j] : &zero,
                        keep ? &frame.state.angular_velocities_radps[j] : &zero};
    double hs = 0.0, hj = 0.0;
    const Eigen::Vector3d step = rotation_step(scratch.rotations[j], frame.state.rotations[j]);
    segment_h(model, j, a, side(frame.state, j), step, inv_t, hs, hj);
    total += hs + hj;
    if (terms != nullptr) {
      terms->segment_J[j] = hs;
      terms->joint_J[j] = hj;
    }
  }
  return total;
}

// ---------------------------------------------------------------------------
// kd feature

std::size_t kd_feature_dimension(const DynamicsModel& model) {
  return 3 * model.segments.size();
}

// f_b = sqrt(m_b / 2) / T * c_b; see the header and docs/energy.md for the bound.
void kd_feature(const DynamicsModel& model, const StateView& state, double transition_time_s,
                float* out) {
  check_time(transition_time_s);
  std::size_t i = 0;
  for (int jj : model.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const double s = std::sqrt(0.5 * model.masses_kg[j]) / transition_time_s;
    for (int k = 0; k < 3; ++k) out[i++] = static_cast<float>(s * state.coms_m[j][k]);
  }
}

void kd_root_feature(const DynamicsModel& model, const std::array<bool, 3>& axes,
                     const Eigen::Vector3d& root_m, double transition_time_s, float* out) {
  check_time(transition_time_s);
  const double s = std::sqrt(0.5 * model.total_mass_kg) / transition_time_s;
  std::size_t i = 0;
  for (int k = 0; k < 3; ++k)
    if (axes[static_cast<std::size_t>(k)]) out[i++] = static_cast<float>(s * root_m[k]);
}

// ---------------------------------------------------------------------------
// Structure-of-arrays scan

void init_h_scan_table(const DynamicsModel& model, std::size_t frame_count, HScanTable& table) {
  table.frame_count = frame_count;
  table.stride = (frame_count + 15) / 16 * 16;
  table.segment_count = model.segments.size();
  table.values.assign(table.segment_count * HScanTable::kFields * table.stride, 0.0f);
  table.root_positions.assign(3 * table.stride, 0.0f);
}

namespace {

// Per segment: COM, 1/2 m|v|^2, q = R P (principal-axes orientation, w >= 0),
// 1/2 w^T I_world w; value k of segment s at out[s * segment_stride + k * field_stride].
void put_h_scan_values(const DynamicsModel& model, const StateView& state, std::size_t segments,
                       float* out, std::size_t segment_stride, std::size_t field_stride) {
  const std::size_t st = field_stride;
  for (std::size_t s = 0; s < segments; ++s) {
    const auto j = static_cast<std::size_t>(model.segments[s]);
    float* base = out + s * segment_stride;
    const Eigen::Vector3d& c = state.coms_m[j];
    using F = HScanField;
    base[F::com_x * st] = static_cast<float>(c.x());
    base[F::com_y * st] = static_cast<float>(c.y());
    base[F::com_z * st] = static_cast<float>(c.z());
    base[F::kinetic * st] =
        static_cast<float>(0.5 * model.masses_kg[j] * state.com_velocities_mps[j].squaredNorm());
    Eigen::Quaterniond q = (state.rotations[j] * model.principal_frames[j]).normalized();
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    base[F::orient_w * st] = static_cast<float>(q.w());
    base[F::orient_x * st] = static_cast<float>(q.x());
    base[F::orient_y * st] = static_cast<float>(q.y());
    base[F::orient_z * st] = static_cast<float>(q.z());
    base[F::kinetic_rot * st] = static_cast<float>(rotational_ke(
        model.inertias_local_kgm2[j], state.rotations[j], state.angular_velocities_radps[j]));
  }
}

}  // namespace

void set_h_scan_frame(const DynamicsModel& model, const StateView& state, std::size_t f,
                      HScanTable& table) {
  const std::size_t st = table.stride;
  put_h_scan_values(model, state, table.segment_count, table.values.data() + f,
                    HScanTable::kFields * st, st);
  const int root = model.root();
  if (root >= 0)
    for (std::size_t k = 0; k < 3; ++k)
      table.root_positions[k * st + f] =
          static_cast<float>(state.joint_positions_m[root][static_cast<int>(k)]);
}

void h_scan_row(const DynamicsModel& model, const StateView& state, float* out) {
  put_h_scan_values(model, state, model.segments.size(), out, HScanTable::kFields, 1);
}

HScanQuery make_h_scan_query(const DynamicsModel& model, const StateView& state,
                             double transition_time_s,
                             std::span<const std::uint8_t> compared_joints) {
  check_time(transition_time_s);
  check_state(model, state);
  if (!compared_joints.empty() && compared_joints.size() != model.joint_count())
    throw std::invalid_argument("make_h_scan_query: compared_joints must have one entry per joint");
  HScanQuery q;
  q.segment_count = model.segments.size();
  q.constants.assign(q.segment_count * HScanQuery::kConstants, 0.0f);
  const double half_inv_t2 = 0.5 / (transition_time_s * transition_time_s);
  for (std::size_t s = 0; s < q.segment_count; ++s) {
    const auto j = static_cast<std::size_t>(model.segments[s]);
    float* c = q.constants.data() + s * HScanQuery::kConstants;
    const double m = model.masses_kg[j];
    using C = HScanConstant;
    c[C::com_x] = static_cast<float>(state.coms_m[j].x());
    c[C::com_y] = static_cast<float>(state.coms_m[j].y());
    c[C::com_z] = static_cast<float>(state.coms_m[j].z());
    c[C::kinetic] = static_cast<float>(0.5 * m * state.com_velocities_mps[j].squaredNorm());
    c[C::mass_gravity] = static_cast<float>(m * model.params.gravity_mps2);
    c[C::mass_half_inv_t2] = static_cast<float>(m * half_inv_t2);
    const Eigen::Quaterniond qa =
        (state.rotations[j] * model.principal_frames[j]).normalized().conjugate();
    c[C::conj_w] = static_cast<float>(qa.w());
    c[C::conj_x] = static_cast<float>(qa.x());
    c[C::conj_y] = static_cast<float>(qa.y());
    c[C::conj_z] = static_cast<float>(qa.z());
    c[C::kinetic_rot] = static_cast<float>(rotational_ke(
        model.inertias_local_kgm2[j], state.rotations[j], state.angular_velocities_radps[j]));
    for (int k = 0; k < 3; ++k)
      c[C::moments_half_inv_t2 + static_cast<std::size_t>(k)] =
          static_cast<float>(model.principal_moments_kgm2[j][k] * half_inv_t2);
    c[C::left_out] = !compared_joints.empty() && compared_joints[j] == 0 ? 1.0f : 0.0f;
  }
  return q;
}

void place_h_scan_query(const HScanQuery& body, const GroundPose& g, HScanQuery& out) {
  out.segment_count = body.segment_count;
  out.constants.resize(body.constants.size());
  const double c = std::cos(g.heading_rad), s = std::sin(g.heading_rad);
  const Eigen::Quaterniond back(Eigen::AngleAxisd(-g.heading_rad, Eigen::Vector3d::UnitY()));
  for (std::size_t b = 0; b < body.segment_count; ++b) {
    const float* in = body.constants.data() + b * HScanQuery::kConstants;
    float* o = out.constants.data() + b * HScanQuery::kConstants;
    std::copy(in, in + HScanQuery::kConstants, o);
    using C = HScanConstant;
    const double x = in[C::com_x], z = in[C::com_z];
    o[C::com_x] = static_cast<float>(c * x + s * z + g.position_m.x());
    o[C::com_z] = static_cast<float>(-s * x + c * z + g.position_m.y());
    // conj(R_y q P) = conj(q P) conj(R_y).
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(in[C::conj_w], in[C::conj_x], in[C::conj_y], in[C::conj_z]) * back;
    o[C::conj_w] = static_cast<float>(q.w());
    o[C::conj_x] = static_cast<float>(q.x());
    o[C::conj_y] = static_cast<float>(q.y());
    o[C::conj_z] = static_cast<float>(q.z());
  }
}

namespace {

// The scan kernel: for each segment, add its h terms for n consecutive frames
// into acc (vectorised over frames; fields as in HScanTable). Formulas:
//   d = c_B - c_A, K_u = m/(2T^2) |d|^2,  h_b = m g |d_y| + dK(K_A, K_u, K_B)
//   r = conj(q_A P) (q_B P) (A's principal frame),  K_w = poly(1-|r_w|) sum_k D_k/(2T^2) r_k^2
//   h_j = dK(K_A^rot, K_w, K_B^rot),  dK(a, u, b) = max(|b - a|, 2u - a - b).
MOCAP_MULTIVERSION_V4
void scan_kernel(const float* __restrict values, std::size_t stride, std::size_t segments,
                 const float* __restrict constants, std::size_t first, std::size_t n,
                 float* __restrict acc) {
  for (std::size_t i = 0; i < n; ++i) acc[i] = 0.0f;
  for (std::size_t s = 0; s < segments; ++s) {
    using C = HScanConstant;
    using F = HScanField;
    const float* k = constants + s * HScanQuery::kConstants;
    if (k[C::left_out] != 0.0f) continue;  // a segment left out (mask)
    const float ax = k[C::com_x], ay = k[C::com_y], az = k[C::com_z], ka = k[C::kinetic];
    const float mg = k[C::mass_gravity], mh = k[C::mass_half_inv_t2];
    const float aw = k[C::conj_w], qx = k[C::conj_x], qy = k[C::conj_y], qz = k[C::conj_z];
    const float kar = k[C::kinetic_rot];
    const float d0 = k[C::moments_half_inv_t2], d1 = k[C::moments_half_inv_t2 + 1],
                d2 = k[C::moments_half_inv_t2 + 2];
    const float* base = values + s * HScanTable::kFields * stride + first;
    const float* __restrict cx = base + F::com_x * stride;
    const float* __restrict cy = base + F::com_y * stride;
    const float* __restrict cz = base + F::com_z * stride;
    const float* __restrict kb = base + F::kinetic * stride;
    const float* __restrict bw = base + F::orient_w * stride;
    const float* __restrict bx = base + F::orient_x * stride;
    const float* __restrict by = base + F::orient_y * stride;
    const float* __restrict bz = base + F::orient_z * stride;
    const float* __restrict kbr = base + F::kinetic_rot * stride;
    for (std::size_t i = 0; i < n; ++i) {
      const float dx = cx[i] - ax, dy = cy[i] - ay, dz = cz[i] - az;
      const float ku = mh * (dx * dx + dy * dy + dz * dz);
      const float grav = mg * std::fabs(dy);
      const float dk = std::fabs(kb[i] - ka);
      const float th = 2.0f * ku - ka - kb[i];
      const float trans = grav + (dk > th ? dk : th);
      // r = a * b with a = conj(q_A P) = (aw, qx, qy, qz), b = q_B P.
      const float rw = aw * bw[i] - qx * bx[i] - qy * by[i] - qz * bz[i];
      const float rx = aw * bx[i] + bw[i] * qx + qy * bz[i] - qz * by[i];
      const float ry = aw * by[i] + bw[i] * qy + qz * bx[i] - qx * bz[i];
      const float rz = aw * bz[i] + bw[i] * qz + qx * by[i] - qy * bx[i];
      float t = 1.0f - std::fabs(rw);
      t = t < 0.0f ? 0.0f : t;
      const float kw = log_norm_factor(t) * (d0 * rx * rx + d1 * ry * ry + d2 * rz * rz);
      const float dkr = std::fabs(kbr[i] - kar);
      const float thr = 2.0f * kw - kar - kbr[i];
      acc[i] += trans + (dkr > thr ? dkr : thr);
    }
  }
}

MOCAP_MULTIVERSION_V4
void root_scan_kernel(const float* __restrict values, const float* __restrict roots,
                      std::size_t stride, std::size_t root_stride, std::size_t segments,
                      const float* __restrict masses, const HScanRootQuery& q, std::size_t first,
                      std::size_t n, float* __restrict out) {
  const float px = q.position[0], py = q.position[1], pz = q.position[2];
  const float gx = q.given[0], gy = q.given[1], gz = q.given[2];
  float total_mass = 0.0f;
  for (std::size_t s = 0; s < segments; ++s) total_mass += masses[s];
  const float* __restrict rx = roots + first;
  const float* __restrict ry = roots + root_stride + first;
  const float* __restrict rz = roots + 2 * root_stride + first;
  for (std::size_t i = 0; i < n; ++i) {
    const float dy = gy * (py - ry[i]);
    out[i] = total_mass * q.gravity * std::fabs(dy);
  }
  for (std::size_t s = 0; s < segments; ++s) {
    const float m_inv_t2 = masses[s] * q.inv_t2;
    const float* base = values + s * HScanTable::kFields * stride + first;
    const float* __restrict kb = base + HScanField::kinetic * stride;
    const float* __restrict kbr = base + HScanField::kinetic_rot * stride;
    for (std::size_t i = 0; i < n; ++i) {
      const float dx = gx * (px - rx[i]), dy = gy * (py - ry[i]), dz = gz * (pz - rz[i]);
      const float two_ku = m_inv_t2 * (dx * dx + dy * dy + dz * dz);
      const float th = two_ku - kb[i];
      out[i] += (kb[i] > th ? kb[i] : th) + kbr[i];
    }
  }
}

}  // namespace

void scan_approximate_energy(const HScanView& table, const HScanQuery& query, std::size_t begin,
                             std::size_t end, float* out) {
  if (query.segment_count != table.segment_count)
    throw std::invalid_argument("scan query and table were made for different character models");
  if (begin > end || end > table.frame_count)
    throw std::out_of_range("scan frame range out of the table");
  scan_kernel(table.values, table.stride, table.segment_count, query.constants.data(), begin,
              end - begin, out);
}

HScanRootQuery make_h_scan_root_query(const DynamicsModel& model,
                                      const std::array<std::optional<double>, 3>& root_position_m,
                                      double transition_time_s) {
  check_time(transition_time_s);
  HScanRootQuery q;
  for (std::size_t k = 0; k < 3; ++k) {
    if (root_position_m[k] && !std::isfinite(*root_position_m[k]))
      throw InputError("<query>", 0, "root position must be finite");
    q.position[k] = root_position_m[k] ? static_cast<float>(*root_position_m[k]) : 0.0f;
    q.given[k] = root_position_m[k] ? 1.0f : 0.0f;
  }
  q.inv_t2 = static_cast<float>(1.0 / (transition_time_s * transition_time_s));
  q.gravity = static_cast<float>(model.params.gravity_mps2);
  for (int j : model.segments)
    q.masses.push_back(static_cast<float>(model.masses_kg[static_cast<std::size_t>(j)]));
  return q;
}

void scan_root_translation_energy(const HScanView& table, const HScanRootQuery& query,
                                  std::size_t begin, std::size_t end, float* out) {
  if (query.masses.size() != table.segment_count)
    throw std::invalid_argument("scan query and table were made for different character models");
  if (begin > end || end > table.frame_count)
    throw std::out_of_range("scan frame range out of the table");
  root_scan_kernel(table.values, table.root_positions, table.stride,
                   table.root_stride != 0 ? table.root_stride : table.stride, table.segment_count,
                   query.masses.data(), query, begin, end - begin, out);
}

std::vector<NamedEnergyTerm> energy_term_names(const DynamicsModel& model) {
  std::vector<NamedEnergyTerm> out;
  for (std::size_t j = 0; j < model.joint_count(); ++j) {
    if (model.masses_kg[j] > 0.0) out.push_back({model.names[j], false, static_cast<int>(j)});
    if (model.is_term_joint[j]) out.push_back({model.names[j], true, static_cast<int>(j)});
  }
  return out;
}

}  // namespace mocap
