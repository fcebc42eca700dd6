// Per-frame lower bounds of h for partial query frames (partial_bounds.hpp).
#include "bounds/partial_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/util/multiversion.hpp"

namespace mocap::search_detail {

PartialBoundPlan make_partial_bound_plan(const ResolvedFrame& q, const SkeletonTables& tables,
                                         double t) {
  PartialBoundPlan p;
  const PartialQuery& pq = q.partial;
  const DynamicsModel& model = tables.model;
  const std::size_t nj = model.joint_count();
  const auto root = static_cast<std::size_t>(model.root());
  p.whole = pq.moves_whole_body;
  p.half_inv_t2 = 0.5 / (t * t);
  p.mass = tables.segment_mass;
  p.gravity = model.params.gravity_mps2;
  p.heading = pq.spec.root_heading_rad.has_value() && pq.in_subtree[root] == 0;
  if (p.heading) p.psi_q = *pq.spec.root_heading_rad;
  std::vector<int> slot(nj, -1);
  if (!p.whole) {
    for (int jj : pq.subtree_joints) {
      const auto j = static_cast<std::size_t>(jj);
      slot[j] = static_cast<int>(p.sub_joints.size());
      p.sub_joints.push_back(jj);
      const int par = model.parents[j];
      p.sub_parent_slot.push_back(par >= 0 ? slot[static_cast<std::size_t>(par)] : -1);
      const int gi = pq.given_rotation[j];
      p.sub_given.push_back(gi >= 0 ? &pq.spec.joint_rotations[static_cast<std::size_t>(gi)].second
                                    : nullptr);
      const int ps = p.sub_parent_slot.back();
      const bool fixed = gi >= 0 && (ps < 0 || p.mq_fixed[static_cast<std::size_t>(ps)] != 0);
      p.mq_fixed.push_back(fixed);
      p.mq.push_back(!fixed ? Eigen::Quaterniond::Identity()
                            : (ps < 0 ? *p.sub_given.back()
                                      : p.mq[static_cast<std::size_t>(ps)] * *p.sub_given.back()));
      p.nq.push_back(p.mq.back().coeffs().squaredNorm());
    }
  }
  for (std::size_t s = 0; s < tables.segments; ++s) {
    const auto j = static_cast<std::size_t>(model.segments[s]);
    if (!pq.affected[j]) continue;
    p.segs.push_back(s);
    // lambda_min from an eigen-solver: shave a relative 1e-6 off for its rounding.
    p.rot_coef.push_back(tables.lambda_min[s] * (1.0 - 1e-6) * p.half_inv_t2);
    p.turns.push_back(p.whole && p.heading && pq.in_subtree[j] == 0);
    p.sub_slot.push_back(p.whole ? -1 : slot[j]);
    const int sl = p.whole ? -1 : slot[j];
    const bool top = sl >= 0 && p.sub_parent_slot[static_cast<std::size_t>(sl)] < 0 &&
                     p.sub_given[static_cast<std::size_t>(sl)] != nullptr && model.parents[j] >= 0;
    p.top_parent.push_back(top ? model.parents[j] : -1);
    p.top_com.push_back(model.coms_local_m[j]);
    p.top_mg.push_back(model.masses_kg[j] * model.params.gravity_mps2);
    p.top_mh.push_back(model.masses_kg[j] * p.half_inv_t2);
  }
  p.com_term = p.whole && pq.subtree_joints.empty();
  for (std::size_t a = 0; a < 3; ++a) {
    p.given[a] = pq.spec.root_position_m[a].has_value();
    if (p.given[a]) p.root_q[static_cast<Eigen::Index>(a)] = *pq.spec.root_position_m[a];
  }
  return p;
}

void attach_columns(PartialBoundPlan& p, const SkeletonData& skeleton, const Index& index) {
  const SkeletonTables& tables = skeleton.tables;
  if (p.whole || p.heading || p.com_term || p.sub_joints.empty()) return;
  // A subtree's top joint is given (the subtrees are those of given joints),
  // and every listed segment lies in a subtree: else the reference serves.
  for (std::size_t t = 0; t < p.sub_joints.size(); ++t)
    if (p.sub_parent_slot[t] < 0 && !p.mq_fixed[t]) return;
  for (int sl : p.sub_slot)
    if (sl < 0) return;
  auto f4 = [](const Eigen::Quaterniond& q) {
    return std::array<float, 4>{static_cast<float>(q.w()), static_cast<float>(q.x()),
                                static_cast<float>(q.y()), static_cast<float>(q.z())};
  };
  // A slot whose local rotation is F's in Q_F as well (neither given nor
  // below a given one on its chain: mode 2) has its parent slot's angle, as
  // right-multiplying both composites by the same rotation keeps the angle
  // between them (and scales the inner product and both squared norms by
  // |l|^2): it is computed only where a slot below needs its composites.
  const std::size_t ns = p.sub_joints.size();
  std::vector<std::uint8_t> needed(ns, 0);
  for (std::size_t t = ns; t-- > 0;) {
    needed[t] = needed[t] || p.mq_fixed[t] || p.sub_given[t] != nullptr;
    if (needed[t] && p.sub_parent_slot[t] >= 0)
      needed[static_cast<std::size_t>(p.sub_parent_slot[t])] = 1;
  }
  std::vector<std::size_t> lrot_joints, rot_joints;
  for (std::size_t t = 0; t < ns; ++t)
    if (needed[t]) lrot_joints.push_back(static_cast<std::size_t>(p.sub_joints[t]));
  for (int par : p.top_parent)
    if (par >= 0) rot_joints.push_back(static_cast<std::size_t>(par));
  ensure_columns(index, skeleton, JointColumn::local_rotation, lrot_joints);
  ensure_columns(index, skeleton, JointColumn::world_rotation, rot_joints);
  ensure_segment_columns(skeleton, p.segs);
  for (std::size_t t = 0; t < ns; ++t) {
    PartialBoundPlan::ColumnSlot c;
    if (needed[t])
      c.lrot = joint_column(skeleton, JointColumn::local_rotation,
                            static_cast<std::size_t>(p.sub_joints[t]));
    c.parent = p.sub_parent_slot[t];
    c.mq_mode = p.mq_fixed[t] ? 0 : p.sub_given[t] != nullptr ? 1 : 2;
    if (p.sub_given[t] != nullptr) {
      c.given = f4(*p.sub_given[t]);
      c.ngiven = static_cast<float>(p.sub_given[t]->coeffs().squaredNorm());
    }
    c.mq = f4(p.mq[t]);
    c.nq = static_cast<float>(p.nq[t]);
    p.col_slots.push_back(c);
  }
  for (std::size_t i = 0; i < p.segs.size(); ++i) {
    const std::size_t s = p.segs[i];
    PartialBoundPlan::ColumnSegment c;
    c.kb = segment_column(skeleton, s, false);
    c.kr = segment_column(skeleton, s, true);
    c.rot_coef = static_cast<float>(p.rot_coef[i]);
    c.slot = static_cast<std::size_t>(p.sub_slot[i]);
    while (!needed[c.slot]) c.slot = static_cast<std::size_t>(p.sub_parent_slot[c.slot]);
    c.top = p.top_parent[i] >= 0;
    if (c.top) {
      // The top joint's slot is given and fixed: its F composite is F's local rotation.
      c.parent_rot = joint_column(skeleton, JointColumn::world_rotation,
                                  static_cast<std::size_t>(p.top_parent[i]));
      const Eigen::Vector3d lqc = p.sub_given[c.slot]->normalized() * p.top_com[i];
      for (std::size_t a = 0; a < 3; ++a) {
        c.c[a] = static_cast<float>(p.top_com[i][static_cast<Eigen::Index>(a)]);
        c.lq_c[a] = static_cast<float>(lqc[static_cast<Eigen::Index>(a)]);
      }
      c.mg = static_cast<float>(p.top_mg[i]);
      c.mh = static_cast<float>(p.top_mh[i]);
    }
    p.col_segs.push_back(c);
  }
  p.col_stride = tables.col_stride;
}

namespace {

// A lower bound of theta^2, theta in [0, pi] the angle between the rotations
// of two non-zero quaternions x, y with squared norms nx, ny: with
// d = |<x, y>| / (|x| |y|) = cos(theta / 2), 1 - d^2 = sin^2(theta / 2) and
// sin t <= t give theta^2 >= 4 (1 - d^2) (no acos, no square root).
double quat_angle_sq_lower(const Eigen::Quaterniond& x, double nx, const Eigen::Quaterniond& y,
                           double ny) {
  const double c = x.coeffs().dot(y.coeffs());
  return 4.0 * std::max(0.0, 1.0 - c * c / (nx * ny));
}

// The translational h term of scan-table segment b of frame g against a
// static A (K_A = 0) whose segment COM is ca: m g |d_y| + dK(0, K_u, K_B) =
// m g |d_y| + max(K_B, 2 K_u - K_B), K_u = m / (2 T^2) |c_B - ca|^2 (mh the
// last factor, K_B >= 0). The subtree kernel and the partial bound's top
// segments both add it, so the bound is that very value.
double static_translation_h(const SkeletonTables& tables, std::size_t b, std::size_t g,
                            const Eigen::Vector3d& ca, double mg, double mh) {
  const double dx = static_cast<double>(tables.scan_value(b, 0, g)) - ca.x();
  const double dy = static_cast<double>(tables.scan_value(b, 1, g)) - ca.y();
  const double dz = static_cast<double>(tables.scan_value(b, 2, g)) - ca.z();
  const double ku = mh * (dx * dx + dy * dy + dz * dz);
  const double kb = tables.scan_value(b, 3, g);
  return mg * std::abs(dy) + std::max(kb, 2.0 * ku - kb);
}

constexpr double kAngleSlack = 1e-4;     // rad: float32 storage and FK rounding of the angles
constexpr std::size_t kBoundLanes = 64;  // frames per pass of partial_bounds_columns

// partial_frame_bounds_reference's bound for a plan with columns (joint
// rotations only), in float, kBoundLanes frames at a time: the composite
// rotations of every slot for those frames, then each segment's terms, loop
// by loop over the frames (vectorised: AVX-512, AVX2 or SSE clone). The
// same formulas; the float roundings (relative ~1e-6, far below the angle
// slack and the engine's comparison slack, LB (1 - 1e-4) - 1e-3 J) are
// covered as in the box and sketch bounds. `lanes`: 10 kBoundLanes floats
// per slot, scratch.
MOCAP_MULTIVERSION_V4
void partial_bounds_columns(const PartialBoundPlan& p, std::size_t g0, std::size_t g1, double* out,
                            float* lanes) {
  constexpr std::size_t W = kBoundLanes;
  constexpr std::size_t kSlot = 10 * W;  // mf (4 W), nf (W), mq (4 W), nq (W)
  const std::size_t cs = p.col_stride;
  const float slack2 = static_cast<float>(2.0 * std::numbers::pi * kAngleSlack);
  alignas(64) float acc[W];
  for (std::size_t g = g0; g < g1; g += W) {
    const std::size_t n = std::min(W, g1 - g);
    for (std::size_t t = 0; t < p.col_slots.size(); ++t) {
      const PartialBoundPlan::ColumnSlot& sl = p.col_slots[t];
      if (sl.lrot == nullptr) continue;
      float* __restrict mf = lanes + t * kSlot;
      float* __restrict nf = mf + 4 * W;
      float* __restrict mq = mf + 5 * W;
      float* __restrict nq = mf + 9 * W;
      const float* __restrict lw = sl.lrot + g;
      const float* __restrict lx = lw + cs;
      const float* __restrict ly = lw + 2 * cs;
      const float* __restrict lz = lw + 3 * cs;
      if (sl.parent < 0) {
        for (std::size_t i = 0; i < n; ++i) {
          mf[i] = lw[i];
          mf[W + i] = lx[i];
          mf[2 * W + i] = ly[i];
          mf[3 * W + i] = lz[i];
          nf[i] = lw[i] * lw[i] + lx[i] * lx[i] + ly[i] * ly[i] + lz[i] * lz[i];
        }
      } else {
        const float* __restrict pf = lanes + static_cast<std::size_t>(sl.parent) * kSlot;
        for (std::size_t i = 0; i < n; ++i) {
          const float aw = pf[i], ax = pf[W + i], ay = pf[2 * W + i], az = pf[3 * W + i];
          const float bw = lw[i], bx = lx[i], by = ly[i], bz = lz[i];
          mf[i] = aw * bw - ax * bx - ay * by - az * bz;
          mf[W + i] = aw * bx + ax * bw + ay * bz - az * by;
          mf[2 * W + i] = aw * by - ax * bz + ay * bw + az * bx;
          mf[3 * W + i] = aw * bz + ax * by - ay * bx + az * bw;
          nf[i] = pf[4 * W + i] * (bw * bw + bx * bx + by * by + bz * bz);
        }
      }
      if (sl.mq_mode == 0) {
        for (std::size_t i = 0; i < n; ++i) {
          mq[i] = sl.mq[0];
          mq[W + i] = sl.mq[1];
          mq[2 * W + i] = sl.mq[2];
          mq[3 * W + i] = sl.mq[3];
          nq[i] = sl.nq;
        }
      } else {
        // The parent's composite times the given local rotation or F's.
        const float* __restrict pq = lanes + static_cast<std::size_t>(sl.parent) * kSlot + 5 * W;
        const bool given = sl.mq_mode == 1;
        for (std::size_t i = 0; i < n; ++i) {
          const float aw = pq[i], ax = pq[W + i], ay = pq[2 * W + i], az = pq[3 * W + i];
          const float bw = given ? sl.given[0] : lw[i], bx = given ? sl.given[1] : lx[i],
                      by = given ? sl.given[2] : ly[i], bz = given ? sl.given[3] : lz[i];
          mq[i] = aw * bw - ax * bx - ay * by - az * bz;
          mq[W + i] = aw * bx + ax * bw + ay * bz - az * by;
          mq[2 * W + i] = aw * by - ax * bz + ay * bw + az * bx;
          mq[3 * W + i] = aw * bz + ax * by - ay * bx + az * bw;
          nq[i] = pq[4 * W + i] * (given ? sl.ngiven : bw * bw + bx * bx + by * by + bz * bz);
        }
      }
    }
    for (std::size_t i = 0; i < W; ++i) acc[i] = 0.0f;
    for (const PartialBoundPlan::ColumnSegment& sg : p.col_segs) {
      const float* __restrict mf = lanes + sg.slot * kSlot;
      const float* __restrict nf = mf + 4 * W;
      const float* __restrict mq = mf + 5 * W;
      const float* __restrict nq = mf + 9 * W;
      const float* __restrict kr = sg.kr + g;
      const float* __restrict kb = sg.kb + g;
      for (std::size_t i = 0; i < n; ++i) {
        // quat_angle_sq_lower, then the rotational term as the reference.
        const float c = mq[i] * mf[i] + mq[W + i] * mf[W + i] + mq[2 * W + i] * mf[2 * W + i] +
                        mq[3 * W + i] * mf[3 * W + i];
        const float theta2 = 4.0f * std::max(0.0f, 1.0f - c * c / (nq[i] * nf[i]));
        const float ku = sg.rot_coef * std::max(0.0f, theta2 - slack2);
        acc[i] += std::max(kr[i], 2.0f * ku - kr[i]);
      }
      if (!sg.top) {
        for (std::size_t i = 0; i < n; ++i) acc[i] += kb[i];
        continue;
      }
      // static_translation_h with Q_F's COM x_j(F) + R_p(F) L_Q c against F's
      // x_j(F) + R_p(F) L_F c: d = R_p (L_F c - L_Q c), so |d| = |L_F c - L_Q c|,
      // and d_y needs R_p's rotation of that vector. L_F is the top slot's F
      // composite (mf, unnormalised: v = q c q* / |q|^2), R_p unnormalised too.
      // The stored COM and joint position agree with this to float rounding
      // (~1e-6 m, ~1e-5 J here), covered by the engine's comparison slack.
      const float* __restrict rw = sg.parent_rot + g;
      const float* __restrict rx = rw + cs;
      const float* __restrict ry = rw + 2 * cs;
      const float* __restrict rz = rw + 3 * cs;
      const float ox = sg.c[0], oy = sg.c[1], oz = sg.c[2];
      for (std::size_t i = 0; i < n; ++i) {
        const float qw = mf[i], qx = mf[W + i], qy = mf[2 * W + i], qz = mf[3 * W + i];
        const float uu = qx * qx + qy * qy + qz * qz;
        const float uc = qx * ox + qy * oy + qz * oz;
        const float k0 = qw * qw - uu;
        const float inv = 1.0f / nf[i];
        const float ex =
            (k0 * ox + 2.0f * uc * qx + 2.0f * qw * (qy * oz - qz * oy)) * inv - sg.lq_c[0];
        const float ey =
            (k0 * oy + 2.0f * uc * qy + 2.0f * qw * (qz * ox - qx * oz)) * inv - sg.lq_c[1];
        const float ez =
            (k0 * oz + 2.0f * uc * qz + 2.0f * qw * (qx * oy - qy * ox)) * inv - sg.lq_c[2];
        const float aw = rw[i], ax = rx[i], ay = ry[i], az = rz[i];
        const float ae = ax * ex + ay * ey + az * ez;
        const float dy = ((aw * aw - (ax * ax + ay * ay + az * az)) * ey + 2.0f * ae * ay +
                          2.0f * aw * (az * ex - ax * ez)) /
                         (aw * aw + ax * ax + ay * ay + az * az);
        const float ku = sg.mh * (ex * ex + ey * ey + ez * ez);
        acc[i] += sg.mg * std::fabs(dy) + std::max(kb[i], 2.0f * ku - kb[i]);
      }
    }
    for (std::size_t i = 0; i < n; ++i) out[g - g0 + i] = static_cast<double>(acc[i]);
  }
}

}  // namespace

namespace {

// The translational part of partial_frame_bounds_reference's bound at frame
// g for a plan with a whole-body COM term: the larger of the segments' sum
// `kt` and the whole body's COM moved from F to Q_F (F turned about the
// vertical through the root to the given heading, then shifted on the given
// axes), plus the gravity term of that move.
double whole_body_com_bound(const PartialBoundPlan& p, const SkeletonTables& tables,
                            const FrameArrays& fa, std::size_t g, double kt) {
  const std::size_t nj = tables.model.joint_count();
  const auto root = static_cast<std::size_t>(tables.model.root());
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (std::size_t s = 0; s < tables.segments; ++s)
    for (std::size_t a = 0; a < 3; ++a)
      c[static_cast<Eigen::Index>(a)] +=
          tables.masses[s] * static_cast<double>(tables.scan_value(s, a, g));
  c /= p.mass;
  const Eigen::Vector3d root_f(tables.root_position(0, g), tables.root_position(1, g),
                               tables.root_position(2, g));
  Eigen::Vector3d v = c - root_f;
  if (p.heading) {
    const float* r = fa.rot + (g * nj + root) * 4;
    const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
    v = Eigen::AngleAxisd(p.psi_q - heading_rad(rr), Eigen::Vector3d::UnitY()) * v;
  }
  Eigen::Vector3d cq = root_f + v;
  for (std::size_t a = 0; a < 3; ++a)
    if (p.given[a])
      cq[static_cast<Eigen::Index>(a)] +=
          p.root_q[static_cast<Eigen::Index>(a)] - root_f[static_cast<Eigen::Index>(a)];
  const Eigen::Vector3d d = cq - c;
  return std::max(kt, p.mass * d.squaredNorm() * p.half_inv_t2) +
         p.mass * p.gravity * std::abs(d.y());
}

}  // namespace

void partial_frame_bounds_reference(const PartialBoundPlan& p, const SkeletonTables& tables,
                                    const FrameArrays& fa, std::size_t g0, std::size_t g1,
                                    double* out, Scratch& scratch) {
  const std::size_t nj = tables.model.joint_count();
  const auto root = static_cast<std::size_t>(tables.model.root());
  scratch.mq.resize(p.sub_joints.size());
  scratch.mf.resize(p.sub_joints.size());
  scratch.nq.resize(p.sub_joints.size());
  scratch.nf.resize(p.sub_joints.size());
  // The frame arrays hold all joints of a frame together (stride nj): the
  // rows a few frames ahead are prefetched (the hardware prefetcher falls
  // behind on this stride: the loads took about a quarter of the pass; 8
  // frames ahead measured about 10 % faster on arm queries, 24 no better).
  constexpr std::size_t kAhead = 8;
  const std::size_t first_joint =
      p.sub_joints.empty() ? 0 : static_cast<std::size_t>(p.sub_joints.front());
  for (std::size_t g = g0; g < g1; ++g) {
    if (!p.sub_joints.empty() && g + kAhead < g1) {
      __builtin_prefetch(fa.lrot + ((g + kAhead) * nj + first_joint) * 4);
      for (std::size_t i = 0; i < p.segs.size(); ++i)
        if (p.top_parent[i] >= 0) {
          const auto j = static_cast<std::size_t>(tables.model.segments[p.segs[i]]);
          __builtin_prefetch(fa.rot +
                             ((g + kAhead) * nj + static_cast<std::size_t>(p.top_parent[i])) * 4);
          __builtin_prefetch(fa.pos + ((g + kAhead) * nj + j) * 3);
        }
    }
    for (std::size_t t = 0; t < p.sub_joints.size(); ++t) {
      const float* l = fa.lrot + (g * nj + static_cast<std::size_t>(p.sub_joints[t])) * 4;
      // Not normalised: the angle bound divides by the squared norms (which multiply).
      const Eigen::Quaterniond lf(static_cast<double>(l[0]), static_cast<double>(l[1]),
                                  static_cast<double>(l[2]), static_cast<double>(l[3]));
      const double nlf = lf.coeffs().squaredNorm();
      const int ps = p.sub_parent_slot[t];
      // Slot t's composite rotation (and squared norm): its parent slot's times
      // the local one, or the local one at the top of a subtree.
      auto chain = [&](std::vector<Eigen::Quaterniond>& m, std::vector<double>& nm,
                       const Eigen::Quaterniond& local, double nlocal) {
        if (ps < 0) {
          m[t] = local;
          nm[t] = nlocal;
        } else {
          m[t] = m[static_cast<std::size_t>(ps)] * local;
          nm[t] = nm[static_cast<std::size_t>(ps)] * nlocal;
        }
      };
      chain(scratch.mf, scratch.nf, lf, nlf);
      if (p.mq_fixed[t]) {
        scratch.mq[t] = p.mq[t];
        scratch.nq[t] = p.nq[t];
      } else if (p.sub_given[t] != nullptr) {
        chain(scratch.mq, scratch.nq, *p.sub_given[t], p.sub_given[t]->coeffs().squaredNorm());
      } else {
        chain(scratch.mq, scratch.nq, lf, nlf);
      }
    }
    double turn = 0.0;
    if (p.heading) {
      const float* r = fa.rot + (g * nj + root) * 4;
      const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
      turn = std::fmod(std::abs(p.psi_q - heading_rad(rr)), 2.0 * std::numbers::pi);
      if (turn > std::numbers::pi) turn = 2.0 * std::numbers::pi - turn;
    }
    double kt = 0.0, rot = 0.0;
    for (std::size_t i = 0; i < p.segs.size(); ++i) {
      const std::size_t s = p.segs[i];
      if (p.top_parent[i] >= 0) {
        // Q_F's COM: F's joint position + R_p(F) L_Q c (as subtree_energy computes it).
        const auto j = static_cast<std::size_t>(tables.model.segments[s]);
        const float* r = fa.rot + (g * nj + static_cast<std::size_t>(p.top_parent[i])) * 4;
        const float* x = fa.pos + (g * nj + j) * 3;
        const Eigen::Quaterniond rq = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized() *
                                      *p.sub_given[static_cast<std::size_t>(p.sub_slot[i])];
        const Eigen::Vector3d ca = Eigen::Vector3d(x[0], x[1], x[2]) + rq * p.top_com[i];
        kt += static_translation_h(tables, s, g, ca, p.top_mg[i], p.top_mh[i]);
      } else {
        kt += static_cast<double>(tables.scan_value(s, 3, g));
      }
      const double kr = tables.scan_value(s, 8, g);
      // (theta - s)^2 >= theta^2 - 2 pi s for theta in [0, pi], s the slack.
      double theta2 = 0.0;
      if (p.turns[i]) {
        theta2 = turn * turn;
      } else if (p.sub_slot[i] >= 0) {
        const auto t = static_cast<std::size_t>(p.sub_slot[i]);
        theta2 = quat_angle_sq_lower(scratch.mq[t], scratch.nq[t], scratch.mf[t], scratch.nf[t]);
      }
      const double ku =
          p.rot_coef[i] * std::max(0.0, theta2 - 2.0 * std::numbers::pi * kAngleSlack);
      rot += std::max(kr, 2.0 * ku - kr);
    }
    const double trans = p.com_term ? whole_body_com_bound(p, tables, fa, g, kt) : kt;
    out[g - g0] = trans + rot;
  }
}

void partial_frame_bounds(const PartialBoundPlan& p, const SkeletonTables& tables,
                          const FrameArrays* fa, std::size_t g0, std::size_t g1, double* out,
                          Scratch& scratch) {
  if (p.col_segs.empty()) {
    partial_frame_bounds_reference(p, tables, *fa, g0, g1, out, scratch);
    return;
  }
  scratch.lanes.resize(p.col_slots.size() * 10 * kBoundLanes);
  partial_bounds_columns(p, g0, g1, out, scratch.lanes.data());
}

}  // namespace mocap::search_detail
