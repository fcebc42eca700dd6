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

// subtree_energy_lanes' rows of kSubtreeLanes doubles (one frame a lane):
// per subtree slot the joint's position (3 rows) and world rotation (4 rows:
// w x y z) in Q_F; then scratch rows: the parent's rotation (4), the local
// rotation (4), two positions (3 each), the table fields of a segment
// (HScanField::count), the total (1).
struct SubtreeRows {
  double* lanes;
  double* parent_rotation;
  double* local_rotation;
  double* p0;
  double* p1;
  double* fld;
  double* total;
  explicit SubtreeRows(double* l, std::size_t slots)
      : lanes(l),
        parent_rotation(l + slots * 7 * kSubtreeLanes),
        local_rotation(parent_rotation + 4 * kSubtreeLanes),
        p0(local_rotation + 4 * kSubtreeLanes),
        p1(p0 + 3 * kSubtreeLanes),
        fld(p1 + 3 * kSubtreeLanes),
        total(fld + HScanField::count * kSubtreeLanes) {}
  double* position(std::size_t slot) const { return lanes + slot * 7 * kSubtreeLanes; }
  double* rotation(std::size_t slot) const { return position(slot) + 3 * kSubtreeLanes; }
};

// Copies `rows` rows (`stride` floats apart) of a column group from frame g
// for the n frames of the lanes, the lanes past n padded with pad[row].
[[gnu::always_inline]] inline void load_rows(const float* col, std::size_t stride, std::size_t rows,
                                             std::size_t g, std::size_t n, double* dst,
                                             const double* pad) {
  constexpr std::size_t W = kSubtreeLanes;
  for (std::size_t c = 0; c < rows; ++c) {
    const float* src = col + c * stride + g;
    for (std::size_t i = 0; i < n; ++i) dst[c * W + i] = static_cast<double>(src[i]);
    for (std::size_t i = n; i < W; ++i) dst[c * W + i] = pad[c];
  }
}

// Normalises the quaternion rows qv in place (Eigen's normalized()).
[[gnu::always_inline]] inline void normalise_rows(double* qv) {
  constexpr std::size_t W = kSubtreeLanes;
  for (std::size_t i = 0; i < W; ++i) {
    const double nn = std::sqrt(qv[i] * qv[i] + qv[W + i] * qv[W + i] +
                                qv[2 * W + i] * qv[2 * W + i] + qv[3 * W + i] * qv[3 * W + i]);
    qv[i] /= nn;
    qv[W + i] /= nn;
    qv[2 * W + i] /= nn;
    qv[3 * W + i] /= nn;
  }
}

// a * b into d (quaternion rows, Eigen's product).
[[gnu::always_inline]] inline void multiply_rows(const double* a, const double* b, double* d) {
  constexpr std::size_t W = kSubtreeLanes;
  for (std::size_t i = 0; i < W; ++i) {
    const double aw = a[i], ax = a[W + i], ay = a[2 * W + i], az = a[3 * W + i];
    const double bw = b[i], bx = b[W + i], by = b[2 * W + i], bz = b[3 * W + i];
    d[i] = aw * bw - ax * bx - ay * by - az * bz;
    d[W + i] = aw * bx + ax * bw + ay * bz - az * by;
    d[2 * W + i] = aw * by + ay * bw + az * bx - ax * bz;
    d[3 * W + i] = aw * bz + az * bw + ax * by - ay * bx;
  }
}

// A joint whose parent is in the subtree: F's local translation of the joint
// (in F's frame of the parent, F's positions p0 of the joint and p1 of the
// parent, F's parent rotation R_p), o = conj(R_p) (x_j - x_p), on Q_F's
// parent (position xp, rotation rp): x = x_ps + R_ps o (m).
[[gnu::always_inline]] inline void child_position_rows(const SubtreeRows& rows, const double* xp,
                                                       const double* rp, double* x) {
  constexpr std::size_t W = kSubtreeLanes;
  const double* const p0 = rows.p0;
  const double* const p1 = rows.p1;
  const double* const parent_rotation = rows.parent_rotation;
  for (std::size_t i = 0; i < W; ++i) {
    // Eigen's q * v: uv = 2 (u x v); v + w uv + u x uv, with q = conj(R_p).
    const double vx = p0[i] - p1[i], vy = p0[W + i] - p1[W + i], vz = p0[2 * W + i] - p1[2 * W + i];
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
}

// Slot t of the subtree in Q_F for the frames [g, g + n) of the lanes: its
// joint's position and world rotation (F's parent rotation times the given
// or F's local rotation, both normalised), from F's where the parent is F's,
// else from the parent slot's (slots are in parent-first order).
[[gnu::always_inline]] inline void subtree_joint_rows(const ResolvedFrame::SubtreeJoint& sj,
                                                      std::size_t t, std::size_t cs, std::size_t g,
                                                      std::size_t n, const SubtreeRows& rows) {
  constexpr std::size_t W = kSubtreeLanes;
  static constexpr double kIdentity[4] = {1.0, 0.0, 0.0, 0.0};
  static constexpr double kZero[9] = {};
  double* const x = rows.position(t);  // x, y, z rows
  double* const r = rows.rotation(t);  // w, x, y, z rows
  load_rows(sj.parent_rot, cs, 4, g, n, rows.parent_rotation, kIdentity);
  if (sj.given) {
    const Eigen::Quaterniond& l = sj.local;
    for (std::size_t i = 0; i < W; ++i) {
      rows.local_rotation[i] = l.w();
      rows.local_rotation[W + i] = l.x();
      rows.local_rotation[2 * W + i] = l.y();
      rows.local_rotation[3 * W + i] = l.z();
    }
  } else {
    load_rows(sj.lrot, cs, 4, g, n, rows.local_rotation, kIdentity);
  }
  normalise_rows(rows.parent_rotation);
  if (!sj.given) normalise_rows(rows.local_rotation);
  load_rows(sj.pos, cs, 3, g, n, rows.p0, kZero);
  if (sj.parent_slot < 0) {
    // The parent is F's: so is the joint's position.
    for (std::size_t i = 0; i < 3 * W; ++i) x[i] = rows.p0[i];
    multiply_rows(rows.parent_rotation, rows.local_rotation, r);
  } else {
    load_rows(sj.parent_pos, cs, 3, g, n, rows.p1, kZero);
    const auto ps = static_cast<std::size_t>(sj.parent_slot);
    child_position_rows(rows, rows.position(ps), rows.rotation(ps), x);
    multiply_rows(rows.rotation(ps), rows.local_rotation, r);
  }
}

// Adds segment sg's h terms (J) of the lanes' frames into rows.total, its
// scan values read from the tiles (lane i's field k at tile[i][(b * count +
// k) * stride[i]]; padding lanes: a static identity segment): the static
// query's translational term of its COM in Q_F, and the rotational term of
// conj(q_A P) (q_B P) with the scan's formula.
[[gnu::always_inline]] inline void add_segment_h(const ResolvedFrame::SubtreeSegment& sg,
                                                 const float* const (&tile)[kSubtreeLanes],
                                                 const std::size_t (&stride)[kSubtreeLanes],
                                                 std::size_t n, const SubtreeRows& rows) {
  constexpr std::size_t W = kSubtreeLanes;
  using F = HScanField;
  const double* const x = rows.position(sg.slot);
  const double* const r = rows.rotation(sg.slot);
  double* const fld = rows.fld;
  double* const total = rows.total;
  const std::size_t b = sg.segment;
  for (std::size_t k = 0; k < F::count; ++k) {
    const std::size_t at = b * F::count + k;
    for (std::size_t i = 0; i < n; ++i)
      fld[k * W + i] = static_cast<double>(tile[i][at * stride[i]]);
    for (std::size_t i = n; i < W; ++i) fld[k * W + i] = k == F::orient_w ? 1.0 : 0.0;
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
    const double dx = fld[F::com_x * W + i] - cax, dy = fld[F::com_y * W + i] - cay,
                 dz = fld[F::com_z * W + i] - caz;
    const double ku = sg.mh * (dx * dx + dy * dy + dz * dz);
    const double kb = fld[F::kinetic * W + i];
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
    const double bw = fld[F::orient_w * W + i], bx = fld[F::orient_x * W + i],
                 by = fld[F::orient_y * W + i], bz = fld[F::orient_z * W + i];
    // r = conj(q_A P) (q_B P), K_w = |log r|_D^2 / (2 T^2) (the scan's formula).
    const double tw = aw * bw - ax * bx - ay * by - az * bz;
    const double tx = aw * bx + bw * ax + ay * bz - az * by;
    const double ty = aw * by + bw * ay + az * bx - ax * bz;
    const double tz = aw * bz + bw * az + ax * by - ay * bx;
    const double kbr = fld[F::kinetic_rot * W + i];
    const double sd2 = sg.d[0] * tx * tx + sg.d[1] * ty * ty + sg.d[2] * tz * tz;
    // log_norm_factor <= pi^2 (+1.6e-8): when 9.88 sd2 <= K_B^rot, K_w <= K_B^rot and
    // the term is K_B^rot whatever the factor (the same value, without the polynomial).
    const double full =
        std::max(kbr, 2.0 * (log_norm_factor(std::max(0.0, 1.0 - std::abs(tw))) * sd2) - kbr);
    total[i] += trans + (9.88 * sd2 > kbr ? full : kbr);
  }
}

// h of a joint-rotation query frame for the frames [g0, g1) into out,
// kSubtreeLanes frames at a time (lanes: subtree_lane_doubles(q) doubles);
// frames with skip[i] != 0 are left alone (a group of only such is skipped).
MOCAP_MULTIVERSION_V4
void subtree_energy_lanes(const ResolvedFrame& q, const SkeletonTables& tables, std::size_t g0,
                          std::size_t g1, double* out, double* lanes, const std::uint8_t* skip) {
  constexpr std::size_t W = kSubtreeLanes;
  const SubtreeRows rows(lanes, q.subtree.size());
  for (std::size_t g = g0; g < g1; g += W) {
    const std::size_t n = std::min(W, g1 - g);
    if (skip != nullptr) {
      bool any = false;
      for (std::size_t i = 0; i < n; ++i) any = any || skip[g - g0 + i] == 0;
      if (!any) continue;
    }
    for (std::size_t t = 0; t < q.subtree.size(); ++t)
      subtree_joint_rows(q.subtree[t], t, tables.col_stride, g, n, rows);
    for (std::size_t i = 0; i < W; ++i) rows.total[i] = 0.0;
    // Where the n frames' scan values lie in the tiles.
    const float* tile[W];
    std::size_t stride[W];
    tables.for_each_tile_piece(
        g, g + n, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
          for (std::size_t i = 0; i < count; ++i) {
            tile[offset + i] = tables.tile_data(row) + lane + i;
            stride[offset + i] = tables.tile_stride(row);
          }
        });
    for (const ResolvedFrame::SubtreeSegment& sg : q.subtree_segments)
      add_segment_h(sg, tile, stride, n, rows);
    for (std::size_t i = 0; i < n; ++i)
      if (skip == nullptr || skip[g - g0 + i] == 0) out[g - g0 + i] = rows.total[i];
  }
}

}  // namespace

void subtree_energy(const ResolvedFrame& q, const SkeletonTables& tables, std::size_t g0,
                    std::size_t g1, double* out, Scratch& scratch, const std::uint8_t* skip) {
  scratch.subtree_lanes.resize(subtree_lane_doubles(q));
  subtree_energy_lanes(q, tables, g0, g1, out, scratch.subtree_lanes.data(), skip);
}

}  // namespace mocap::search_detail
