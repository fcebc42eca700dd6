// The context energy (context_energy.hpp; docs/queries.md "Context frames").
#include "scan/context_energy.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "mocap/common/dynamics/h_scan_layout.hpp"
#include "query/relative_frames.hpp"

namespace mocap::search_detail {
namespace {

// Segment b's COM at skeleton frame g, from the h scan tiles.
Eigen::Vector3d scan_com(const SkeletonTables& tables, std::size_t b, std::size_t g) {
  return {static_cast<double>(tables.scan_value(b, HScanField::com_x, g)),
          static_cast<double>(tables.scan_value(b, HScanField::com_y, g)),
          static_cast<double>(tables.scan_value(b, HScanField::com_z, g))};
}

}  // namespace

double context_energy(const FrameContext& c, const SkeletonData& skeleton, const Index& index,
                      std::size_t g) {
  const SkeletonTables& tables = skeleton.tables;
  const ClipInfo& ci = tables.clips[tables.frame_row[g]];
  const std::size_t segments = tables.model.segments.size();
  if (c.steps == 0 || segments == 0) return 0.0;
  const double dt = index.clips()[ci.clip].frame_time_s;
  const double psi = frame_headings(skeleton)[g];
  const double cs = std::cos(psi), sn = std::sin(psi);
  const auto f = static_cast<long long>(g - ci.frame_start);
  const auto last = static_cast<long long>(ci.frame_count) - 1;
  double sum = 0.0;
  for (std::size_t j = 0; j < c.steps; ++j) {
    const auto o = std::llround(static_cast<double>(j) * c.frame_time_s / dt);
    long long lo = c.before ? f - o - 1 : f + o;
    lo = std::clamp(lo, 0LL, std::max(0LL, last - 1));
    const long long hi = std::min(lo + 1, last);
    const std::size_t g_lo = ci.frame_start + static_cast<std::size_t>(lo);
    const std::size_t g_hi = ci.frame_start + static_cast<std::size_t>(hi);
    for (std::size_t b = 0; b < segments; ++b) {
      const double m = c.masses_kg[b];
      if (m == 0.0) continue;
      const Eigen::Vector3d v = (scan_com(tables, b, g_hi) - scan_com(tables, b, g_lo)) / dt;
      // R_y(-psi) v: the velocity in F's body frame (heading_rad's convention).
      const Eigen::Vector3d body(cs * v.x() - sn * v.z(), v.y(), sn * v.x() + cs * v.z());
      sum += 0.5 * m * (c.rows[j * segments + b] - body).squaredNorm();
    }
  }
  return sum / static_cast<double>(c.steps);
}

void add_context_energy(const FrameContext& c, const SkeletonData& skeleton, const Index& index,
                        std::size_t g0, std::size_t g1, double* out, const std::uint8_t* skip) {
  for (std::size_t g = g0; g < g1; ++g) {
    const std::size_t i = g - g0;
    if ((skip != nullptr && skip[i]) || !std::isfinite(out[i])) continue;
    out[i] += c.weight * context_energy(c, skeleton, index, g);
  }
}

}  // namespace mocap::search_detail
