#pragma once
// Internal to mocap_search: lower bounds of h(Q -> F) over sets of database
// frames from the bound tables (bound_tables.hpp): 16-frame block boxes,
// whole-body and chain sketches, clip and group tiles (docs/search.md proves
// each). A query frame is first put in its box-bound form (BoundQuery).
// Bounds are computed in float from the same float values as the scan; a
// caller compares safe(bound) with scores, whose slack absorbs the roundings.
// The per-block functions are inline here: the clip scans call them per block.
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bounds/skeleton_tables.hpp"
#include "mocap/common/util/half.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// A query frame prepared for box bounds (full and root-only frames; other
// kinds have bound 0 here and per-frame bounds instead).
struct BoundQuery {
  FrameKind kind = FrameKind::partial;
  std::size_t s = 0;
  // full: per segment COM, KE_A, m g, m / (2 T^2), KE_A^rot (the scan constants).
  std::vector<float> ax, ay, az, ka, mg, mh, kar;
  // root_only: position, given axes, M g, per segment m / T^2.
  std::array<float, 3> p{0.0f, 0.0f, 0.0f};
  std::array<bool, 3> given{false, false, false};
  float total_mg = 0.0f;
  std::vector<float> m_inv_t2;
  // full: the whole-body sketch constants (sketch_term): mean COM x y z,
  // sum KE_A, sum KE_A^rot, M g, M / T^2.
  std::array<float, kSketchConstants> sketch{};
  // full: the same per chain, [chain][kSketchConstants].
  std::vector<float> chain_sketch;
};

// The box-bound form of query frame q on a skeleton (partial frames: kind
// only; their bounds are per frame, partial_bounds.hpp).
BoundQuery make_bound_query(const ResolvedFrame& q, const SkeletonTables& tables);

// Lower bound of the scanned h(Q -> F) over every frame F of a block or clip
// (`row`: kBoundFields x S bounds, `root`: root box); docs/search.md proves it. Computed in float
// from the same float values and constants as the scan; the caller's slack (safe()) absorbs the
// roundings.
inline float box_bound(const BoundQuery& q, const float* __restrict row,
                       const float* __restrict root) {
  if (q.kind == FrameKind::full) {
    const std::size_t n = q.s;
    const float *lx = row, *ly = row + n, *lz = row + 2 * n, *hx = row + 3 * n, *hy = row + 4 * n,
                *hz = row + 5 * n;
    const float *klo = row + 6 * n, *khi = row + 7 * n, *rlo = row + 8 * n, *rhi = row + 9 * n;
    const float* __restrict qx = q.ax.data(), * __restrict qy = q.ay.data(), * __restrict qz = q.az.data();
    const float* __restrict qka = q.ka.data(), * __restrict qkr = q.kar.data(), * __restrict qmg = q.mg.data(), * __restrict qmh = q.mh.data();
#if defined(__SSE__)
    // Per segment terms, 4 at a time (SSE; n is a multiple of 8).
    const __m128 zero = _mm_setzero_ps();
    __m128 acc = zero;
    for (std::size_t s = 0; s < n; s += 4) {
      const __m128 ax = _mm_loadu_ps(qx + s), ay = _mm_loadu_ps(qy + s), az = _mm_loadu_ps(qz + s);
      const __m128 ka = _mm_loadu_ps(qka + s), kar = _mm_loadu_ps(qkr + s);
      const __m128 dx = _mm_max_ps(
          _mm_max_ps(_mm_sub_ps(_mm_loadu_ps(lx + s), ax), _mm_sub_ps(ax, _mm_loadu_ps(hx + s))),
          zero);
      const __m128 dy = _mm_max_ps(
          _mm_max_ps(_mm_sub_ps(_mm_loadu_ps(ly + s), ay), _mm_sub_ps(ay, _mm_loadu_ps(hy + s))),
          zero);
      const __m128 dz = _mm_max_ps(
          _mm_max_ps(_mm_sub_ps(_mm_loadu_ps(lz + s), az), _mm_sub_ps(az, _mm_loadu_ps(hz + s))),
          zero);
      const __m128 ku = _mm_mul_ps(
          _mm_loadu_ps(qmh + s),
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz)));
      // min over K_B in [klo, khi] of max(|K_B - K_A|, 2 K_u - K_A - K_B): convex in K_B,
      // minimal at max(K_u, K_A) clamped into the interval.
      const __m128 x =
          _mm_min_ps(_mm_max_ps(_mm_max_ps(ku, ka), _mm_loadu_ps(klo + s)), _mm_loadu_ps(khi + s));
      const __m128 phi = _mm_max_ps(_mm_max_ps(_mm_sub_ps(x, ka), _mm_sub_ps(ka, x)),
                                    _mm_sub_ps(_mm_sub_ps(_mm_add_ps(ku, ku), ka), x));
      // Rotation: K_w >= 0, so the term is at least the distance of K_A^rot to [rlo, rhi].
      const __m128 rot = _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_loadu_ps(rlo + s), kar),
                                               _mm_sub_ps(kar, _mm_loadu_ps(rhi + s))),
                                    zero);
      acc =
          _mm_add_ps(acc, _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_loadu_ps(qmg + s), dy), phi), rot));
    }
    alignas(16) float lane[4];
    _mm_store_ps(lane, acc);
    const float total = (lane[0] + lane[1]) + (lane[2] + lane[3]);
#else
    // The same arithmetic, one segment at a time, summed in the same lane order.
    float lane[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (std::size_t s = 0; s < n; ++s) {
      const float ax = qx[s], ay = qy[s], az = qz[s], ka = qka[s], kar = qkr[s];
      const float dx = std::max(std::max(lx[s] - ax, ax - hx[s]), 0.0f);
      const float dy = std::max(std::max(ly[s] - ay, ay - hy[s]), 0.0f);
      const float dz = std::max(std::max(lz[s] - az, az - hz[s]), 0.0f);
      const float ku = qmh[s] * ((dx * dx + dy * dy) + dz * dz);
      const float x = std::min(std::max(std::max(ku, ka), klo[s]), khi[s]);
      const float phi = std::max(std::max(x - ka, ka - x), ((ku + ku) - ka) - x);
      const float rot = std::max(std::max(rlo[s] - kar, kar - rhi[s]), 0.0f);
      lane[s % 4] += (qmg[s] * dy + phi) + rot;
    }
    const float total = (lane[0] + lane[1]) + (lane[2] + lane[3]);
#endif
    return total;
  }
  if (q.kind == FrameKind::root_only) {
    // Q_F is F shifted by delta (given axes), |delta_a| >= distance of p_a to the root box.
    float d2 = 0.0f, dy = 0.0f;
    for (std::size_t a = 0; a < 3; ++a) {
      if (!q.given[a]) continue;
      const float d = std::max(std::max(root[a] - q.p[a], q.p[a] - root[a + 3]), 0.0f);
      d2 += d * d;
      if (a == 1) dy = d;
    }
    const std::size_t n = q.s;
    const float *klo = row + 6 * n, *khi = row + 7 * n, *rlo = row + 8 * n;
    float acc = q.total_mg * dy;
    for (std::size_t s = 0; s < n; ++s) {
      // min over K_B in [klo, khi] of max(K_B, 2 K_u - K_B) (scan: 2 K_u = m |delta|^2 / T^2).
      const float c = q.m_inv_t2[s] * d2;
      const float x = std::min(std::max(0.5f * c, klo[s]), khi[s]);
      acc += std::max(x, c - x) + rlo[s];
    }
    return acc;
  }
  return 0.0f;
}

// Lower bound of the scanned h(Q -> F) for a full query frame from F's
// whole-body sketch (x, y, z, kb, rb; SkeletonTables::sketch) and the query's
// constants k (BoundQuery::sketch); docs/search.md "Whole-body sketches"
// proves it. Float, like box_bound; the caller's slack absorbs the roundings.
inline float sketch_term(const float* k, float x, float y, float z, float kb, float rb) {
  const float dx = x - k[0], dy = y - k[1], dz = z - k[2];
  const float trans =
      std::max(std::fabs(kb - k[3]), k[6] * ((dx * dx + dy * dy) + dz * dz) - k[3] - kb);
  return (k[5] * std::fabs(dy) + trans) + std::fabs(rb - k[4]);
}

// box_bound of block `row` (its half-float row, SkeletonTables::block_box).
inline float block_box_bound(const BoundQuery& q, const SkeletonTables& tables, std::size_t row) {
  if (q.kind == FrameKind::partial) return 0.0f;  // as box_bound
  const std::size_t w = kBoundFields * tables.padded;
  constexpr std::size_t kStack = kBoundFields * 128;  // up to 128 segments on the stack
  std::array<float, kStack> buf;                      // NOLINT: written before read
  std::vector<float> heap;
  float* out = buf.data();
  if (w > kStack) {
    heap.resize(w);
    out = heap.data();
  }
  halves_to_floats(tables.block_box.data() + row * w, w, out);
  return box_bound(q, out, tables.block_root.data() + row * 6);
}

// Requests the cache lines of block `row`'s half-float box row.
inline void prefetch_block_box(const SkeletonTables& tables, std::size_t row) {
  const std::size_t w = kBoundFields * tables.padded;
  const char* p = reinterpret_cast<const char*>(tables.block_box.data() + row * w);
  for (std::size_t off = 0; off < w * sizeof(std::uint16_t); off += 64) __builtin_prefetch(p + off);
}

// A bound computed in float from float32 data is compared with scores
// computed by the float32 scan: the slack covers both roundings.
inline double safe(double lb) {
  return lb * (1.0 - 1e-4) - 1e-3;
}

// The least sketch bound over the frames of one block (`blk`: its
// [kSketchFields][kBlock] sketches) for query frame a (constants ka) and
// query frame b (kb), in one pass over the block.
void sketch_block_bounds(const float* __restrict ka, const float* __restrict kb,
                         const float* __restrict blk, float& out_a, float& out_b);

// Per-frame lower bounds of the scanned h(Q -> F) for the kBlock frames of
// one block from their chain sketches (`blk`: [chains][kSketchFields][kBlock]
// halves of SkeletonTables::chain_sketch) and the query's chain constants k
// (BoundQuery::chain_sketch): out[l] = sum over the chains of the sketch
// term's least value over the fields' intervals [v - r, v + r] (v a stored
// half, r = half_nearest_radius(v): the interval holds the frame's value;
// docs/search.md "Chain sketches": h is a sum over segments, and each
// chain's segments obey the whole-body lemma).
void chain_sketch_bounds(const float* __restrict k, const std::uint16_t* __restrict blk,
                         std::size_t chains, float* __restrict out);

// The bounds of query frame q over the frames of each of group g's kLanes
// clips (out[l]: clip row kLanes g + l): their box bounds and, for a full
// query frame, at least their sketch-range bounds (docs/search.md "Sketch
// ranges"); 0 for partial query frames.
void clip_tile_bounds(const BoundQuery& q, const SkeletonTables& tables, std::size_t g, float* out);

// The same over every frame of each group's clips, for all the groups of the
// skeleton: out[g], g < the number of groups (out is resized to whole tiles).
void group_bounds(const BoundQuery& q, const SkeletonTables& tables, std::vector<float>& out);

}  // namespace mocap::search_detail
