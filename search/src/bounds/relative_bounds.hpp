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
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "bounds/skeleton_tables.hpp"
#include "mocap/common/body/ground_pose.hpp"
#include "query/resolved_frame.hpp"

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

// Root-only query frames (root position components only; energy.hpp
// HScanRootQuery) in a relative placement. With d = the given components of
// (placed query root - F's root), K and K^rot F's kinetic energies summed
// over the segments and M the total mass,
//   h = M g |d_y| + sum_b [max(K_b, m_b |d|^2 / T^2 - K_b) + K_b^rot]
//     >= M g |d_y| + max(K, M |d|^2 / T^2 - K) + K^rot
// (the sum of maxima is at least the maximum of the sums); over frames with
// K in [K_lo, K_hi] and K^rot >= R_lo, max(K_lo, M |d|^2 / T^2 - K_hi) + R_lo.
//
// A root frame that also gives the heading (no joint rotations: the whole
// body of F turned by delta = heading - F's heading about the vertical
// through its root, then moved by d, every segment static) moves segment b
// by d_b = (R_y(delta) - I) p_b + d, with p_b = c_b - root. Summed exactly,
//   sum_b m_b |d_b|^2 = 2 (1 - cos delta) S + 2 d_xz . (R_y(delta) - I) P + M |d|^2
// with S = sum_b m_b |p_b,xz|^2 and P = sum_b m_b p_b,xz, and every segment
// turns by delta about +y, so sum_b 2 K^rot_u,b = delta^2 / T^2 J with
// J = sum_b (I_b, world)_yy, and delta^2 >= 2 (1 - cos delta) (delta the short
// way, |delta| <= pi). With dK >= max(K_A, 2 K_u - K_A) per segment:
//   h >= M g |d_y| + max(K, sum_b m_b |d_b|^2 / T^2 - K)
//        + max(K^rot, 2 (1 - cos delta) J / T^2 - K^rot).
// Without a turn (delta = 0) this is the bound above. A turn can move the
// segments less than the root's d (the cross term is negative), so the
// boxes of root positions (RootBlocks, the clip's root box) bound a turning
// frame through its height alone.
struct RootBoundQuery {
  double mass = 0.0, g = 0.0, inv_t2 = 0.0;
  std::array<bool, 3> given{false, false, false};
  Eigen::Vector3d root_body = Eigen::Vector3d::Zero();  // given components, body frame
  bool turns = false;                                   // the frame gives a heading
  double heading_body = 0.0;                            // that heading in the body frame (radians)
  // A turning frame with joint rotations: S, P_x, P_z, J over the segments
  // outside the given subtrees, 4 floats per skeleton frame; empty: every
  // segment (frame_turn_moments).
  std::vector<float> moments;
};
//
// A partial frame giving root position components or a heading, and joint
// rotations (a BVH frame with "only": ["root_position_xz", "RightArm"],
// say) moves the segments outside the given joints' subtrees as above, and
// makes the ones inside static (dK >= K_b, K_b^rot): the bounds above hold
// with M, S, P and J over the segments outside those subtrees, K and K^rot
// still summed over every segment, since each segment costs at least its
// own.
//
// For a frame root_bound_applies accepts.
RootBoundQuery make_root_bound_query(const ResolvedFrame& q, const SkeletonData& skeleton,
                                     double t);
// The frames these bounds serve: root-only frames; partial frames giving the
// root heading (turning frames), or root position components and joint
// rotations. Never frames with body-frame constraints or a segment mask.
bool root_bound_applies(const ResolvedFrame& q);

// Per skeleton frame, S, P_x, P_z and J of the turning bound above, from the
// scan table's floats (SkeletonCaches::turn_moments, 4 floats a frame);
// computed once per skeleton.
const std::vector<float>& frame_turn_moments(const SkeletonData& skeleton);
// The moments a turning frame's bound reads: its own (q.moments) or the
// skeleton's (frame_turn_moments); 4 floats per skeleton frame.
const float* turn_moments_of(const RootBoundQuery& q, const SkeletonData& skeleton);

// The turning bound for skeleton frame g (root r, cos and sin of its heading
// cs_g, kinetic energies k and krot) and the query frame placed with its
// root at `p` (world; components not given ignored) and the cos and sin of
// its heading (world) cq, sq. No trigonometry: cos and sin of delta by the
// angle-difference formulas, and delta^2 >= 2 (1 - cos delta).
inline double turn_root_bound(const RootBoundQuery& q, const float* moments, double k, double krot,
                              const Eigen::Vector3d& r, const double* cs_g,
                              const Eigen::Vector3d& p, double cq, double sq) {
  const double c = cq * cs_g[0] + sq * cs_g[1], s = sq * cs_g[0] - cq * cs_g[1];
  const double dx = q.given[0] ? p.x() - r.x() : 0.0, dy = q.given[1] ? p.y() - r.y() : 0.0,
               dz = q.given[2] ? p.z() - r.z() : 0.0;
  const double px = static_cast<double>(moments[1]), pz = static_cast<double>(moments[2]);
  const double cross = dx * ((c - 1.0) * px + s * pz) + dz * (-s * px + (c - 1.0) * pz);
  const double one_minus_c = std::max(0.0, 1.0 - c);
  const double sum = std::max(0.0, 2.0 * one_minus_c * static_cast<double>(moments[0]) +
                                       2.0 * cross + q.mass * (dx * dx + dy * dy + dz * dz));
  const double moved = sum * q.inv_t2 - k;
  const double turned = 2.0 * one_minus_c * static_cast<double>(moments[3]) * q.inv_t2 - krot;
  return (q.given[1] ? q.mass * q.g * std::abs(dy) : 0.0) + (moved > k ? moved : k) +
         (turned > krot ? turned : krot);
}

// The bound for root distances (dx, dy, dz) (components not given ignored).
inline double root_bound(const RootBoundQuery& q, double k_lo, double k_hi, double krot_lo,
                         double dx, double dy, double dz) {
  const double d2 =
      (q.given[0] ? dx * dx : 0.0) + (q.given[1] ? dy * dy : 0.0) + (q.given[2] ? dz * dz : 0.0);
  const double moved = q.mass * d2 * q.inv_t2 - k_hi;
  return (q.given[1] ? q.mass * q.g * std::abs(dy) : 0.0) + (moved > k_lo ? moved : k_lo) + krot_lo;
}

// The per-frame bound of any frame root_bound_applies accepts, at a skeleton
// frame with root r and kinetic energies k, krot: turn_root_bound for a
// turning frame (its moments for that frame, cos and sin of the frame's
// heading cs_g and of the placed heading cq, sq), root_bound with the root
// distances p - r otherwise (moments, cs_g, cq and sq unused).
inline double frame_root_bound(const RootBoundQuery& q, const float* moments, double k, double krot,
                               const Eigen::Vector3d& r, const double* cs_g,
                               const Eigen::Vector3d& p, double cq, double sq) {
  if (q.turns) return turn_root_bound(q, moments, k, krot, r, cs_g, p, cq, sq);
  const Eigen::Vector3d d = p - r;
  return root_bound(q, k, k, krot, d.x(), d.y(), d.z());
}

// Each skeleton frame's kinetic energies summed over the segments
// (SkeletonCaches::kinetic, kinetic_rot) and each clip's root box
// (clip_root_boxes), computed once per skeleton.
void ensure_frame_kinetic(const SkeletonData& skeleton);

// Boxes of kBlock consecutive frames of a clip (block j = clip frames
// [j kBlock, (j + 1) kBlock)): root position ranges, K range, least K^rot.
struct RootBlocks {
  static constexpr std::size_t kBlock = 16;
  std::vector<double> x0, x1, y0, y1, z0, z1, k0, k1, r0;
  // Blocks of `block` frames (kBlock in the scans; n for one box of the clip).
  void build(const SkeletonData& skeleton, std::size_t g0, std::size_t n,
             std::size_t block = kBlock);
  // The bound over block j for placed query roots anywhere in the box [lo, hi].
  double bound_box(const RootBoundQuery& q, std::size_t j, const Eigen::Vector3d& lo,
                   const Eigen::Vector3d& hi) const {
    auto gap = [](double a0, double a1, double b0, double b1) {
      return a1 < b0 ? b0 - a1 : (b1 < a0 ? a0 - b1 : 0.0);
    };
    return root_bound(q, k0[j], k1[j], r0[j], gap(lo.x(), hi.x(), x0[j], x1[j]),
                      gap(lo.y(), hi.y(), y0[j], y1[j]), gap(lo.z(), hi.z(), z0[j], z1[j]));
  }
  // The bound over block j for a placed query root p.
  double bound(const RootBoundQuery& q, std::size_t j, const Eigen::Vector3d& p) const {
    auto gap = [](double v, double lo, double hi) {
      return v < lo ? lo - v : (v > hi ? v - hi : 0.0);
    };
    return root_bound(q, k0[j], k1[j], r0[j], gap(p.x(), x0[j], x1[j]), gap(p.y(), y0[j], y1[j]),
                      gap(p.z(), z0[j], z1[j]));
  }
};

}  // namespace mocap::search_detail
