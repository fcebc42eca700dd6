// h of a query frame against database frames (frame_energy.hpp).
#include "scan/frame_energy.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <numbers>
#include <vector>

#include "query/relative_frames.hpp"
#include "scan/context_energy.hpp"
#include "scan/subtree_kernel.hpp"

namespace mocap::search_detail {

namespace {

// Converts skeleton frame g into scratch (double) and returns its FrameRef.
// Only the joints in `need` are converted (all when it is empty); the local
// translations only for `local` (all when `need` is empty). The caller passes
// the joints partial_approximate_energy reads for its query
// (partial_needed_joints); the other entries are never read.
FrameRef frame_ref(const SkeletonTables& tables, const FrameArrays& fa, std::size_t g,
                   Scratch& scratch, const std::vector<int>& need, const std::vector<int>& local) {
  const std::size_t nj = tables.model.joint_count();
  if (scratch.pos.size() != nj) {
    scratch.pos.assign(nj, Eigen::Vector3d::Zero());
    scratch.com.assign(nj, Eigen::Vector3d::Zero());
    scratch.vel.assign(nj, Eigen::Vector3d::Zero());
    scratch.angvel.assign(nj, Eigen::Vector3d::Zero());
    scratch.zero.assign(nj, Eigen::Vector3d::Zero());
    scratch.ltrans.assign(nj, Eigen::Vector3d::Zero());
    scratch.rot.assign(nj, Eigen::Quaterniond::Identity());
    scratch.lrot.assign(nj, Eigen::Quaterniond::Identity());
  }
  auto v3 = [](const float* p) { return Eigen::Vector3d(p[0], p[1], p[2]); };
  auto q4 = [](const float* p) { return Eigen::Quaterniond(p[0], p[1], p[2], p[3]).normalized(); };
  // A neighbour's COM offset R c: the stored rotation as it is (unit to
  // float precision: not normalised, which would cost a square root).
  auto turned = [](const float* p, const Eigen::Vector3d& v) {
    return Eigen::Quaterniond(p[0], p[1], p[2], p[3])._transformVector(v);
  };
  // The COMs and their velocities as sequence_state makes them: central
  // differences over the frame's clip neighbours, one-sided at its ends,
  // zero for a clip of one frame.
  const ClipInfo& clip = tables.clips[tables.frame_row[g]];
  const double dt = clip.frame_time_s;
  const bool has_prev = g > clip.frame_start && dt > 0.0;
  const bool has_next = g + 1 < clip.frame_start + clip.frame_count && dt > 0.0;
  const double inv_dt = dt > 0.0 ? 1.0 / dt : 0.0;
  auto convert = [&](std::size_t j) {
    const std::size_t i = g * nj + j;
    const Eigen::Vector3d& com_local = tables.model.coms_local_m[j];
    scratch.pos[j] = v3(fa.pos + i * 3);
    scratch.rot[j] = q4(fa.rot + i * 4);
    scratch.lrot[j] = q4(fa.lrot + i * 4);
    const Eigen::Vector3d c = scratch.pos[j] + scratch.rot[j] * com_local;
    scratch.com[j] = c;
    scratch.angvel[j] = v3(fa.angvel + i * 3);
    Eigen::Vector3d v_lo = Eigen::Vector3d::Zero(), v_hi = Eigen::Vector3d::Zero();
    if (has_prev)
      v_lo = (c - (v3(fa.pos + (i - nj) * 3) + turned(fa.rot + (i - nj) * 4, com_local))) * inv_dt;
    if (has_next)
      v_hi = ((v3(fa.pos + (i + nj) * 3) + turned(fa.rot + (i + nj) * 4, com_local)) - c) * inv_dt;
    scratch.vel[j] = has_prev && has_next ? Eigen::Vector3d(0.5 * (v_lo + v_hi))
                     : has_prev           ? v_lo
                                          : v_hi;
  };
  auto local_translation = [&](std::size_t j) {
    const int p = tables.model.parents[j];
    scratch.ltrans[j] =
        p < 0 ? scratch.pos[j]
              : Eigen::Vector3d(scratch.rot[static_cast<std::size_t>(p)].conjugate() *
                                (scratch.pos[j] - scratch.pos[static_cast<std::size_t>(p)]));
  };
  if (need.empty()) {
    for (std::size_t j = 0; j < nj; ++j) convert(j);
    for (std::size_t j = 0; j < nj; ++j) local_translation(j);
  } else {
    for (int j : need) convert(static_cast<std::size_t>(j));
    for (int j : local) local_translation(static_cast<std::size_t>(j));
  }
  FrameRef r;
  r.state.joint_count = nj;
  r.state.joint_positions_m = scratch.pos.data();
  r.state.rotations = scratch.rot.data();
  r.state.coms_m = scratch.com.data();
  r.state.com_velocities_mps = scratch.vel.data();
  r.state.com_accelerations_mps2 = scratch.zero.data();
  r.state.angular_velocities_radps = scratch.angvel.data();
  r.state.angular_accelerations_radps2 = scratch.zero.data();
  r.local_translations_m = scratch.ltrans.data();
  r.local_rotations = scratch.lrot.data();
  return r;
}

// The scan values of skeleton frames [g0, g1) copied out of the tiles into
// one field-major view (scratch.gathered, stride g1 - g0). The scan
// kernel's value for a frame depends on its position in the scanned range
// (vector body or remainder), so a range is scanned whole, as one
// contiguous run, whatever tiles it touches: exact and brute, which scan
// the same ranges, see the same values. With `kinetic_only` only the rows
// the root scan reads (each segment's KE and KE_rot) are copied.
void gather_frames(const SkeletonTables& tables, std::size_t g0, std::size_t g1, bool kinetic_only,
                   Scratch& scratch) {
  const std::size_t n = g1 - g0;
  const std::size_t rows = tables.segments * HScanTable::kFields;
  scratch.gathered_values.resize(rows * n);
  scratch.gathered_roots.resize(3 * n);
  float* values = scratch.gathered_values.data();
  float* roots = scratch.gathered_roots.data();
  tables.for_each_tile_piece(
      g0, g1, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
        const float* t = tables.tile_data(row) + lane;
        const std::size_t stride = tables.tile_stride(row);
        for (std::size_t r = 0; r < rows; ++r) {
          const std::size_t field = r % HScanTable::kFields;
          if (kinetic_only && field != 3 && field != 8) continue;
          std::copy(t + r * stride, t + r * stride + count, values + r * n + offset);
        }
      });
  for (std::size_t a = 0; a < 3; ++a)
    std::copy(
        tables.root_positions.begin() + static_cast<std::ptrdiff_t>(a * tables.frame_count + g0),
        tables.root_positions.begin() + static_cast<std::ptrdiff_t>(a * tables.frame_count + g1),
        roots + a * n);
  scratch.gathered = {values, roots, n, n, tables.segments};
}

// h of a constrained frame (solved on r), its terms weighted per joint and
// the whole by the frame's weight. A joint the solution left where F has it
// (pq.keep_rates) contributes nothing: its completed state is F's but for
// the rounding of recomposing its pose, which is not counted.
double weighted_energy(const ResolvedFrame& q, const DynamicsModel& model, const PartialQuery& pq,
                       const FrameRef& r, double t, Scratch& scratch) {
  partial_approximate_energy(model, pq, r, t, scratch.state, &scratch.terms);
  double sum = 0.0;
  for (int jj : pq.affected_joints) {
    const auto j = static_cast<std::size_t>(jj);
    if (!pq.keep_rates.empty() && pq.keep_rates[j]) continue;
    const double w = q.joint_weights.empty() ? 1.0 : q.joint_weights[j];
    sum += w * (scratch.terms.segment_J[j] + scratch.terms.joint_J[j]);
  }
  return sum * q.weight;
}

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Whether database frame `r` (every joint) meets each named constraint of
// q within its verdict limit (ConstraintResidual::limit).
bool frame_meets(const ResolvedFrame& q, const DynamicsModel& model, const FrameRef& r) {
  for (const PoseConstraint& c : q.constraints) {
    if (c.name.empty()) continue;
    const bool metres = c.kind == PoseConstraintKind::effector;
    ConstraintResidual v;
    v.metres = metres;
    v.tolerance = metres ? c.tolerance : c.tolerance * 180.0 / std::numbers::pi;
    v.residual = constraint_residual(model.parents, model.root(), c, r.state.joint_positions_m,
                                     r.state.rotations);
    if (!v.met()) return false;
  }
  return true;
}

// The require_met pass: +inf on the evaluated frames that miss (frame_meets).
void mask_missed(const ResolvedFrame& q, const SkeletonData& skeleton, const Index& index,
                 std::size_t g0, std::size_t n, double* out, Scratch& scratch,
                 const std::uint8_t* skip) {
  for (std::size_t i = 0; i < n; ++i) {
    if ((skip != nullptr && skip[i]) || !(out[i] < kInfinity)) continue;
    if (!frame_meets(q, skeleton.tables.model, database_frame(skeleton, index, g0 + i, scratch)))
      out[i] = kInfinity;
  }
}

// h(Q -> F) for skeleton frames [g0, g1) into out, without the context energy.
void evaluate_h_alone(const ResolvedFrame& q, const SkeletonData& skeleton, const Index& index,
                      double t, std::size_t g0, std::size_t g1, double* out, Scratch& scratch,
                      const std::optional<GroundPose>& place, const std::uint8_t* skip,
                      const HScanView* tile) {
  const SkeletonTables& tables = skeleton.tables;
  const std::size_t n = g1 - g0;
  if (n == 0) return;
  if (q.kind == FrameKind::full || q.kind == FrameKind::root_only) {
    scratch.fbuf.resize(n);
    const HScanQuery* sq = &q.scan;
    const HScanRootQuery* rq = &q.root_scan;
    if (place && q.kind == FrameKind::full) {
      place_h_scan_query(q.scan, *place, scratch.shifted_scan);
      sq = &scratch.shifted_scan;
    } else if (place) {
      scratch.shifted_root = q.root_scan;
      move_given_root(*place, q, nullptr, &scratch.shifted_root);
      rq = &scratch.shifted_root;
    }
    // Lanes [lane, lane + count) of a tile into fbuf[offset ...] (a frame's
    // value does not depend on the lanes scanned with it).
    auto scan = [&](const HScanView& view, std::size_t lane, std::size_t count,
                    std::size_t offset) {
      if (q.kind == FrameKind::full)
        scan_approximate_energy(view, *sq, lane, lane + count, scratch.fbuf.data() + offset);
      else
        scan_root_translation_energy(view, *rq, lane, lane + count, scratch.fbuf.data() + offset);
    };
    if (tile != nullptr && !place) {
      scan(*tile, 0, n, 0);  // a whole block in world mode: its tile
    } else if (n == 1) {
      const ClipInfo& ci = tables.clips[tables.frame_row[g0]];
      const std::size_t local = g0 - ci.frame_start;
      const std::size_t lane = local % kBlock;
      scan(tables.tile(ci.block_start + local / kBlock, g0 - lane, lane + 1), lane, 1, 0);
    } else {
      gather_frames(tables, g0, g1, q.kind == FrameKind::root_only, scratch);
      scan(scratch.gathered, 0, n, 0);
    }
    for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(scratch.fbuf[i]) * q.weight;
    return;
  }
  const PartialQuery* pq = &q.partial;
  const PartialPoseSpec& spec = q.partial.spec;
  if (place && (q.given[0] || q.given[2] || spec.root_heading_rad)) {
    scratch.shifted_partial = q.partial;
    move_given_root(*place, q, &scratch.shifted_partial.spec, nullptr);
    pq = &scratch.shifted_partial;
  }
  if (!q.subtree.empty()) {  // joint rotations only: no root component to shift
    subtree_energy(q, tables, g0, g1, out, scratch, skip);
    if (q.weight != 1.0)
      for (std::size_t i = 0; i < n; ++i)
        if (skip == nullptr || !skip[i]) out[i] *= q.weight;
    if (q.require_met) mask_missed(q, skeleton, index, g0, n, out, scratch, skip);
    return;
  }
  const FrameArrays& fa = frame_arrays(index, skeleton);
  if (q.solve) {  // body-frame constraints: the given rotations solved on each F
    if (pq != &scratch.shifted_partial) {
      scratch.shifted_partial = q.partial;
      pq = &scratch.shifted_partial;
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (skip != nullptr && skip[i]) continue;
      const FrameRef r = frame_ref(tables, fa, g0 + i, scratch, q.need_joints, q.local_joints);
      solve_given(*q.pose, tables.model, r.state.joint_positions_m, r.state.rotations,
                  scratch.constraints, scratch.solved, scratch.shifted_partial.spec,
                  &scratch.shifted_partial.keep_rates);
      out[i] = weighted_energy(q, tables.model, *pq, r, t, scratch);
    }
    if (q.require_met) mask_missed(q, skeleton, index, g0, n, out, scratch, skip);
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (skip != nullptr && skip[i]) continue;
    const FrameRef r = frame_ref(tables, fa, g0 + i, scratch, q.need_joints, q.local_joints);
    out[i] = partial_approximate_energy(tables.model, *pq, r, t, scratch.state) * q.weight;
  }
  if (q.require_met) mask_missed(q, skeleton, index, g0, n, out, scratch, skip);
}

}  // namespace

// h(Q -> F) for skeleton frames [g0, g1) into out (frame_energy.hpp).
void evaluate_h(const ResolvedFrame& q, const SkeletonData& skeleton, const Index& index, double t,
                std::size_t g0, std::size_t g1, double* out, Scratch& scratch,
                const std::optional<GroundPose>& place, const std::uint8_t* skip,
                const HScanView* tile) {
  evaluate_h_alone(q, skeleton, index, t, g0, g1, out, scratch, place, skip, tile);
  // Context frames are whole frames, evaluated on every frame of the range.
  if (q.context != nullptr) add_context_energy(*q.context, skeleton, index, g0, g1, out, nullptr);
  // The query's style term: a constant per clip (docs/style.md).
  if (q.style_rows != nullptr)
    for (std::size_t g = g0; g < g1; ++g)
      if (std::isfinite(out[g - g0])) out[g - g0] += q.style_rows[skeleton.tables.frame_row[g]];
}

FrameRef database_frame(const SkeletonData& skeleton, const Index& index, std::size_t g,
                        Scratch& scratch) {
  return frame_ref(skeleton.tables, frame_arrays(index, skeleton), g, scratch, {}, {});
}

void set_needed_joints(ResolvedFrame& q, const DynamicsModel& model) {
  q.need_joints.clear();
  q.local_joints.clear();
  if (q.kind != FrameKind::partial || q.partial.moves_whole_body || q.solve) return;
  std::vector<std::uint8_t> need(model.joint_count(), 0);
  for (int j : q.partial.affected_joints) need[static_cast<std::size_t>(j)] = 1;
  for (int j : q.partial.subtree_joints) {
    const int p = model.parents[static_cast<std::size_t>(j)];
    if (p >= 0) need[static_cast<std::size_t>(p)] = 1;
  }
  for (std::size_t j = 0; j < need.size(); ++j)
    if (need[j]) q.need_joints.push_back(static_cast<int>(j));
  q.local_joints = q.partial.subtree_joints;
  if (q.need_joints.empty()) q.need_joints.push_back(model.root());  // never empty: empty means all
}

}  // namespace mocap::search_detail
