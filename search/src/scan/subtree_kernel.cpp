// The subtree kernel: h of joint-rotation query frames (subtree_kernel.hpp).
#include "scan/subtree_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "mocap/common/util/multiversion.hpp"

namespace mocap::search_detail {

void set_subtree_plan(ResolvedFrame& q, const SkeletonData& skeleton, const Index& index,
                      double t) {
  const SkeletonTables& tables = skeleton.tables;
  q.subtree.clear();
  q.subtree_segments.clear();
  if (q.kind != FrameKind::partial || q.partial.moves_whole_body ||
      q.partial.subtree_joints.empty() || q.solve)
    return;
  const DynamicsModel& model = tables.model;
  const PartialQuery& pq = q.partial;
  std::vector<int> slot(model.joint_count(), -1);
  for (int jj : pq.subtree_joints) {
    const auto j = static_cast<std::size_t>(jj);
    const int par = model.parents[j];
    if (par < 0) {  // the root rotated: not this case (it moves the whole body)
      q.subtree.clear();
      return;
    }
    ResolvedFrame::SubtreeJoint sj;
    sj.joint = j;
    sj.parent = static_cast<std::size_t>(par);
    sj.parent_slot = slot[sj.parent];
    const int gi = pq.given_rotation[j];
    sj.given = gi >= 0;
    if (sj.given) sj.local = pq.spec.joint_rotations[static_cast<std::size_t>(gi)].second;
    slot[j] = static_cast<int>(q.subtree.size());
    q.subtree.push_back(sj);
  }
  std::vector<std::size_t> rot_joints, lrot_joints, pos_joints;
  for (const ResolvedFrame::SubtreeJoint& sj : q.subtree) {
    rot_joints.push_back(sj.parent);
    // Given joints too: the per-frame bound (attach_columns) reads F's local
    // rotation of those, and one pass over the array serves both.
    lrot_joints.push_back(sj.joint);
    pos_joints.push_back(sj.joint);
    if (sj.parent_slot >= 0) pos_joints.push_back(sj.parent);
  }
  ensure_columns(index, skeleton, JointColumn::world_rotation, rot_joints);
  ensure_columns(index, skeleton, JointColumn::local_rotation, lrot_joints);
  ensure_columns(index, skeleton, JointColumn::position, pos_joints);
  for (ResolvedFrame::SubtreeJoint& sj : q.subtree) {
    sj.parent_rot = joint_column(skeleton, JointColumn::world_rotation, sj.parent);
    if (!sj.given) sj.lrot = joint_column(skeleton, JointColumn::local_rotation, sj.joint);
    sj.pos = joint_column(skeleton, JointColumn::position, sj.joint);
    if (sj.parent_slot >= 0)
      sj.parent_pos = joint_column(skeleton, JointColumn::position, sj.parent);
  }
  const double half_inv_t2 = 0.5 / (t * t);
  for (int jj : pq.affected_joints) {
    const auto j = static_cast<std::size_t>(jj);
    if (!(model.masses_kg[j] > 0.0) || slot[j] < 0 || tables.segment_of_joint[j] < 0) continue;
    ResolvedFrame::SubtreeSegment sg;
    sg.slot = static_cast<std::size_t>(slot[j]);
    sg.segment = static_cast<std::size_t>(tables.segment_of_joint[j]);
    sg.mg = model.masses_kg[j] * model.params.gravity_mps2;
    sg.mh = model.masses_kg[j] * half_inv_t2;
    sg.com_local = model.coms_local_m[j];
    sg.principal = model.principal_frames[j];
    for (int k = 0; k < 3; ++k)
      sg.d[static_cast<std::size_t>(k)] = model.principal_moments_kgm2[j][k] * half_inv_t2;
    q.subtree_segments.push_back(sg);
  }
}

namespace {

constexpr std::size_t kSubtreeLanes = 16;
std::size_t subtree_lane_doubles(const ResolvedFrame& q) {
  return (q.subtree.size() * 7 + 24) * kSubtreeLanes;
}

MOCAP_MULTIVERSION_V4
void subtree_energy_lanes(const ResolvedFrame& q, const SkeletonTables& tables, std::size_t g0,
                          std::size_t g1, double* out, double* lanes, const std::uint8_t* skip) {
  constexpr std::size_t W = kSubtreeLanes;
  const std::size_t cs = tables.col_stride;
  const std::size_t ns = q.subtree.size();
  // Per slot: the joint's position (3 W) and world rotation (4 W) in Q_F;
  // then scratch rows: the parent's rotation (4 W), the local rotation (4 W),
  // two positions (6 W), the table fields of a segment (9 W), the total (W).
  double* const parent_rotation = lanes + ns * 7 * W;
  double* const local_rotation = parent_rotation + 4 * W;
  double* const p0 = local_rotation + 4 * W;
  double* const p1 = p0 + 3 * W;
  double* const fld = p1 + 3 * W;
  double* const total = fld + 9 * W;
  // Copies rows of a column group (count rows of `stride`) for the lanes, padding with `pad`.
  auto load = [&](const float* col, std::size_t stride, std::size_t rows, std::size_t g,
                  std::size_t n, double* dst, const double* pad) {
    for (std::size_t c = 0; c < rows; ++c) {
      const float* src = col + c * stride + g;
      for (std::size_t i = 0; i < n; ++i) dst[c * W + i] = static_cast<double>(src[i]);
      for (std::size_t i = n; i < W; ++i) dst[c * W + i] = pad[c];
    }
  };
  static constexpr double kIdentity[4] = {1.0, 0.0, 0.0, 0.0};
  static constexpr double kZero[9] = {};
  for (std::size_t g = g0; g < g1; g += W) {
    const std::size_t n = std::min(W, g1 - g);
    if (skip != nullptr) {
      bool any = false;
      for (std::size_t i = 0; i < n; ++i) any = any || skip[g - g0 + i] == 0;
      if (!any) continue;
    }
    for (std::size_t t = 0; t < ns; ++t) {
      const ResolvedFrame::SubtreeJoint& sj = q.subtree[t];
      double* const x = lanes + t * 7 * W;  // x, y, z rows
      double* const r = x + 3 * W;          // w, x, y, z rows
      // F's parent rotation and the joint's local rotation, normalised (Eigen's normalized()).
      load(sj.parent_rot, cs, 4, g, n, parent_rotation, kIdentity);
      if (sj.given) {
        const Eigen::Quaterniond& l = sj.local;
        for (std::size_t i = 0; i < W; ++i) {
          local_rotation[i] = l.w();
          local_rotation[W + i] = l.x();
          local_rotation[2 * W + i] = l.y();
          local_rotation[3 * W + i] = l.z();
        }
      } else {
        load(sj.lrot, cs, 4, g, n, local_rotation, kIdentity);
      }
      for (double* qv : {parent_rotation, local_rotation}) {
        if (qv == local_rotation && sj.given) break;
        for (std::size_t i = 0; i < W; ++i) {
          const double nn =
              std::sqrt(qv[i] * qv[i] + qv[W + i] * qv[W + i] + qv[2 * W + i] * qv[2 * W + i] +
                        qv[3 * W + i] * qv[3 * W + i]);
          qv[i] /= nn;
          qv[W + i] /= nn;
          qv[2 * W + i] /= nn;
          qv[3 * W + i] /= nn;
        }
      }
      load(sj.pos, cs, 3, g, n, p0, kZero);
      // a * b into d (quaternions, Eigen's product)
      auto qmul = [&](const double* a, const double* b, double* d) {
        for (std::size_t i = 0; i < W; ++i) {
          const double aw = a[i], ax = a[W + i], ay = a[2 * W + i], az = a[3 * W + i];
          const double bw = b[i], bx = b[W + i], by = b[2 * W + i], bz = b[3 * W + i];
          d[i] = aw * bw - ax * bx - ay * by - az * bz;
          d[W + i] = aw * bx + ax * bw + ay * bz - az * by;
          d[2 * W + i] = aw * by + ay * bw + az * bx - ax * bz;
          d[3 * W + i] = aw * bz + az * bw + ax * by - ay * bx;
        }
      };
      if (sj.parent_slot < 0) {
        // The parent is F's: so is the joint's position.
        for (std::size_t i = 0; i < 3 * W; ++i) x[i] = p0[i];
        qmul(parent_rotation, local_rotation, r);
      } else {
        // F's local translation of the joint (in F's frame of the parent),
        // o = conj(R_p) (x_j - x_p), on Q_F's parent: x = x_ps + R_ps o.
        load(sj.parent_pos, cs, 3, g, n, p1, kZero);
        const auto ps = static_cast<std::size_t>(sj.parent_slot);
        const double* const xp = lanes + ps * 7 * W;
        const double* const rp = xp + 3 * W;
        for (std::size_t i = 0; i < W; ++i) {
          // Eigen's q * v: uv = 2 (u x v); v + w uv + u x uv, with q = conj(R_p).
          const double vx = p0[i] - p1[i], vy = p0[W + i] - p1[W + i],
                       vz = p0[2 * W + i] - p1[2 * W + i];
          const double w = parent_rotation[i], ux = -parent_rotation[W + i],
                       uy = -parent_rotation[2 * W + i], uz = -parent_rotation[3 * W + i];
          double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
          cx += cx;
          cy += cy;
          cz += cz;
          const double ox = vx + w * cx + (uy * cz - uz * cy);
          const double oy = vy + w * cy + (uz * cx - ux * cz);
          const double oz = vz + w * cz + (ux * cy - uy * cx);
          // x_ps + R_ps o
          const double rw = rp[i], rx = rp[W + i], ry = rp[2 * W + i], rz = rp[3 * W + i];
          double dx = ry * oz - rz * oy, dy = rz * ox - rx * oz, dz = rx * oy - ry * ox;
          dx += dx;
          dy += dy;
          dz += dz;
          x[i] = xp[i] + (ox + rw * dx + (ry * dz - rz * dy));
          x[W + i] = xp[W + i] + (oy + rw * dy + (rz * dx - rx * dz));
          x[2 * W + i] = xp[2 * W + i] + (oz + rw * dz + (rx * dy - ry * dx));
        }
        qmul(rp, local_rotation, r);
      }
    }
    for (std::size_t i = 0; i < W; ++i) total[i] = 0.0;
    // Where the n frames' scan values lie in the tiles: lane i's segment b
    // field k is tile[i][(b * 9 + k) * stride[i]].
    const float* tile[W];
    std::size_t stride[W];
    tables.for_each_tile_piece(
        g, g + n, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
          for (std::size_t i = 0; i < count; ++i) {
            tile[offset + i] = tables.tile_data(row) + lane + i;
            stride[offset + i] = tables.tile_stride(row);
          }
        });
    for (const ResolvedFrame::SubtreeSegment& sg : q.subtree_segments) {
      const double* const x = lanes + sg.slot * 7 * W;
      const double* const r = x + 3 * W;
      const std::size_t b = sg.segment;
      for (std::size_t k = 0; k < HScanTable::kFields; ++k) {
        const std::size_t at = b * HScanTable::kFields + k;
        for (std::size_t i = 0; i < n; ++i)
          fld[k * W + i] = static_cast<double>(tile[i][at * stride[i]]);
        for (std::size_t i = n; i < W; ++i) fld[k * W + i] = k == 4 ? 1.0 : 0.0;
      }
      const double cx = sg.com_local.x(), cy = sg.com_local.y(), cz = sg.com_local.z();
      const double qw = sg.principal.w(), qx = sg.principal.x(), qy = sg.principal.y(),
                   qz = sg.principal.z();
      for (std::size_t i = 0; i < W; ++i) {
        const double rw = r[i], rx = r[W + i], ry = r[2 * W + i], rz = r[3 * W + i];
        // ca = x + r * com_local (Eigen's q * v)
        double ux = ry * cz - rz * cy, uy = rz * cx - rx * cz, uz = rx * cy - ry * cx;
        ux += ux;
        uy += uy;
        uz += uz;
        const double cax = x[i] + (cx + rw * ux + (ry * uz - rz * uy));
        const double cay = x[W + i] + (cy + rw * uy + (rz * ux - rx * uz));
        const double caz = x[2 * W + i] + (cz + rw * uz + (rx * uy - ry * ux));
        // static_translation_h
        const double dx = fld[i] - cax, dy = fld[W + i] - cay, dz = fld[2 * W + i] - caz;
        const double ku = sg.mh * (dx * dx + dy * dy + dz * dz);
        const double kb = fld[3 * W + i];
        const double trans = sg.mg * std::abs(dy) + std::max(kb, 2.0 * ku - kb);
        // a = conj(normalised(r * principal))
        double aw = rw * qw - rx * qx - ry * qy - rz * qz;
        double ax = rw * qx + rx * qw + ry * qz - rz * qy;
        double ay = rw * qy + ry * qw + rz * qx - rx * qz;
        double az = rw * qz + rz * qw + rx * qy - ry * qx;
        const double an = std::sqrt(aw * aw + ax * ax + ay * ay + az * az);
        aw /= an;
        ax = -(ax / an);
        ay = -(ay / an);
        az = -(az / an);
        const double bw = fld[4 * W + i], bx = fld[5 * W + i], by = fld[6 * W + i],
                     bz = fld[7 * W + i];
        // r = conj(q_A P) (q_B P), K_w = |log r|_D^2 / (2 T^2) (the scan's formula).
        const double tw = aw * bw - ax * bx - ay * by - az * bz;
        const double tx = aw * bx + bw * ax + ay * bz - az * by;
        const double ty = aw * by + bw * ay + az * bx - ax * bz;
        const double tz = aw * bz + bw * az + ax * by - ay * bx;
        const double kbr = fld[8 * W + i];
        const double sd2 = sg.d[0] * tx * tx + sg.d[1] * ty * ty + sg.d[2] * tz * tz;
        // log_norm_factor <= pi^2 (+1.6e-8): when 9.88 sd2 <= K_B^rot, K_w <= K_B^rot and
        // the term is K_B^rot whatever the factor (the same value, without the polynomial).
        const double full =
            std::max(kbr, 2.0 * (log_norm_factor(std::max(0.0, 1.0 - std::abs(tw))) * sd2) - kbr);
        total[i] += trans + (9.88 * sd2 > kbr ? full : kbr);
      }
    }
    for (std::size_t i = 0; i < n; ++i)
      if (skip == nullptr || skip[g - g0 + i] == 0) out[g - g0 + i] = total[i];
  }
}

}  // namespace

void subtree_energy(const ResolvedFrame& q, const SkeletonTables& tables, std::size_t g0,
                    std::size_t g1, double* out, Scratch& scratch, const std::uint8_t* skip) {
  scratch.subtree_lanes.resize(subtree_lane_doubles(q));
  subtree_energy_lanes(q, tables, g0, g1, out, scratch.subtree_lanes.data(), skip);
}

}  // namespace mocap::search_detail
