// Box and sketch bounds of query frames over blocks, clips and groups of
// clips (box_bounds.hpp).
#include "bounds/box_bounds.hpp"

#include "bounds/bound_tables.hpp"
#include "mocap/common/util/multiversion.hpp"

namespace mocap::search_detail {

BoundQuery make_bound_query(const ResolvedFrame& q, const SkeletonTables& tables) {
  BoundQuery b;
  b.kind = q.kind;
  b.s = tables.padded;
  // A frame that compares only some segments (retargeted from another rig):
  // every bound here sums over all segments, so it gets the partial frames'
  // bound 0 (and, having no per-frame bounds, is scanned whole).
  if (!q.compared.empty()) b.kind = FrameKind::partial;
  if (b.kind == FrameKind::full) {
    for (auto* v : {&b.ax, &b.ay, &b.az, &b.ka, &b.mg, &b.mh, &b.kar}) v->reserve(b.s);
    for (std::size_t s = 0; s < tables.segments; ++s) {
      using C = HScanConstant;
      const float* k = q.scan.constants.data() + s * HScanQuery::kConstants;
      b.ax.push_back(k[C::com_x]);
      b.ay.push_back(k[C::com_y]);
      b.az.push_back(k[C::com_z]);
      b.ka.push_back(k[C::kinetic]);
      b.mg.push_back(k[C::mass_gravity]);
      b.mh.push_back(k[C::mass_half_inv_t2]);
      b.kar.push_back(k[C::kinetic_rot]);
    }
    const std::vector<float>* com[3] = {&b.ax, &b.ay, &b.az};
    auto com_of = [&](std::size_t s, std::size_t a) { return (*com[a])[s]; };
    auto ke_of = [&](std::size_t s) { return b.ka[s]; };
    auto rot_of = [&](std::size_t s) { return b.kar[s]; };
    // A group's sketch constants: its sketch, then M g and M / T^2 summed from
    // the scan's own constants (in segment order, like the sketch).
    auto constants = [&](const std::array<double, kSketchFields>& v, double mg, double m_t2,
                         float* out) {
      for (std::size_t i = 0; i < kSketchFields; ++i) out[i] = static_cast<float>(v[i]);
      out[5] = static_cast<float>(mg);
      out[6] = static_cast<float>(m_t2);
    };
    double mg = 0.0, m_t2 = 0.0;
    std::vector<double> chain_mg(tables.chains, 0.0), chain_m_t2(tables.chains, 0.0);
    for (std::size_t s = 0; s < tables.segments; ++s) {
      mg += static_cast<double>(b.mg[s]);
      m_t2 += 2.0 * static_cast<double>(b.mh[s]);
      chain_mg[tables.chain_of_segment[s]] += static_cast<double>(b.mg[s]);
      chain_m_t2[tables.chain_of_segment[s]] += 2.0 * static_cast<double>(b.mh[s]);
    }
    constants(whole_body_sketch(tables, com_of, ke_of, rot_of), mg, m_t2, b.sketch.data());
    std::vector<std::array<double, kSketchFields>> chains(tables.chains);
    chain_sketches(tables, com_of, ke_of, rot_of, chains.data());
    b.chain_sketch.resize(tables.chains * kSketchConstants);
    for (std::size_t ch = 0; ch < tables.chains; ++ch)
      constants(chains[ch], chain_mg[ch], chain_m_t2[ch],
                b.chain_sketch.data() + ch * kSketchConstants);
    for (auto* v : {&b.ax, &b.ay, &b.az, &b.ka, &b.mg, &b.mh, &b.kar}) v->resize(b.s, 0.0f);
  } else if (q.kind == FrameKind::root_only) {
    float total = 0.0f;
    b.m_inv_t2.reserve(b.s);
    for (float m : q.root_scan.masses) {
      total += m;
      b.m_inv_t2.push_back(m * q.root_scan.inv_t2);
    }
    b.m_inv_t2.resize(b.s, 0.0f);
    b.total_mg = total * q.root_scan.gravity;
    for (std::size_t a = 0; a < 3; ++a) {
      b.p[a] = q.root_scan.position[a];
      b.given[a] = q.root_scan.given[a] != 0.0f;
    }
  }
  return b;
}

// The least sketch bound over the frames of one block (`blk`: its
// [kSketchFields][kBlock] sketches) for query frame a (constants ka) and
// query frame b (kb), in one pass over the block.
MOCAP_MULTIVERSION_V4
void sketch_block_bounds(const float* __restrict ka, const float* __restrict kb,
                         const float* __restrict blk, float& out_a, float& out_b) {
  float va[kBlock], vb[kBlock];
  for (std::size_t l = 0; l < kBlock; ++l) {
    const float x = blk[l], y = blk[kBlock + l], z = blk[2 * kBlock + l];
    const float kin = blk[3 * kBlock + l], rot = blk[4 * kBlock + l];
    va[l] = sketch_term(ka, x, y, z, kin, rot);
    vb[l] = sketch_term(kb, x, y, z, kin, rot);
  }
  // Pairwise (a tree of depth 4, not a chain of 15 dependent minima).
  for (std::size_t w = kBlock / 2; w >= 1; w /= 2)
    for (std::size_t l = 0; l < w; ++l) {
      va[l] = std::min(va[l], va[l + w]);
      vb[l] = std::min(vb[l], vb[l + w]);
    }
  out_a = va[0];
  out_b = vb[0];
}

namespace {

// Lower bound of the scanned h(Q -> F) for a full query frame over the
// frames F whose sketch fields lie in the ranges [lo[i], hi[i]] (a clip's or
// a group's): each term of sketch_term at its least over the ranges, which
// the sum of the terms' minima cannot exceed (docs/search.md "Sketch
// ranges"). k: the query's constants (BoundQuery::sketch).
inline float sketch_range_term(const float* k, const float* lo, const float* hi) {
  auto dist = [](float v, float a, float b) { return std::max(std::max(a - v, v - b), 0.0f); };
  const float dx = dist(k[0], lo[0], hi[0]), dy = dist(k[1], lo[1], hi[1]),
              dz = dist(k[2], lo[2], hi[2]);
  const float trans =
      std::max(dist(k[3], lo[3], hi[3]), k[6] * ((dx * dx + dy * dy) + dz * dz) - k[3] - hi[3]);
  return (k[5] * dy + trans) + dist(k[4], lo[4], hi[4]);
}

}  // namespace

MOCAP_MULTIVERSION_V4
void chain_sketch_bounds(const float* __restrict k, const std::uint16_t* __restrict blk,
                         std::size_t chains, float* __restrict out) {
  constexpr std::size_t kChainRow = kSketchFields * kBlock;
  float v[kChainRow];
  for (std::size_t l = 0; l < kBlock; ++l) out[l] = 0.0f;
  for (std::size_t ch = 0; ch < chains; ++ch) {
    halves_to_floats(blk + ch * kChainRow, kChainRow, v);
    const float* kc = k + ch * kSketchConstants;
    for (std::size_t l = 0; l < kBlock; ++l) {
      float lo[kSketchFields], hi[kSketchFields];
      for (std::size_t i = 0; i < kSketchFields; ++i) {
        const float x = v[i * kBlock + l], r = half_nearest_radius(x);
        lo[i] = x - r;
        hi[i] = x + r;
      }
      out[l] += sketch_range_term(kc, lo, hi);
    }
  }
}

namespace {

// sketch_range_term for the kLanes clips of one lane-major tile
// (SkeletonTables::clip_sketch_soa), vectorised over the clips.
MOCAP_MULTIVERSION_V4
void sketch_range_lanes(const float* __restrict k, const float* __restrict tile,
                        float* __restrict out) {
  for (std::size_t l = 0; l < kLanes; ++l) {
    float lo[kSketchFields], hi[kSketchFields];
    for (std::size_t i = 0; i < kSketchFields; ++i) {
      lo[i] = tile[i * kLanes + l];
      hi[i] = tile[(kSketchFields + i) * kLanes + l];
    }
    out[l] = sketch_range_term(k, lo, hi);
  }
}

// box_bound for the kLanes boxes of one lane-major tile (SkeletonTables::clip_soa)
// at once, vectorised over the boxes: out[l] bounds h(Q -> F) for every
// frame F of box l. The same terms as box_bound (summed in another
// order: the caller's slack covers it); 0 for partial query frames.
MOCAP_MULTIVERSION_V4
void box_bounds_lanes(const BoundQuery& q, const float* __restrict tile,
                      const float* __restrict root, std::size_t segments, float* __restrict out) {
  float acc[kLanes];
  for (std::size_t l = 0; l < kLanes; ++l) acc[l] = 0.0f;
  const std::size_t n = segments * kLanes;
  if (q.kind == FrameKind::full) {
    for (std::size_t b = 0; b < segments; ++b) {
      const float ax = q.ax[b], ay = q.ay[b], az = q.az[b], ka = q.ka[b], kar = q.kar[b];
      const float mg = q.mg[b], mh = q.mh[b];
      const float* __restrict lx = tile + b * kLanes;
      const float* __restrict ly = lx + n;
      const float* __restrict lz = lx + 2 * n;
      const float* __restrict hx = lx + 3 * n;
      const float* __restrict hy = lx + 4 * n;
      const float* __restrict hz = lx + 5 * n;
      const float* __restrict klo = lx + 6 * n;
      const float* __restrict khi = lx + 7 * n;
      const float* __restrict rlo = lx + 8 * n;
      const float* __restrict rhi = lx + 9 * n;
      for (std::size_t l = 0; l < kLanes; ++l) {
        const float dx = std::max(std::max(lx[l] - ax, ax - hx[l]), 0.0f);
        const float dy = std::max(std::max(ly[l] - ay, ay - hy[l]), 0.0f);
        const float dz = std::max(std::max(lz[l] - az, az - hz[l]), 0.0f);
        const float ku = mh * ((dx * dx + dy * dy) + dz * dz);
        const float x = std::min(std::max(std::max(ku, ka), klo[l]), khi[l]);
        const float phi = std::max(std::max(x - ka, ka - x), ((ku + ku) - ka) - x);
        const float rot = std::max(std::max(rlo[l] - kar, kar - rhi[l]), 0.0f);
        acc[l] += (mg * dy + phi) + rot;
      }
    }
  } else if (q.kind == FrameKind::root_only) {
    float d2[kLanes], dy[kLanes];
    for (std::size_t l = 0; l < kLanes; ++l) d2[l] = dy[l] = 0.0f;
    for (std::size_t a = 0; a < 3; ++a) {
      if (!q.given[a]) continue;
      const float p = q.p[a];
      const float* __restrict lo = root + a * kLanes;
      const float* __restrict hi = root + (a + 3) * kLanes;
      for (std::size_t l = 0; l < kLanes; ++l) {
        const float d = std::max(std::max(lo[l] - p, p - hi[l]), 0.0f);
        d2[l] += d * d;
        if (a == 1) dy[l] = d;
      }
    }
    for (std::size_t l = 0; l < kLanes; ++l) acc[l] = q.total_mg * dy[l];
    for (std::size_t b = 0; b < segments; ++b) {
      const float m = q.m_inv_t2[b];
      const float* __restrict klo = tile + 6 * n + b * kLanes;
      const float* __restrict khi = tile + 7 * n + b * kLanes;
      const float* __restrict rlo = tile + 8 * n + b * kLanes;
      for (std::size_t l = 0; l < kLanes; ++l) {
        const float c = m * d2[l];
        const float x = std::min(std::max(0.5f * c, klo[l]), khi[l]);
        acc[l] += std::max(x, c - x) + rlo[l];
      }
    }
  }
  for (std::size_t l = 0; l < kLanes; ++l) out[l] = acc[l];
}

// The bounds of query frame q over the frames of each of the kLanes boxes
// of lane-major tile t (soa, root_soa, sketch_soa: clip_soa, clip_root_soa,
// clip_sketch_soa or the group ones): their box bounds and, for a full
// query frame, at least their sketch-range bounds.
void tile_bounds(const BoundQuery& q, const SkeletonTables& tables, const std::vector<float>& soa,
                 const std::vector<float>& root_soa, const std::vector<float>& sketch_soa,
                 std::size_t t, float* out) {
  box_bounds_lanes(q, soa.data() + t * kBoundFields * tables.segments * kLanes,
                   root_soa.data() + t * 6 * kLanes, tables.segments, out);
  if (q.kind != FrameKind::full) return;
  float sk[kLanes];
  sketch_range_lanes(q.sketch.data(), sketch_soa.data() + t * kSketchRange * kLanes, sk);
  for (std::size_t l = 0; l < kLanes; ++l) out[l] = std::max(out[l], sk[l]);
}

}  // namespace

void clip_tile_bounds(const BoundQuery& q, const SkeletonTables& tables, std::size_t g,
                      float* out) {
  tile_bounds(q, tables, tables.clip_soa, tables.clip_root_soa, tables.clip_sketch_soa, g, out);
}

void group_bounds(const BoundQuery& q, const SkeletonTables& tables, std::vector<float>& out) {
  const std::size_t tiles = tables.group_root_soa.size() / (6 * kLanes);
  out.resize(tiles * kLanes);
  for (std::size_t t = 0; t < tiles; ++t)
    tile_bounds(q, tables, tables.group_soa, tables.group_root_soa, tables.group_sketch_soa, t,
                out.data() + t * kLanes);
}

}  // namespace mocap::search_detail
