// Lower bounds of a relative pair's second term (relative_bounds.hpp).
#include "bounds/relative_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mocap::search_detail {

RelativeBoundQuery make_relative_bound_query(const ResolvedFrame& q, const SkeletonTables& tables,
                                             double t) {
  RelativeBoundQuery out;
  const DynamicsModel& model = tables.model;
  out.g = model.params.gravity_mps2;
  out.inv_t2 = 1.0 / (t * t);
  for (std::size_t b = 0; b < model.segments.size(); ++b) {
    const auto j = static_cast<std::size_t>(model.segments[b]);
    using C = HScanConstant;
    const float* c = q.scan.constants.data() + b * HScanQuery::kConstants;
    const double m = model.masses_kg[j];
    out.mass.push_back(m);
    out.y.push_back(c[C::com_y]);
    out.ke.push_back(c[C::kinetic]);
    out.ke_rot.push_back(c[C::kinetic_rot]);
    out.total_mass += m;
    out.ke_total += static_cast<double>(c[C::kinetic]);
    out.com_body += m * Eigen::Vector3d(c[C::com_x], c[C::com_y], c[C::com_z]).cast<double>();
  }
  if (out.total_mass > 0.0) out.com_body /= out.total_mass;
  return out;
}

double clip_relative_bound(const RelativeBoundQuery& q, const SkeletonTables& tables,
                           std::size_t row) {
  const std::size_t segments = q.mass.size();
  const std::size_t tw = kBoundFields * segments * kLanes;
  const float* tile = tables.clip_soa.data() + (row / kLanes) * tw + row % kLanes;
  auto value = [&](std::size_t field, std::size_t b) {
    return static_cast<double>(tile[(field * segments + b) * kLanes]);
  };
  auto gap = [](double v, double lo, double hi) { return std::max({0.0, lo - v, v - hi}); };
  double sum = 0.0;
  for (std::size_t b = 0; b < segments; ++b) {
    const double m = q.mass[b];
    const double dy = gap(q.y[b], value(1, b), value(4, b));
    const double dk = gap(q.ke[b], value(6, b), value(7, b));
    sum += m * q.g * dy + gap(q.ke_rot[b], value(8, b), value(9, b)) +
           std::max(dk, m * q.inv_t2 * dy * dy - value(7, b) - q.ke[b]);
  }
  return sum;
}

void relative_bound_frames(const RelativeBoundQuery& q, const SkeletonTables& tables,
                           std::size_t g0, std::size_t n, RelativeBoundFrames& out) {
  for (auto* v : {&out.fixed, &out.height, &out.ke, &out.cx, &out.cy, &out.cz}) v->assign(n, 0.0);
  // Tile by tile, all kBlock lanes at once (fixed-length loops; lanes
  // outside [lane, lane + count) are computed and dropped); per frame the
  // segments are summed in order, as in one pass over the clip.
  tables.for_each_tile_piece(
      g0, g0 + n, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
        double fixed[kBlock] = {}, height[kBlock] = {}, ke_sum[kBlock], cx[kBlock] = {},
               cy[kBlock] = {}, cz[kBlock] = {};
        for (std::size_t l = 0; l < kBlock; ++l) ke_sum[l] = q.ke_total;
        // Lanes past a short tile's stride read the next rows (finite
        // values, dropped below; the tiles end with a spare line).
        const float* tile = tables.tile_data(row);
        const std::size_t stride = tables.tile_stride(row);
        for (std::size_t b = 0; b < q.mass.size(); ++b) {
          const float* base = tile + b * HScanTable::kFields * stride;
          const float* x = base + HScanField::com_x * stride;
          const float* y = base + HScanField::com_y * stride;
          const float* z = base + HScanField::com_z * stride;
          const float* ke = base + HScanField::kinetic * stride;
          const float* kr = base + HScanField::kinetic_rot * stride;
          const double m = q.mass[b], mg = m * q.g, mh = m * q.inv_t2;
          const double yq = q.y[b], kq = q.ke[b], rq = q.ke_rot[b];
          for (std::size_t l = 0; l < kBlock; ++l) {
            const double dy = static_cast<double>(y[l]) - yq;
            const double k = ke[l];
            fixed[l] += mg * std::abs(dy) + std::abs(static_cast<double>(kr[l]) - rq);
            const double d = std::abs(k - kq), v = mh * dy * dy - k - kq;
            height[l] += d > v ? d : v;
            ke_sum[l] += k;
            cx[l] += m * static_cast<double>(x[l]);
            cy[l] += m * static_cast<double>(y[l]);
            cz[l] += m * static_cast<double>(z[l]);
          }
        }
        for (std::size_t i = 0; i < count; ++i) {
          out.fixed[offset + i] = fixed[lane + i];
          out.height[offset + i] = height[lane + i];
          out.ke[offset + i] = ke_sum[lane + i];
          out.cx[offset + i] = cx[lane + i];
          out.cy[offset + i] = cy[lane + i];
          out.cz[offset + i] = cz[lane + i];
        }
      });
  if (q.total_mass > 0.0)
    for (std::size_t f = 0; f < n; ++f) {
      out.cx[f] /= q.total_mass;
      out.cy[f] /= q.total_mass;
      out.cz[f] /= q.total_mass;
    }
}

namespace {

// Adds segment b's terms of S, P_x, P_z and J (relative_bounds.hpp) to each
// skeleton frame's 4 values in `acc`, from the scan table's floats.
void add_turn_moments(const SkeletonTables& tables, std::size_t b, std::vector<double>& acc) {
  const DynamicsModel& model = tables.model;
  const auto j = static_cast<std::size_t>(model.segments[b]);
  const double m = model.masses_kg[j];
  const Eigen::Vector3d d = model.principal_moments_kgm2[j];
  tables.for_each_tile_piece(
      0, tables.frame_count,
      [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
        const std::size_t stride = tables.tile_stride(row);
        const float* t = tables.tile_data(row) + b * HScanTable::kFields * stride + lane;
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t g = offset + i;
          const double px = t[HScanField::com_x * stride + i] - tables.root_position(0, g);
          const double pz = t[HScanField::com_z * stride + i] - tables.root_position(2, g);
          // q = R P, world-from-principal: (I_world)_yy = sum_k D_k (q e_k)_y^2.
          const double w = t[HScanField::orient_w * stride + i],
                       x = t[HScanField::orient_x * stride + i],
                       y = t[HScanField::orient_y * stride + i],
                       z = t[HScanField::orient_z * stride + i];
          const double n2 = w * w + x * x + y * y + z * z;
          const double e0 = 2.0 * (x * y + w * z) / n2, e1 = 1.0 - 2.0 * (x * x + z * z) / n2,
                       e2 = 2.0 * (y * z - w * x) / n2;
          double* a = acc.data() + 4 * g;
          a[0] += m * (px * px + pz * pz);
          a[1] += m * px;
          a[2] += m * pz;
          a[3] += d.x() * e0 * e0 + d.y() * e1 * e1 + d.z() * e2 * e2;
        }
      });
}

}  // namespace

RootBoundQuery make_root_bound_query(const ResolvedFrame& q, const SkeletonData& skeleton,
                                     double t) {
  RootBoundQuery out;
  const SkeletonTables& tables = skeleton.tables;
  const DynamicsModel& model = tables.model;
  out.g = model.params.gravity_mps2;
  out.inv_t2 = 1.0 / (t * t);
  // The mass outside the given joints' subtrees (all of it for root-only
  // frames and frames without joint rotations).
  const std::vector<std::uint8_t>& inside = q.partial.in_subtree;
  auto outside = [&](std::size_t b) {
    const auto j = static_cast<std::size_t>(model.segments[b]);
    return q.kind != FrameKind::partial || j >= inside.size() || !inside[j];
  };
  bool all = true;
  for (std::size_t b = 0; b < model.segments.size(); ++b) {
    if (outside(b))
      out.mass += model.masses_kg[static_cast<std::size_t>(model.segments[b])];
    else
      all = false;
  }
  out.given = q.given;
  for (std::size_t a = 0; a < 3; ++a)
    if (q.given[a])
      out.root_body[static_cast<Eigen::Index>(a)] = q.root_m[static_cast<Eigen::Index>(a)];
  if (q.kind == FrameKind::partial && q.partial.spec.root_heading_rad) {
    out.turns = true;
    out.heading_body = *q.partial.spec.root_heading_rad;
    if (!all) {  // a heading and joint rotations: the moments of the segments outside
      std::vector<double> acc(4 * tables.frame_count, 0.0);
      for (std::size_t b = 0; b < model.segments.size(); ++b)
        if (outside(b)) add_turn_moments(tables, b, acc);
      out.moments.assign(acc.begin(), acc.end());
    }
  }
  return out;
}

bool root_bound_applies(const ResolvedFrame& q) {
  if (q.kind == FrameKind::root_only) return true;
  if (q.kind != FrameKind::partial || q.solve || !q.compared.empty()) return false;
  const PartialPoseSpec& spec = q.partial.spec;
  return spec.root_heading_rad ||
         (!spec.joint_rotations.empty() && (q.given[0] || q.given[1] || q.given[2]));
}

const std::vector<float>& frame_turn_moments(const SkeletonData& skeleton) {
  SkeletonCaches& caches = skeleton.caches;
  std::call_once(caches.turn_once, [&] {
    const SkeletonTables& tables = skeleton.tables;
    std::vector<double> acc(4 * tables.frame_count, 0.0);
    for (std::size_t b = 0; b < tables.segments; ++b) add_turn_moments(tables, b, acc);
    caches.turn_moments.assign(acc.begin(), acc.end());
  });
  return caches.turn_moments;
}

const float* turn_moments_of(const RootBoundQuery& q, const SkeletonData& skeleton) {
  return q.moments.empty() ? frame_turn_moments(skeleton).data() : q.moments.data();
}

void ensure_frame_kinetic(const SkeletonData& skeleton) {
  SkeletonCaches& caches = skeleton.caches;
  std::call_once(caches.kinetic_once, [&] {
    const SkeletonTables& tables = skeleton.tables;
    const std::size_t n = tables.frame_count;
    caches.kinetic.assign(n, 0.0f);
    caches.kinetic_rot.assign(n, 0.0f);
    for (std::size_t b = 0; b < tables.segments; ++b)
      tables.for_each_tile_piece(
          0, n, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
            const std::size_t stride = tables.tile_stride(row);
            const float* t = tables.tile_data(row) + b * HScanTable::kFields * stride + lane;
            for (std::size_t i = 0; i < count; ++i) {
              caches.kinetic[offset + i] += t[HScanField::kinetic * stride + i];
              caches.kinetic_rot[offset + i] += t[HScanField::kinetic_rot * stride + i];
            }
          });
    RootBlocks whole;
    for (const ClipInfo& ci : skeleton.tables.clips) {
      whole.build(skeleton, ci.frame_start, ci.frame_count, ci.frame_count);
      caches.clip_root_boxes.push_back({whole.x0[0], whole.x1[0], whole.y0[0], whole.y1[0],
                                        whole.z0[0], whole.z1[0], whole.k0[0], whole.k1[0],
                                        whole.r0[0]});
    }
  });
}

void RootBlocks::build(const SkeletonData& skeleton, std::size_t g0, std::size_t n,
                       std::size_t block) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::size_t blocks = n == 0 ? 0 : (n + block - 1) / block;
  for (auto* v : {&x0, &y0, &z0, &k0, &r0}) v->assign(blocks, kInf);
  for (auto* v : {&x1, &y1, &z1, &k1}) v->assign(blocks, -kInf);
  const SkeletonTables& tables = skeleton.tables;
  const float* k = skeleton.caches.kinetic.data() + g0;
  const float* r = skeleton.caches.kinetic_rot.data() + g0;
  const float* px = tables.root_positions.data() + g0;
  const float* py = px + tables.frame_count;
  const float* pz = py + tables.frame_count;
  for (std::size_t f = 0; f < n; ++f) {
    const std::size_t j = f / block;
    x0[j] = std::min(x0[j], static_cast<double>(px[f]));
    x1[j] = std::max(x1[j], static_cast<double>(px[f]));
    y0[j] = std::min(y0[j], static_cast<double>(py[f]));
    y1[j] = std::max(y1[j], static_cast<double>(py[f]));
    z0[j] = std::min(z0[j], static_cast<double>(pz[f]));
    z1[j] = std::max(z1[j], static_cast<double>(pz[f]));
    k0[j] = std::min(k0[j], static_cast<double>(k[f]));
    k1[j] = std::max(k1[j], static_cast<double>(k[f]));
    r0[j] = std::min(r0[j], static_cast<double>(r[f]));
  }
}

}  // namespace mocap::search_detail
