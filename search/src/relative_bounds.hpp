#pragma once
// Internal to mocap_search: lower bounds of either term of a relative pair,
// a(s) = h(F^s -> Q^h placed at F^s) and b(s, e) = h(F^e -> Q^h+1 placed at
// F^s), for a full query frame (docs/search.md "Relative placements"). With
// A = the database frame, B = the placed query frame and the per-segment
// terms of h (energy.hpp):
//   h >= sum_b m_b g |dy_b|                                    (gravity; heights do not turn)
//      + sum_b |K_B^rot - K_A^rot|                             (rotational dK >= |dK|)
//      + max( sum_b max(|K_B - K_A|, m_b dy_b^2 / T^2 - K_A - K_B),
//             M |com(B) - com(A)|^2 / T^2 - sum_b (K_A + K_B) )
// (dK(K_A, K_u, K_B) >= max(|K_B - K_A|, 2 K_u - K_A - K_B), 2 K_u >= m dy^2 / T^2,
// and sum_b m_b |dc_b|^2 >= M |dcom|^2 for the mass-weighted mean COM). Only
// the last term depends on where the query is placed (on s), through where
// its mean COM lands: the rest is a per-frame value of the database frame.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mocap/common/ground_pose.hpp"
#include "resolve.hpp"
#include "skeleton_tables.hpp"

namespace mocap::search_detail {

// What the bounds need of a full body-frame query frame (per segment: mass,
// COM height, kinetic energies), in double.
struct RelativeBoundQuery {
  std::vector<double> mass, y, ke, ke_rot;
  double total_mass = 0.0, ke_total = 0.0, g = 0.0, inv_t2 = 0.0;
  Eigen::Vector3d com_body = Eigen::Vector3d::Zero();  // mass-weighted mean COM, body frame
};
RelativeBoundQuery make_relative_bound_query(const ResolvedFrame& q, const SkeletonTables& tables,
                                             double t);

// The s-independent part of the bound over every frame of clip row `row`,
// from its box (SkeletonTables::clip_soa: the ranges of the segments' COM
// height and kinetic energies over the clip's frames).
double clip_relative_bound(const RelativeBoundQuery& q, const SkeletonTables& tables,
                           std::size_t row);

// Per frame of a clip (index f = clip frame), from the scan table's floats.
struct RelativeBoundFrames {
  std::vector<double> fixed;       // gravity + rotational terms
  std::vector<double> height;      // the first alternative of the max
  std::vector<double> ke;          // sum_b (K_A + K_B)
  std::vector<double> cx, cy, cz;  // F's mass-weighted mean COM, world (m)
  // The least s-independent bound fixed + height over each frame (for s skipping).
  double lower(std::size_t f) const { return fixed[f] + height[f]; }
};
void relative_bound_frames(const RelativeBoundQuery& q, const SkeletonTables& tables,
                           std::size_t g0, std::size_t n, RelativeBoundFrames& out);

// The bound for frame f of the clip with the query's mean COM placed at `com` (world).
inline double relative_bound(const RelativeBoundQuery& q, const RelativeBoundFrames& fr,
                             std::size_t f, const Eigen::Vector3d& com) {
  const double dx = fr.cx[f] - com.x(), dy = fr.cy[f] - com.y(), dz = fr.cz[f] - com.z();
  const double moved = q.total_mass * (dx * dx + dy * dy + dz * dz) * q.inv_t2 - fr.ke[f];
  return fr.fixed[f] + (moved > fr.height[f] ? moved : fr.height[f]);
}

}  // namespace mocap::search_detail
