// Lower bounds of a relative pair's second term (relative_bounds.hpp).
#include "relative_bounds.hpp"

#include <algorithm>
#include <cmath>

namespace mocap::search_detail {

RelativeBoundQuery make_relative_bound_query(const ResolvedFrame& q, const SkeletonTables& tables,
                                             double t) {
  RelativeBoundQuery out;
  const DynamicsModel& model = tables.model;
  out.g = model.params.gravity_mps2;
  out.inv_t2 = 1.0 / (t * t);
  for (std::size_t b = 0; b < model.segments.size(); ++b) {
    const auto j = static_cast<std::size_t>(model.segments[b]);
    const float* c = q.scan.constants.data() + b * HScanQuery::kConstants;
    const double m = model.masses_kg[j];
    out.mass.push_back(m);
    out.y.push_back(c[1]);
    out.ke.push_back(c[3]);
    out.ke_rot.push_back(c[10]);
    out.total_mass += m;
    out.ke_total += static_cast<double>(c[3]);
    out.com_body += m * Eigen::Vector3d(c[0], c[1], c[2]).cast<double>();
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
  for (std::size_t f = 0; f < n; ++f) out.ke[f] = q.ke_total;
  const HScanTable& table = tables.table;
  for (std::size_t b = 0; b < q.mass.size(); ++b) {
    const float* x = table.field(b, 0) + g0;
    const float* y = table.field(b, 1) + g0;
    const float* z = table.field(b, 2) + g0;
    const float* ke = table.field(b, 3) + g0;
    const float* kr = table.field(b, 8) + g0;
    const double m = q.mass[b], mg = m * q.g, mh = m * q.inv_t2;
    const double yq = q.y[b], kq = q.ke[b], rq = q.ke_rot[b];
    for (std::size_t f = 0; f < n; ++f) {
      const double dy = static_cast<double>(y[f]) - yq;
      const double k = ke[f];
      out.fixed[f] += mg * std::abs(dy) + std::abs(static_cast<double>(kr[f]) - rq);
      const double d = std::abs(k - kq), v = mh * dy * dy - k - kq;
      out.height[f] += d > v ? d : v;
      out.ke[f] += k;
      out.cx[f] += m * static_cast<double>(x[f]);
      out.cy[f] += m * static_cast<double>(y[f]);
      out.cz[f] += m * static_cast<double>(z[f]);
    }
  }
  if (q.total_mass > 0.0)
    for (std::size_t f = 0; f < n; ++f) {
      out.cx[f] /= q.total_mass;
      out.cy[f] /= q.total_mass;
      out.cz[f] /= q.total_mass;
    }
}

}  // namespace mocap::search_detail
