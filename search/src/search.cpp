// The search engine (search.hpp; algorithm and proofs: docs/search.md).
#include "mocap/search.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>
#include <set>
#include <sstream>

#include "flann_knn.hpp"
#include "mocap/body.hpp"
#include "mocap/energy.hpp"
#include "mocap/error.hpp"
#include "mocap/half.hpp"
#include "mocap/memory.hpp"
#include "mocap/newton_euler.hpp"
#include "resolve.hpp"

namespace mocap {

using search_detail::BvhCache;
using search_detail::FrameKind;
using search_detail::ResolvedFrame;

const char* search_mode_name(SearchMode m) {
  switch (m) {
    case SearchMode::exact:
      return "exact";
    case SearchMode::approx:
      return "approx";
    case SearchMode::brute:
      return "brute";
  }
  return "?";
}

std::optional<SearchMode> parse_search_mode(const std::string& s) {
  if (s == "exact") return SearchMode::exact;
  if (s == "approx") return SearchMode::approx;
  if (s == "brute") return SearchMode::brute;
  return std::nullopt;
}

// ---------------------------------------------------------------------------
// Running minimum

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// (score, e, s) lexicographic: true when the candidate beats the incumbent.
bool better(double score, std::size_t e, std::size_t s, const ClipBest& best, bool have) {
  if (!have) return true;
  if (score != best.score) return score < best.score;
  if (e != best.e) return e < best.e;
  return s < best.s;
}
}  // namespace

bool best_partial_motion(const double* a, const double* b, const double* prefix, std::size_t k,
                         double lambda, ClipBest& out) {
  bool have = false;
  double run_min = kInf;  // min_{s<e} (a(s) - lambda P[s])
  std::size_t run_s = 0;
  for (std::size_t e = 1; e < k; ++e) {
    const std::size_t s = e - 1;
    if (std::isfinite(a[s])) {
      const double v = a[s] - lambda * prefix[s];
      if (v < run_min) {  // strict: the earliest s wins ties
        run_min = v;
        run_s = s;
      }
    }
    if (!std::isfinite(b[e]) || !std::isfinite(run_min)) continue;
    const double score = (b[e] + lambda * prefix[e]) + run_min;
    if (score < out.score || !have) {  // strict: the earliest e wins ties
      out = {score, run_s, e};
      have = true;
    }
  }
  return have;
}

bool best_partial_motion_quadratic(const double* a, const double* b, const double* prefix,
                                   std::size_t k, double lambda, ClipBest& out) {
  bool have = false;
  for (std::size_t e = 1; e < k; ++e) {
    if (!std::isfinite(b[e])) continue;
    for (std::size_t s = 0; s < e; ++s) {
      if (!std::isfinite(a[s])) continue;
      const double score = (b[e] + lambda * prefix[e]) + (a[s] - lambda * prefix[s]);
      if (better(score, e, s, out, have)) {
        out = {score, s, e};
        have = true;
      }
    }
  }
  return have;
}

// ---------------------------------------------------------------------------
// Engine tables

namespace {

struct ClipInfo {
  std::size_t clip = 0;         // global clip index
  std::size_t frame_start = 0;  // skeleton row of frame 0
  std::size_t frame_count = 0;
  std::size_t block_start = 0;  // row of block 0 in SkelData::block_bounds (16-frame blocks)
  std::size_t row = 0;          // clip_bounds row
};

struct FrameArrays {
  const float *pos, *rot, *com, *vel, *angvel, *lrot;
};

// Bound tables (docs/search.md "Box bounds"): per 16-frame block and per clip,
// kBoundFields rows of S floats: the minimum and maximum over the frames of
// the scan table's segment COM x, y, z, translational KE and rotational KE.
// Computed from the very float values the scan reads, so a bound computed
// from them holds for the scanned h of every frame of the block.
constexpr std::size_t kBoundFields = 10;  // cmin xyz, cmax xyz, KE min max, KE_rot min max
// Whether bound field f (of kBoundFields) is a minimum (0..2, 6, 8) or a maximum (3..5, 7, 9).
constexpr bool is_min_bound_field(std::size_t f) {
  return f < 3 || f == 6 || f == 8;
}
constexpr std::size_t kBlock = 16;
constexpr std::size_t kGroup = 16;  // clips per group (group bound tables)
constexpr std::size_t kLanes = 16;  // clips per lane-major tile (box_bounds_lanes)
// Whole-body sketch of a frame (docs/search.md "Whole-body sketches"): the
// segments' mass-weighted mean COM x, y, z (metres) and the sums of their
// translational and rotational kinetic energies (J).
constexpr std::size_t kSketchFields = 5;
constexpr std::size_t kSketchRange = 2 * kSketchFields;  // min fields, then max fields
constexpr std::size_t kSketchConstants = kSketchFields + 2;  // a query's: fields, M g, M / T^2
static_assert(kGroup == kLanes, "a group's clip bounds are one lane-major tile");

struct SkelData {
  std::uint32_t k = 0;
  const IndexSkeleton* sk = nullptr;
  DynamicsModel model;
  HScanTable table;
  std::size_t segments = 0;
  std::size_t padded = 0;      // segments rounded up to a multiple of 8 (bound tables)
  std::vector<double> masses;  // per segment
  double segment_mass = 0.0;
  std::vector<double> lambda_min;        // per segment: smallest principal moment (kg m^2)
  std::vector<int> segment_of_joint;     // joint -> segment index, -1 if massless
  std::vector<ClipInfo> clips;           // by row
  std::vector<std::uint32_t> frame_row;  // skeleton frame -> clip row
  // The scan table again, one tile per 16-frame block (the blocks of
  // block_bounds): a block's 16 x S x 9 values are contiguous, so scanning a
  // block reads 12 KB in one stream instead of S x 9 rows far apart. Block
  // `row`'s tile is HScanTable's layout with stride kBlock at
  // tile_values[tile_offset + row * tile_floats] (64-byte aligned, on huge
  // pages: assign_huge), its root rows at tile_roots[root_offset + row * 3 kBlock].
  std::vector<float> tile_values, tile_roots;
  std::size_t tile_floats = 0, tile_offset = 0, root_offset = 0;
  // Block `row`'s tile, `frames` frames of it (<= kBlock).
  HScanView tile(std::size_t row, std::size_t frames) const {
    return {tile_values.data() + tile_offset + row * tile_floats,
            tile_roots.data() + root_offset + row * 3 * kBlock, frames, kBlock,
            model.segments.size()};
  }
  // [row][kBoundFields][S] and root boxes [row][6] (min xyz, max xyz), metres / joules
  // (clip_bounds and clip_root only while the tables are built: clip_soa holds them).
  // The blocks' rows are kept as IEEE half floats rounded outwards (block_box:
  // minima down, maxima up, so each box still holds its frames' values; half
  // the bytes of a row for the 1,200 block boxes a full-frame query reads;
  // docs/search.md "Box bounds"); block_bounds is the float table they are
  // made from, emptied once the clip rows are built.
  std::vector<float> block_bounds, clip_bounds, block_root, clip_root;
  std::vector<std::uint16_t> block_box;
  // The clip bound table again, lane-major for SIMD over a group's clips
  // (box_bounds_lanes): tile g holds clip rows [kLanes g, kLanes g + kLanes)
  // (group g) as [kBoundFields][segments][kLanes] floats, and their root
  // boxes as [6][kLanes] (unused lanes are zero).
  std::vector<float> clip_soa, clip_root_soa;
  // The same for groups of kGroup consecutive clip rows (the union of their
  // clips' boxes): tile t holds groups [kLanes t, kLanes t + kLanes).
  std::vector<float> group_soa, group_root_soa;
  // Whole-body sketches of every frame, per block: [block][kSketchFields][kBlock]
  // floats, from the scan table's float values (a short block repeats its
  // last frame, which leaves the block's minimum unchanged).
  std::vector<float> sketch;
  // The ranges of the sketch fields over each clip's frames, lane-major like
  // clip_soa: tile g holds clip rows [kLanes g, kLanes g + kLanes) as
  // [kSketchRange][kLanes] floats (min x y z kin rot, max x y z kin rot;
  // unused lanes are zero); and over each group's frames, lane-major by
  // group tiles like group_soa.
  std::vector<float> clip_sketch_soa, group_sketch_soa;
  // Chain sketches (docs/search.md "Chain sketches"): the same five fields
  // per kinematic chain (a maximal run of joints without branching; the
  // chains with segments, `chains` of them, chain_of_segment[b] in
  // [0, chains)), per frame, per block: [block][chains][kSketchFields][kBlock]
  // floats; chain_mass[c] = the chain's total segment mass (kg).
  std::size_t chains = 0;
  std::vector<std::uint32_t> chain_of_segment;
  std::vector<double> chain_mass;
  std::vector<float> chain_sketch;
  // A query character's kd features [N][S*3] (kd points to them; null for
  // the index's character: ensure_forest reads the index's on first use).
  const float* kd = nullptr;
  std::vector<float> kd_own;
  // Frame arrays for partial queries (index arrays, loaded on first use; for a
  // query character the character-dependent ones are owned).
  mutable std::once_flag frames_once;
  mutable FrameArrays fa{};
  std::vector<float> pos_own, com_own, vel_own;
  bool own_frames = false;
  // Per-joint columns of the frame arrays for joint-rotation frames (their
  // per-frame bound, partial_bounds_columns, and the subtree kernel,
  // subtree_energy_lanes): column kind * joints + joint holds the
  // joint's components (w x y z for rotations, x y z for positions) as rows
  // of col_stride floats, one value per skeleton frame. Made on first use
  // (ensure_columns, under col_mutex: streamed from the index array, the
  // array itself not kept), then read-only.
  std::size_t col_stride = 0;
  mutable std::mutex col_mutex;
  mutable std::unique_ptr<std::unique_ptr<float[]>[]> cols;
  // The index's energy prefix sums of the skeleton's frames (Index::array
  // locks a mutex: fetched once, not per clip); null for a query character.
  const double* prefix_index = nullptr;
  // A query character's energy prefix sums (lambda > 0), built on first use.
  mutable std::once_flag prefix_once;
  mutable std::vector<double> prefix_own;
  std::vector<double> joint_ratio;  // query character: bone length ratio per joint (1 = index's)
  IndexSkeleton sk_own;  // query character: the skeleton with its length scales, its body
  mutable std::once_flag flann_once;
  mutable std::unique_ptr<search_detail::KnnIndex> flann;
};

// The frame arrays of skeleton k (loaded once): what
// partial_approximate_energy reads through frame_ref, for partial frames that
// move the whole body (a heading, a root position with joint rotations, a
// root rotation). Joint-rotation frames read per-joint columns instead
// (ensure_columns).
const FrameArrays& frame_arrays(const Index& index, const SkelData& sd) {
  std::call_once(sd.frames_once, [&] {
    tbb::this_task_arena::isolate([&] {
      const std::uint32_t k = sd.k;
      sd.fa = {index.array(k, "frames", "joint_positions_m").f32.data(),
               index.array(k, "frames", "world_rotations").f32.data(),
               index.array(k, "frames", "segment_com_m").f32.data(),
               index.array(k, "frames", "segment_com_velocity_mps").f32.data(),
               index.array(k, "frames", "segment_angular_velocity_radps").f32.data(),
               index.array(k, "frames", "local_rotations").f32.data()};
      if (sd.own_frames) {
        sd.fa.pos = sd.pos_own.data();
        sd.fa.com = sd.com_own.data();
        sd.fa.vel = sd.vel_own.data();
      }
    });
  });
  return sd.fa;
}

// The frame-array columns of joint-rotation frames (SkelData::cols).
enum class JointColumn : std::size_t { local_rotation = 0, world_rotation = 1, position = 2 };
constexpr std::size_t kJointColumnKinds = 3;

// Makes columns `kind` of `joints` of skeleton sd available: one pass over
// the index array streams in the rows (Index::stream_rows: blocks of 8,192
// frames, checksum compared) and keeps the missing joints' columns; a query
// character's positions come from its own array. Thread-safe.
void ensure_columns(const Index& index, const SkelData& sd, JointColumn kind,
                    const std::vector<std::size_t>& joints) {
  const std::size_t nj = sd.model.joint_count(), n = sd.sk->frame_count;
  const std::size_t w = kind == JointColumn::position ? 3 : 4;
  const std::size_t base = static_cast<std::size_t>(kind) * nj;
  std::lock_guard lock(sd.col_mutex);
  std::vector<std::size_t> missing;
  for (std::size_t j : joints)
    if (!sd.cols[base + j] && std::find(missing.begin(), missing.end(), j) == missing.end())
      missing.push_back(j);
  if (missing.empty()) return;
  std::vector<float*> out;
  for (std::size_t j : missing) {
    sd.cols[base + j] = std::make_unique_for_overwrite<float[]>(w * sd.col_stride);
    out.push_back(sd.cols[base + j].get());
  }
  auto take = [&](std::uint64_t first, std::uint64_t count, const float* rows) {
    for (std::size_t m = 0; m < missing.size(); ++m)
      for (std::size_t a = 0; a < w; ++a) {
        float* col = out[m] + a * sd.col_stride + first;
        const float* src = rows + missing[m] * w + a;
        for (std::size_t i = 0; i < count; ++i) col[i] = src[i * nj * w];
      }
  };
  try {
    if (kind == JointColumn::position && sd.own_frames) {
      take(0, n, sd.pos_own.data());
    } else {
      const char* field = kind == JointColumn::local_rotation   ? "local_rotations"
                          : kind == JointColumn::world_rotation ? "world_rotations"
                                                                : "joint_positions_m";
      index.stream_rows(sd.k, "frames", field, 8192, take);
    }
  } catch (...) {
    for (std::size_t j : missing) sd.cols[base + j].reset();  // never half-made
    throw;
  }
}

// Column `kind` of joint j of skeleton sd (after ensure_columns).
const float* joint_column(const SkelData& sd, JointColumn kind, std::size_t j) {
  return sd.cols[static_cast<std::size_t>(kind) * sd.model.joint_count() + j].get();
}

// The FLANN forest of skeleton sd's frame features (approx mode), built once
// (the index's kd_features, read then: exact and brute never need them).
void ensure_forest(const Index& index, const SkelData& sd, const SearchOptions& opt) {
  const std::size_t n = sd.sk->frame_count, dim = sd.segments * 3;
  if (n == 0) return;
  std::call_once(sd.flann_once, [&] {
    tbb::this_task_arena::isolate([&] {
      const float* kd =
          sd.kd != nullptr ? sd.kd : index.array(sd.k, "frames", "kd_features").f32.data();
      sd.flann = std::make_unique<search_detail::KnnIndex>(kd, n, dim, opt.approx_trees);
    });
  });
}

// Sketches of groups of segments (kSketchFields values each: mass-weighted
// mean COM x y z, summed KE, summed KE_rot) from per-segment values:
// com(s, axis), ke(s), rot(s), summed in double in segment order, in one pass;
// group(s) in [0, groups) is segment s's group and mass[c] group c's mass.
// Database frames and query frames are formed by this one function, as the
// bounds require. A group without mass gets a zero COM (no segment: h = 0
// there, and so is the bound).
template <class Group, class Com, class Ke, class Rot>
void group_sketches(const SkelData& sd, Group group, const double* mass, std::size_t groups,
                    Com com, Ke ke, Rot rot, std::array<double, kSketchFields>* out) {
  for (std::size_t c = 0; c < groups; ++c) out[c] = {};
  for (std::size_t b = 0; b < sd.segments; ++b) {
    std::array<double, kSketchFields>& v = out[group(b)];
    for (std::size_t a = 0; a < 3; ++a) v[a] += sd.masses[b] * static_cast<double>(com(b, a));
    v[3] += static_cast<double>(ke(b));
    v[4] += static_cast<double>(rot(b));
  }
  for (std::size_t c = 0; c < groups; ++c)
    if (mass[c] > 0.0)
      for (std::size_t a = 0; a < 3; ++a) out[c][a] /= mass[c];
}

// The whole body as one group.
template <class Com, class Ke, class Rot>
std::array<double, kSketchFields> whole_body_sketch(const SkelData& sd, Com com, Ke ke, Rot rot) {
  std::array<double, kSketchFields> v;
  group_sketches(
      sd, [](std::size_t) { return std::size_t{0}; }, &sd.segment_mass, 1, com, ke, rot, &v);
  return v;
}

// Each kinematic chain as a group (SkelData::chain_of_segment): out[c], c < sd.chains.
template <class Com, class Ke, class Rot>
void chain_sketches(const SkelData& sd, Com com, Ke ke, Rot rot,
                    std::array<double, kSketchFields>* out) {
  group_sketches(
      sd, [&](std::size_t b) { return static_cast<std::size_t>(sd.chain_of_segment[b]); },
      sd.chain_mass.data(), sd.chains, com, ke, rot, out);
}

// Model-derived per-segment constants, clip rows, frame -> clip row.
void init_skel_data(const Index& index, std::uint32_t k, DynamicsModel model, SkelData& sd) {
  sd.k = k;
  sd.sk = &index.skeletons()[k];
  sd.model = std::move(model);
  sd.segments = sd.model.segments.size();
  sd.padded = (sd.segments + 7) / 8 * 8;
  sd.segment_of_joint.assign(sd.model.joint_count(), -1);
  sd.col_stride = (sd.sk->frame_count + 15) / 16 * 16;
  sd.cols =
      std::make_unique<std::unique_ptr<float[]>[]>(kJointColumnKinds * sd.model.joint_count());
  for (int b : sd.model.segments) {
    const auto j = static_cast<std::size_t>(b);
    sd.masses.push_back(sd.model.masses_kg[j]);
    sd.segment_mass += sd.masses.back();
    // Smallest eigenvalue of the (symmetric) local inertia: w^T R I R^T w >= lambda_min |w|^2.
    const Eigen::Vector3d d = sd.model.principal_moments_kgm2[j];
    sd.lambda_min.push_back(std::max(0.0, std::min({d[0], d[1], d[2]})));
    sd.segment_of_joint[j] = static_cast<int>(sd.masses.size() - 1);
  }
  // Kinematic chains: a joint starts one unless its parent has exactly one
  // child (joints are in index order, parents first); chains without a
  // segment are dropped.
  const std::size_t nj = sd.model.joint_count();
  std::vector<int> children(nj, 0), chain_of_joint(nj, -1), id_of_chain;
  for (std::size_t j = 0; j < nj; ++j)
    if (sd.model.parents[j] >= 0) ++children[static_cast<std::size_t>(sd.model.parents[j])];
  int next = 0;
  for (std::size_t j = 0; j < nj; ++j) {
    const int p = sd.model.parents[j];
    chain_of_joint[j] = p >= 0 && children[static_cast<std::size_t>(p)] == 1
                            ? chain_of_joint[static_cast<std::size_t>(p)]
                            : next++;
  }
  id_of_chain.assign(static_cast<std::size_t>(next), -1);
  for (std::size_t b = 0; b < sd.segments; ++b) {
    int& id = id_of_chain[static_cast<std::size_t>(
        chain_of_joint[static_cast<std::size_t>(sd.model.segments[b])])];
    if (id < 0) {
      id = static_cast<int>(sd.chains++);
      sd.chain_mass.push_back(0.0);
    }
    sd.chain_of_segment.push_back(static_cast<std::uint32_t>(id));
    sd.chain_mass[static_cast<std::size_t>(id)] += sd.masses[b];
  }
  const std::size_t n = sd.sk->frame_count;
  std::size_t blocks = 0;
  for (std::size_t row = 0; row < sd.sk->clips.size(); ++row) {
    const IndexClip& c = index.clips()[sd.sk->clips[row]];
    sd.clips.push_back({sd.sk->clips[row], c.frame_start, c.frame_count, blocks, c.row});
    blocks += (c.frame_count + kBlock - 1) / kBlock;
  }
  sd.frame_row.assign(n, 0);
  for (std::size_t row = 0; row < sd.clips.size(); ++row)
    for (std::size_t f = 0; f < sd.clips[row].frame_count; ++f)
      sd.frame_row[sd.clips[row].frame_start + f] = static_cast<std::uint32_t>(row);
  init_h_scan_table(sd.model, n, sd.table);
}

// Block and clip bound tables from the scan table (parallel over clips).
void build_bound_tables(SkelData& sd) {
  // Rows of `padded` floats; the padding stays 0 (a zero box and zero query
  // constants make a zero term).
  const std::size_t s = sd.padded, w = kBoundFields * s, real = sd.segments;
  const std::size_t blocks =
      sd.clips.empty()
          ? 0
          : sd.clips.back().block_start + (sd.clips.back().frame_count + kBlock - 1) / kBlock;
  sd.block_bounds.assign(blocks * w, 0.0f);
  sd.block_root.assign(blocks * 6, 0.0f);
  sd.clip_bounds.assign(sd.clips.size() * w, 0.0f);
  sd.clip_root.assign(sd.clips.size() * 6, 0.0f);
  // Tiles: rows of kBlock floats, whole 64-byte lines; the first one aligned.
  constexpr std::size_t kLine = 64 / sizeof(float);
  static_assert(kBlock % kLine == 0, "a tile row is whole cache lines");
  auto line_offset = [](const std::vector<float>& v) {
    const auto a = reinterpret_cast<std::uintptr_t>(v.data()) / sizeof(float);
    return (kLine - a % kLine) % kLine;
  };
  sd.tile_floats = real * HScanTable::kFields * kBlock;
  assign_huge(sd.tile_values, blocks * sd.tile_floats + kLine, 0.0f);
  assign_huge(sd.tile_roots, blocks * 3 * kBlock + kLine, 0.0f);
  sd.tile_offset = line_offset(sd.tile_values);
  sd.root_offset = line_offset(sd.tile_roots);
  assign_huge(sd.sketch, blocks * kSketchFields * kBlock, 0.0f);
  assign_huge(sd.chain_sketch, blocks * sd.chains * kSketchFields * kBlock, 0.0f);
  const HScanTable& tb = sd.table;
  constexpr float inf = std::numeric_limits<float>::infinity();
  auto init = [&](float* row, float* root) {
    for (std::size_t f = 0; f < 3; ++f)
      for (std::size_t b = 0; b < real; ++b) {
        row[f * s + b] = inf;
        row[(f + 3) * s + b] = -inf;
      }
    for (std::size_t b = 0; b < real; ++b) {
      row[6 * s + b] = row[8 * s + b] = inf;
      row[7 * s + b] = row[9 * s + b] = -inf;
    }
    for (std::size_t a = 0; a < 3; ++a) {
      root[a] = inf;
      root[a + 3] = -inf;
    }
  };
  // Widens the box `row` (bound row and root box) to hold the box `from`.
  auto unite = [&](float* row, float* root, const float* from, const float* from_root) {
    for (std::size_t i = 0; i < w; ++i)
      row[i] = is_min_bound_field(i / s) ? std::min(row[i], from[i]) : std::max(row[i], from[i]);
    for (std::size_t a = 0; a < 3; ++a) {
      root[a] = std::min(root[a], from_root[a]);
      root[a + 3] = std::max(root[a + 3], from_root[a + 3]);
    }
  };
  tbb::parallel_for(std::size_t{0}, sd.clips.size(), [&](std::size_t r) {
    const ClipInfo& ci = sd.clips[r];
    std::vector<std::array<double, kSketchFields>> chain_values(sd.chains);
    float* crow = sd.clip_bounds.data() + r * w;
    float* croot = sd.clip_root.data() + r * 6;
    init(crow, croot);
    for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
      float* row = sd.block_bounds.data() + (ci.block_start + bl) * w;
      float* root = sd.block_root.data() + (ci.block_start + bl) * 6;
      init(row, root);
      const std::size_t g0 = ci.frame_start + bl * kBlock,
                        g1 = ci.frame_start + std::min(ci.frame_count, bl * kBlock + kBlock);
      float* tile_values =
          sd.tile_values.data() + sd.tile_offset + (ci.block_start + bl) * sd.tile_floats;
      float* tile_roots =
          sd.tile_roots.data() + sd.root_offset + (ci.block_start + bl) * 3 * kBlock;
      for (std::size_t f = 0; f < real * HScanTable::kFields; ++f)
        std::copy(tb.values.begin() + static_cast<std::ptrdiff_t>(f * tb.stride + g0),
                  tb.values.begin() + static_cast<std::ptrdiff_t>(f * tb.stride + g1),
                  tile_values + f * kBlock);
      for (std::size_t a = 0; a < 3; ++a)
        std::copy(tb.root_positions.begin() + static_cast<std::ptrdiff_t>(a * tb.stride + g0),
                  tb.root_positions.begin() + static_cast<std::ptrdiff_t>(a * tb.stride + g1),
                  tile_roots + a * kBlock);
      float* sketch = sd.sketch.data() + (ci.block_start + bl) * kSketchFields * kBlock;
      float* chain =
          sd.chain_sketch.data() + (ci.block_start + bl) * sd.chains * kSketchFields * kBlock;
      for (std::size_t l = 0; l < kBlock; ++l) {
        const std::size_t g = std::min(g0 + l, g1 - 1);
        auto com = [&](std::size_t b, std::size_t a) { return tb.field(b, a)[g]; };
        auto ke = [&](std::size_t b) { return tb.field(b, 3)[g]; };
        auto rot = [&](std::size_t b) { return tb.field(b, 8)[g]; };
        const auto v = whole_body_sketch(sd, com, ke, rot);
        for (std::size_t i = 0; i < kSketchFields; ++i)
          sketch[i * kBlock + l] = static_cast<float>(v[i]);
        chain_sketches(sd, com, ke, rot, chain_values.data());
        for (std::size_t ch = 0; ch < sd.chains; ++ch)
          for (std::size_t i = 0; i < kSketchFields; ++i)
            chain[(ch * kSketchFields + i) * kBlock + l] = static_cast<float>(chain_values[ch][i]);
      }
      // Scan fields COM x y z, KE, KE_rot -> (min, max) bound fields.
      constexpr std::size_t src[5] = {0, 1, 2, 3, 8}, lo_f[5] = {0, 1, 2, 6, 8},
                            hi_f[5] = {3, 4, 5, 7, 9};
      for (std::size_t b = 0; b < real; ++b)
        for (std::size_t i = 0; i < 5; ++i) {
          const float* v = tb.field(b, src[i]);
          float& lo = row[lo_f[i] * s + b];
          float& hi = row[hi_f[i] * s + b];
          for (std::size_t g = g0; g < g1; ++g) {
            lo = std::min(lo, v[g]);
            hi = std::max(hi, v[g]);
          }
        }
      for (std::size_t a = 0; a < 3; ++a)
        for (std::size_t g = g0; g < g1; ++g) {
          const float v = tb.root_positions[a * tb.stride + g];
          root[a] = std::min(root[a], v);
          root[a + 3] = std::max(root[a + 3], v);
        }
      unite(crow, croot, row, root);
    }
  });
  // The blocks' rows as halves rounded outwards; the float rows are not needed any more.
  assign_huge(sd.block_box, sd.block_bounds.size(), std::uint16_t{0});
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t row) {
    for (std::size_t i = 0; i < w; ++i)
      sd.block_box[row * w + i] =
          float_to_half(sd.block_bounds[row * w + i], !is_min_bound_field(i / s));
  });
  std::vector<float>().swap(sd.block_bounds);
  // Lane-major copies (box_bounds_lanes).
  auto lanes = [&](const std::vector<float>& rows, const std::vector<float>& roots, std::size_t count,
                   std::vector<float>& out, std::vector<float>& out_root) {
    const std::size_t tiles = (count + kLanes - 1) / kLanes, tw = kBoundFields * real * kLanes;
    out.assign(tiles * tw, 0.0f);
    out_root.assign(tiles * 6 * kLanes, 0.0f);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t t = i / kLanes, l = i % kLanes;
      for (std::size_t f = 0; f < kBoundFields; ++f)
        for (std::size_t b = 0; b < real; ++b)
          out[t * tw + (f * real + b) * kLanes + l] = rows[i * w + f * s + b];
      for (std::size_t a = 0; a < 6; ++a) out_root[(t * 6 + a) * kLanes + l] = roots[i * 6 + a];
    }
  };
  lanes(sd.clip_bounds, sd.clip_root, sd.clips.size(), sd.clip_soa, sd.clip_root_soa);
  const std::size_t groups = (sd.clips.size() + kGroup - 1) / kGroup;
  // Sketch ranges of clips (lane-major) and groups, from the block sketches.
  sd.clip_sketch_soa.assign(groups * kSketchRange * kLanes, 0.0f);
  const std::size_t group_tiles = (groups + kLanes - 1) / kLanes;
  sd.group_sketch_soa.assign(group_tiles * kSketchRange * kLanes, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    std::array<float, kSketchRange> grange;
    for (std::size_t i = 0; i < kSketchFields; ++i) {
      grange[i] = inf;
      grange[kSketchFields + i] = -inf;
    }
    for (std::size_t r = g * kGroup; r < std::min(sd.clips.size(), g * kGroup + kGroup); ++r) {
      const ClipInfo& ci = sd.clips[r];
      float* tile = sd.clip_sketch_soa.data() + g * kSketchRange * kLanes;
      const std::size_t l = r % kLanes;
      for (std::size_t i = 0; i < kSketchFields; ++i) {
        float lo = inf, hi = -inf;
        for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
          const float* v = sd.sketch.data() + ((ci.block_start + bl) * kSketchFields + i) * kBlock;
          for (std::size_t f = 0; f < kBlock; ++f) {
            lo = std::min(lo, v[f]);
            hi = std::max(hi, v[f]);
          }
        }
        if (ci.frame_count == 0) lo = hi = 0.0f;
        tile[i * kLanes + l] = lo;
        tile[(kSketchFields + i) * kLanes + l] = hi;
        grange[i] = std::min(grange[i], lo);
        grange[kSketchFields + i] = std::max(grange[kSketchFields + i], hi);
      }
    }
    for (std::size_t i = 0; i < kSketchRange; ++i)
      sd.group_sketch_soa[((g / kLanes) * kSketchRange + i) * kLanes + g % kLanes] = grange[i];
  }
  std::vector<float> group_rows(groups * w, 0.0f), group_root(groups * 6, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    float* grow = group_rows.data() + g * w;
    float* groot = group_root.data() + g * 6;
    init(grow, groot);
    for (std::size_t r = g * kGroup; r < std::min(sd.clips.size(), g * kGroup + kGroup); ++r) {
      unite(grow, groot, sd.clip_bounds.data() + r * w, sd.clip_root.data() + r * 6);
    }
  }
  lanes(group_rows, group_root, groups, sd.group_soa, sd.group_root_soa);
  // The clip rows live on in their lane-major copies.
  std::vector<float>().swap(sd.clip_bounds);
  std::vector<float>().swap(sd.clip_root);
}

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

BoundQuery make_bound_query(const ResolvedFrame& q, const SkelData& sd) {
  BoundQuery b;
  b.kind = q.kind;
  b.s = sd.padded;
  if (q.kind == FrameKind::full) {
    for (auto* v : {&b.ax, &b.ay, &b.az, &b.ka, &b.mg, &b.mh, &b.kar}) v->reserve(b.s);
    for (std::size_t s = 0; s < sd.segments; ++s) {
      const float* k = q.scan.constants.data() + s * HScanQuery::kConstants;
      b.ax.push_back(k[0]);
      b.ay.push_back(k[1]);
      b.az.push_back(k[2]);
      b.ka.push_back(k[3]);
      b.mg.push_back(k[4]);
      b.mh.push_back(k[5]);
      b.kar.push_back(k[10]);
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
    std::vector<double> chain_mg(sd.chains, 0.0), chain_m_t2(sd.chains, 0.0);
    for (std::size_t s = 0; s < sd.segments; ++s) {
      mg += static_cast<double>(b.mg[s]);
      m_t2 += 2.0 * static_cast<double>(b.mh[s]);
      chain_mg[sd.chain_of_segment[s]] += static_cast<double>(b.mg[s]);
      chain_m_t2[sd.chain_of_segment[s]] += 2.0 * static_cast<double>(b.mh[s]);
    }
    constants(whole_body_sketch(sd, com_of, ke_of, rot_of), mg, m_t2, b.sketch.data());
    std::vector<std::array<double, kSketchFields>> chains(sd.chains);
    chain_sketches(sd, com_of, ke_of, rot_of, chains.data());
    b.chain_sketch.resize(sd.chains * kSketchConstants);
    for (std::size_t ch = 0; ch < sd.chains; ++ch)
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

// Lower bound of the scanned h(Q -> F) over every frame F of a block or clip
// (`row`: kBoundFields x S bounds, `root`: root box); docs/search.md proves it. Computed in float
// from the same float values and constants as the scan; the caller's slack (safe()) absorbs the
// roundings.
float box_bound(const BoundQuery& q, const float* __restrict row, const float* __restrict root) {
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

// Function multiversioning as in common/src/multiversion.hpp (an AVX-512 and
// an AVX2 clone next to the baseline one, picked at load time).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(MOCAP_NO_TARGET_CLONES) && !defined(__SANITIZE_ADDRESS__)
#define MOCAP_SEARCH_MULTIVERSION \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MOCAP_SEARCH_MULTIVERSION
#endif

// Lower bound of the scanned h(Q -> F) for a full query frame from F's
// whole-body sketch (x, y, z, kb, rb; SkelData::sketch) and the query's
// constants k (BoundQuery::sketch); docs/search.md "Whole-body sketches"
// proves it. Float, like box_bound; the caller's slack absorbs the roundings.
inline float sketch_term(const float* k, float x, float y, float z, float kb, float rb) {
  const float dx = x - k[0], dy = y - k[1], dz = z - k[2];
  const float trans =
      std::max(std::fabs(kb - k[3]), k[6] * ((dx * dx + dy * dy) + dz * dz) - k[3] - kb);
  return (k[5] * std::fabs(dy) + trans) + std::fabs(rb - k[4]);
}

// The least sketch bound over the frames of one block (`blk`: its
// [kSketchFields][kBlock] sketches) for query frame a (constants ka) and
// query frame b (kb), in one pass over the block.
MOCAP_SEARCH_MULTIVERSION
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

// box_bound of block `row` (its half-float row, SkelData::block_box).
float block_box_bound(const BoundQuery& q, const SkelData& sd, std::size_t row) {
  if (q.kind == FrameKind::partial) return 0.0f;  // as box_bound
  const std::size_t w = kBoundFields * sd.padded;
  constexpr std::size_t kStack = kBoundFields * 128;  // up to 128 segments on the stack
  std::array<float, kStack> buf;                      // NOLINT: written before read
  std::vector<float> heap;
  float* out = buf.data();
  if (w > kStack) {
    heap.resize(w);
    out = heap.data();
  }
  halves_to_floats(sd.block_box.data() + row * w, w, out);
  return box_bound(q, out, sd.block_root.data() + row * 6);
}

// Requests the cache lines of block `row`'s half-float box row.
void prefetch_block_box(const SkelData& sd, std::size_t row) {
  const std::size_t w = kBoundFields * sd.padded;
  const char* p = reinterpret_cast<const char*>(sd.block_box.data() + row * w);
  for (std::size_t off = 0; off < w * sizeof(std::uint16_t); off += 64) __builtin_prefetch(p + off);
}

// Per-frame lower bounds of the scanned h(Q -> F) for the kBlock frames of
// one block from their chain sketches (`blk`: [chains][kSketchFields][kBlock]
// of SkelData::chain_sketch) and the query's chain constants k
// (BoundQuery::chain_sketch): out[l] = sum over the chains of sketch_term
// (docs/search.md "Chain sketches": h is a sum over segments, and each
// chain's segments obey the whole-body lemma).
MOCAP_SEARCH_MULTIVERSION
void chain_sketch_bounds(const float* __restrict k, const float* __restrict blk, std::size_t chains,
                         float* __restrict out) {
  for (std::size_t l = 0; l < kBlock; ++l) out[l] = 0.0f;
  for (std::size_t ch = 0; ch < chains; ++ch) {
    const float* kc = k + ch * kSketchConstants;
    const float* v = blk + ch * kSketchFields * kBlock;
    for (std::size_t l = 0; l < kBlock; ++l)
      out[l] += sketch_term(kc, v[l], v[kBlock + l], v[2 * kBlock + l], v[3 * kBlock + l],
                            v[4 * kBlock + l]);
  }
}

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

// sketch_range_term for the kLanes clips of one lane-major tile
// (SkelData::clip_sketch_soa), vectorised over the clips.
MOCAP_SEARCH_MULTIVERSION
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

// box_bound for the kLanes boxes of one lane-major tile (SkelData::clip_soa)
// at once, vectorised over the boxes: out[l] bounds h(Q -> F) for every
// frame F of box l. The same terms as box_bound (summed in another
// order: the caller's slack covers it); 0 for partial query frames.
MOCAP_SEARCH_MULTIVERSION
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
void tile_bounds(const BoundQuery& q, const SkelData& sd, const std::vector<float>& soa,
                 const std::vector<float>& root_soa, const std::vector<float>& sketch_soa,
                 std::size_t t, float* out) {
  box_bounds_lanes(q, soa.data() + t * kBoundFields * sd.segments * kLanes,
                   root_soa.data() + t * 6 * kLanes, sd.segments, out);
  if (q.kind != FrameKind::full) return;
  float sk[kLanes];
  sketch_range_lanes(q.sketch.data(), sketch_soa.data() + t * kSketchRange * kLanes, sk);
  for (std::size_t l = 0; l < kLanes; ++l) out[l] = std::max(out[l], sk[l]);
}

// The bounds of query frame q over the frames of each of group g's kLanes
// clips (out[l]: clip row kLanes g + l).
void clip_tile_bounds(const BoundQuery& q, const SkelData& sd, std::size_t g, float* out) {
  tile_bounds(q, sd, sd.clip_soa, sd.clip_root_soa, sd.clip_sketch_soa, g, out);
}

// The bounds of query frame q over every frame of each group's clips, for
// all the groups of skeleton sd: out[g], g < the number of groups (out is
// resized to whole tiles).
void group_bounds(const BoundQuery& q, const SkelData& sd, std::vector<float>& out) {
  const std::size_t tiles = sd.group_root_soa.size() / (6 * kLanes);
  out.resize(tiles * kLanes);
  for (std::size_t t = 0; t < tiles; ++t)
    tile_bounds(q, sd, sd.group_soa, sd.group_root_soa, sd.group_sketch_soa, t,
                out.data() + t * kLanes);
}

// A bound computed in float from float32 data is compared with scores
// computed by the float32 scan: the slack covers both roundings.
double safe(double lb) {
  return lb * (1.0 - 1e-4) - 1e-3;
}

// A character's tables for skeleton k: the index's skeleton with the
// character's length scales, its body and model; per-frame dynamics
// recomputed from the stored world pose (joint positions moved for the new
// bone lengths, rotations unchanged) exactly as the indexer computes them.
std::unique_ptr<SkelData> make_character_skel_data(const Index& index, std::uint32_t k,
                                                   const Character& ch) {
  const IndexSkeleton& isk = index.skeletons()[k];
  Skeleton base = isk.skeleton;
  base.translation_scales.clear();
  const Skeleton scaled = apply_length_scales(base, ch);
  const Body body = build_body(scaled, ch);
  DynamicsModel model = build_dynamics_model(scaled, body, index.info().energy_params);
  if (model.segments.empty())
    throw InputError("character", 0,
                     "no joint of the index skeleton carries mass with this character");
  auto sd = std::make_unique<SkelData>();
  init_skel_data(index, k, std::move(model), *sd);
  // Query frames are posed on the character's skeleton (resolve_frame).
  sd->sk_own = isk;
  sd->sk_own.skeleton = scaled;
  sd->sk_own.body = body;
  sd->sk = &sd->sk_own;
  const std::size_t nj = sd->model.joint_count(), n = isk.frame_count, s = sd->segments;
  sd->joint_ratio.assign(nj, 1.0);
  bool scaled_bones = false;
  for (std::size_t j = 0; j < nj; ++j) {
    const double old_s =
        isk.skeleton.translation_scales.empty() ? 1.0 : isk.skeleton.translation_scales[j];
    const double new_s = scaled.translation_scales.empty() ? 1.0 : scaled.translation_scales[j];
    sd->joint_ratio[j] = new_s / old_s;
    scaled_bones = scaled_bones || sd->joint_ratio[j] != 1.0;
  }
  const float* pos = index.array(k, "frames", "joint_positions_m").f32.data();
  const float* rot = index.array(k, "frames", "world_rotations").f32.data();
  sd->pos_own.resize(n * nj * 3);
  sd->com_own.resize(n * nj * 3);
  sd->vel_own.resize(n * nj * 3);
  sd->kd_own.resize(n * s * 3);
  sd->own_frames = true;
  const double t_index = index.info().transition_time_s;
  tbb::parallel_for(std::size_t{0}, sd->clips.size(), [&](std::size_t r) {
    const ClipInfo& ci = sd->clips[r];
    const std::size_t kf = ci.frame_count;
    std::vector<Eigen::Vector3d> p(kf * nj);
    std::vector<Eigen::Quaterniond> q(kf * nj);
    for (std::size_t f = 0; f < kf; ++f)
      for (std::size_t j = 0; j < nj; ++j) {
        const std::size_t i = (ci.frame_start + f) * nj + j;
        const float* x = pos + i * 3;
        const float* w = rot + i * 4;
        q[f * nj + j] = Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized();
        const Eigen::Vector3d pj(x[0], x[1], x[2]);
        const int par = sd->model.parents[j];
        if (!scaled_bones || par < 0) {
          p[f * nj + j] = pj;
        } else {
          // x'_j = x'_parent + ratio_j (x_j - x_parent): the bone from the parent, rescaled.
          const auto pp = static_cast<std::size_t>(par);
          const float* xp = pos + ((ci.frame_start + f) * nj + pp) * 3;
          p[f * nj + j] =
              p[f * nj + pp] + sd->joint_ratio[j] * (pj - Eigen::Vector3d(xp[0], xp[1], xp[2]));
        }
      }
    ClipDynamics dyn;
    compute_clip_dynamics(sd->model, kf, index.clips()[ci.clip].frame_time_s, p.data(), q.data(),
                          dyn);
    for (std::size_t f = 0; f < kf; ++f) {
      const std::size_t g = ci.frame_start + f;
      set_h_scan_frame(sd->model, dyn.state(f), g, sd->table);
      const Eigen::Vector3d& root =
          dyn.joint_positions_m[f * nj + static_cast<std::size_t>(isk.root_joint)];
      for (std::size_t a = 0; a < 3; ++a)
        sd->table.root_positions[a * sd->table.stride + g] =
            static_cast<float>(root[static_cast<Eigen::Index>(a)]);
      for (std::size_t j = 0; j < nj; ++j)
        for (std::size_t a = 0; a < 3; ++a) {
          const auto e = static_cast<Eigen::Index>(a);
          sd->pos_own[(g * nj + j) * 3 + a] =
              static_cast<float>(dyn.joint_positions_m[f * nj + j][e]);
          sd->com_own[(g * nj + j) * 3 + a] = static_cast<float>(dyn.coms_m[f * nj + j][e]);
          sd->vel_own[(g * nj + j) * 3 + a] =
              static_cast<float>(dyn.com_velocities_mps[f * nj + j][e]);
        }
      kd_feature(sd->model, dyn.state(f), t_index, sd->kd_own.data() + g * s * 3);
    }
  });
  sd->kd = sd->kd_own.data();
  build_bound_tables(*sd);
  return sd;
}

// A clip's energy prefix sums for the skeleton's character.
std::span<const double> clip_prefix(const Index& index, const SkelData& sd, const ClipInfo& ci) {
  if (!sd.own_frames) return {sd.prefix_index + ci.frame_start, ci.frame_count};
  // Isolated: while waiting for its parallel_for, the thread inside call_once
  // must not pick up another clip task that would wait on the same flag.
  std::call_once(sd.prefix_once, [&] {
    tbb::this_task_arena::isolate([&] {
      const std::size_t nj = sd.model.joint_count();
      std::vector<double> out(sd.sk->frame_count, 0.0);
      const float* rot = index.array(sd.k, "frames", "world_rotations").f32.data();
      tbb::parallel_for(std::size_t{0}, sd.clips.size(), [&](std::size_t r) {
        const ClipInfo& c = sd.clips[r];
        std::vector<Eigen::Vector3d> p(c.frame_count * nj);
        std::vector<Eigen::Quaterniond> q(c.frame_count * nj);
        for (std::size_t i = 0; i < c.frame_count * nj; ++i) {
          const float* x = sd.pos_own.data() + (c.frame_start * nj + i) * 3;
          const float* w = rot + (c.frame_start * nj + i) * 4;
          p[i] = Eigen::Vector3d(x[0], x[1], x[2]);
          q[i] = Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized();
        }
        ClipDynamics dyn;
        compute_clip_dynamics(sd.model, c.frame_count, index.clips()[c.clip].frame_time_s, p.data(),
                              q.data(), dyn);
        const std::vector<double> pre = energy_prefix_sums(clip_step_energies(sd.model, dyn));
        std::copy(pre.begin(), pre.end(), out.begin() + static_cast<std::ptrdiff_t>(c.frame_start));
      });
      sd.prefix_own = std::move(out);
    });
  });
  return {sd.prefix_own.data() + ci.frame_start, ci.frame_count};
}

// The index's character from its `character` attribute: the indexer's
// canonical form (index_builder.cpp character_json: every map written out),
// or a character file's form; nullopt when neither parses (then every query
// character gets its own tables).
std::optional<Character> index_character(const Index& index) {
  const std::string& text = index.info().character_json;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.is_object() && j.contains("class_mass_kg")) {
      using Map = std::map<std::string, double>;
      Character c;
      c.name = j.at("name").get<std::string>();
      c.total_mass_kg = j.at("total_mass_kg").get<double>();
      c.sex = j.at("sex").get<std::string>() == "female" ? Sex::female : Sex::male;
      auto classes = [&](const char* key, std::map<SegmentClass, double>& out) {
        for (const auto& [name, v] : j.at(key).get<Map>()) {
          const auto cls = parse_segment_class(name);
          if (!cls)
            throw InputError(index.path().string(), 0, "character: unknown segment class " + name);
          out[*cls] = v;
        }
      };
      classes("class_mass_kg", c.class_mass_kg);
      classes("class_mass_scale", c.class_mass_scale);
      c.joint_mass_kg = j.at("joint_mass_kg").get<Map>();
      classes("class_length_scale", c.class_length_scale);
      c.joint_length_scale = j.at("joint_length_scale").get<Map>();
      return c;
    }
    return parse_character_json(text, index.path().string());
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace

namespace {
// Per-thread scratch, kept by the engine across queries (its buffers grow
// to the largest clip once instead of being allocated again for every query).
struct Scratch {
  std::vector<float> fbuf;
  std::vector<double> a, b, la, lb;
  std::vector<std::uint8_t> skip_a, skip_b;
  // eval_clip_blocks: per block suffix / prefix minima, needed blocks.
  std::vector<double> sb, pa;
  std::vector<std::uint8_t> need_a, need_b;
  // eval_clip_blocks: blocks the probe scanned, the computed side's running
  // minima, the second side's keys and its blocks in the order of them.
  std::vector<std::uint8_t> done_a, done_b;
  std::vector<double> run, key;
  std::vector<std::size_t> order;
  // Bounds of a clip's blocks.
  std::vector<double> blk_a, blk_b;
  std::vector<double> blk_pa;          // block_bounds_of: prefix minima of the a-side sketch bounds
  std::vector<std::uint8_t> blk_need;  // and the boxes needed (bit 0: a, bit 1: b)
  std::vector<Eigen::Quaterniond> mq, mf;  // partial bound: composite rotations
  std::vector<double> nq, nf;              // and their squared norms
  std::vector<float> lanes;                // partial_bounds_columns' per-slot lanes
  std::vector<double> subtree_lanes;       // subtree_energy's lane arrays
  // Database frames converted for partial_approximate_energy.
  std::vector<Eigen::Vector3d> pos, com, vel, angvel, zero, ltrans;
  std::vector<Eigen::Quaterniond> rot, lrot;
  BodyState state;
  HScanQuery shifted_scan;
  HScanRootQuery shifted_root;
  PartialQuery shifted_partial;
};
}  // namespace

struct SearchEngine::Impl {
  const Index* index = nullptr;
  double t_index = 0.5;
  std::vector<std::unique_ptr<SkelData>> skels;
  int content_key = -1, style_key = -1;
  mutable BvhCache bvh_cache;
  std::optional<Character> character;
  // Query characters other than the index's: tables built once, shared.
  struct CharacterTables {
    std::once_flag once;
    std::vector<std::unique_ptr<SkelData>> skels;
    std::string error;
  };
  mutable std::mutex characters_mutex;
  mutable std::map<std::string, std::shared_ptr<CharacterTables>> characters;
  // Used only between blocking points (no task of another query can run on
  // the thread while a reference to its scratch is held).
  mutable tbb::enumerable_thread_specific<Scratch> scratch;
};

SearchEngine::SearchEngine(const Index& index) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.index = &index;
  m.t_index = index.info().transition_time_s;
  for (std::size_t i = 0; i < index.label_keys().size(); ++i) {
    if (index.label_keys()[i] == "content") m.content_key = static_cast<int>(i);
    if (index.label_keys()[i] == "style") m.style_key = static_cast<int>(i);
  }
  m.character = index_character(index);
  // Query frames from indexed, unchanged files: only their +-2 frame window is parsed.
  m.bvh_cache.use_index(index);
  // Per skeleton, this thread reads the index arrays (HDF5, one reader at a
  // time) and a task builds the tables from them, so the next skeleton's
  // reading overlaps this one's building (TBB-parallel inside).
  const std::size_t nk = index.skeletons().size();
  m.skels.resize(nk);
  tbb::task_group builds;
  for (std::uint32_t k = 0; k < nk; ++k) {
    const IndexArray* rp = &index.array(k, "frames", "root_position_m");
    const double* prefix = index.array(k, "frames", "energy_prefix_J").f64.data();
    builds.run([&m, &index, k, rp, prefix] {
      auto sd = std::make_unique<SkelData>();
      init_skel_data(index, k, index.dynamics_model(k), *sd);
      const std::size_t n = sd->sk->frame_count, s = sd->segments;
      // h_scan [N][S][9] (one row per frame) -> field-major HScanTable, read
      // in blocks of rows (the array itself is not kept: 0.3 GB on set 2).
      const std::size_t stride = sd->table.stride;
      auto transpose = [&](std::uint64_t first, std::uint64_t count, const float* rows) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 2048),
                          [&](const tbb::blocked_range<std::size_t>& rg) {
                            for (std::size_t i = rg.begin(); i != rg.end(); ++i) {
                              const float* row = rows + i * s * 9;
                              const std::size_t f = first + i;
                              for (std::size_t b = 0; b < s; ++b)
                                for (std::size_t q = 0; q < 9; ++q)
                                  sd->table.values[(b * 9 + q) * stride + f] = row[b * 9 + q];
                            }
                          });
      };
      index.stream_rows(k, "frames", "h_scan", 8192, transpose);
      for (std::size_t f = 0; f < n; ++f)
        for (std::size_t a = 0; a < 3; ++a)
          sd->table.root_positions[a * stride + f] = rp->f32[f * 3 + a];
      sd->prefix_index = prefix;
      build_bound_tables(*sd);
      m.skels[k] = std::move(sd);
    });
  }
  builds.wait();
}

SearchEngine::SearchEngine(SearchEngine&&) noexcept = default;
SearchEngine::~SearchEngine() = default;
const Index& SearchEngine::index() const {
  return *impl_->index;
}

// ---------------------------------------------------------------------------
// Evaluation

namespace {

// Converts skeleton frame g into scratch (double) and returns its FrameRef.
// Only the joints in `need` are converted (all when it is empty); the local
// translations only for `local` (all when `need` is empty). The caller passes
// the joints partial_approximate_energy reads for its query
// (partial_needed_joints); the other entries are never read.
FrameRef frame_ref(const SkelData& sd, const FrameArrays& fa, std::size_t g, Scratch& sc,
                   const std::vector<int>& need, const std::vector<int>& local) {
  const std::size_t nj = sd.model.joint_count();
  if (sc.pos.size() != nj) {
    sc.pos.assign(nj, Eigen::Vector3d::Zero());
    sc.com.assign(nj, Eigen::Vector3d::Zero());
    sc.vel.assign(nj, Eigen::Vector3d::Zero());
    sc.angvel.assign(nj, Eigen::Vector3d::Zero());
    sc.zero.assign(nj, Eigen::Vector3d::Zero());
    sc.ltrans.assign(nj, Eigen::Vector3d::Zero());
    sc.rot.assign(nj, Eigen::Quaterniond::Identity());
    sc.lrot.assign(nj, Eigen::Quaterniond::Identity());
  }
  auto v3 = [](const float* p) { return Eigen::Vector3d(p[0], p[1], p[2]); };
  auto q4 = [](const float* p) { return Eigen::Quaterniond(p[0], p[1], p[2], p[3]).normalized(); };
  auto convert = [&](std::size_t j) {
    const std::size_t i = g * nj + j;
    sc.pos[j] = v3(fa.pos + i * 3);
    sc.com[j] = v3(fa.com + i * 3);
    sc.vel[j] = v3(fa.vel + i * 3);
    sc.angvel[j] = v3(fa.angvel + i * 3);
    sc.rot[j] = q4(fa.rot + i * 4);
    sc.lrot[j] = q4(fa.lrot + i * 4);
  };
  auto local_translation = [&](std::size_t j) {
    const int p = sd.model.parents[j];
    sc.ltrans[j] = p < 0 ? sc.pos[j]
                         : Eigen::Vector3d(sc.rot[static_cast<std::size_t>(p)].conjugate() *
                                           (sc.pos[j] - sc.pos[static_cast<std::size_t>(p)]));
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
  r.state.joint_positions_m = sc.pos.data();
  r.state.rotations = sc.rot.data();
  r.state.coms_m = sc.com.data();
  r.state.com_velocities_mps = sc.vel.data();
  r.state.com_accelerations_mps2 = sc.zero.data();
  r.state.angular_velocities_radps = sc.angvel.data();
  r.state.angular_accelerations_radps2 = sc.zero.data();
  r.local_translations_m = sc.ltrans.data();
  r.local_rotations = sc.lrot.data();
  return r;
}

void subtree_energy(const ResolvedFrame& q, const SkelData& sd, std::size_t g0, std::size_t g1,
                    double* out, Scratch& sc, const std::uint8_t* skip = nullptr);

// h(Q -> F) for skeleton frames [g0, g1) into out. With `shift` (relative
// mode) the query's given x/z root components are placed at shift (world).
void evaluate(const ResolvedFrame& q, const SkelData& sd, const Index& index, double t,
              std::size_t g0, std::size_t g1, double* out, Scratch& sc,
              const std::optional<Eigen::Vector2d>& xz = std::nullopt,
              const std::uint8_t* skip = nullptr, const HScanView* tile = nullptr) {
  const std::size_t n = g1 - g0;
  if (n == 0) return;
  // A whole block in world mode: scan its tile (same values, contiguous).
  const HScanView table = tile != nullptr && !xz ? *tile : sd.table.view();
  const std::size_t b0 = tile != nullptr && !xz ? 0 : g0;
  if (q.kind == FrameKind::full || q.kind == FrameKind::root_only) {
    sc.fbuf.resize(n);
    if (q.kind == FrameKind::full) {
      const HScanQuery* sq = &q.scan;
      if (xz) {
        sc.shifted_scan = q.scan;
        const double dx = (*xz)[0] - q.root_m[0], dz = (*xz)[1] - q.root_m[2];
        for (std::size_t b = 0; b < sc.shifted_scan.segment_count; ++b) {
          sc.shifted_scan.constants[b * HScanQuery::kConstants + 0] = static_cast<float>(
              q.state.coms_m[static_cast<std::size_t>(sd.model.segments[b])][0] + dx);
          sc.shifted_scan.constants[b * HScanQuery::kConstants + 2] = static_cast<float>(
              q.state.coms_m[static_cast<std::size_t>(sd.model.segments[b])][2] + dz);
        }
        sq = &sc.shifted_scan;
      }
      scan_approximate_energy(table, *sq, b0, b0 + n, sc.fbuf.data());
    } else {
      const HScanRootQuery* rq = &q.root_scan;
      if (xz) {
        sc.shifted_root = q.root_scan;
        if (q.given[0]) sc.shifted_root.position[0] = static_cast<float>((*xz)[0]);
        if (q.given[2]) sc.shifted_root.position[2] = static_cast<float>((*xz)[1]);
        rq = &sc.shifted_root;
      }
      scan_root_translation_energy(table, *rq, b0, b0 + n, sc.fbuf.data());
    }
    for (std::size_t i = 0; i < n; ++i) out[i] = sc.fbuf[i];
    return;
  }
  const PartialQuery* pq = &q.partial;
  if (xz && (q.given[0] || q.given[2])) {
    sc.shifted_partial = q.partial;
    if (q.given[0]) sc.shifted_partial.spec.root_position_m[0] = (*xz)[0];
    if (q.given[2]) sc.shifted_partial.spec.root_position_m[2] = (*xz)[1];
    pq = &sc.shifted_partial;
  }
  if (!q.subtree.empty()) {  // joint rotations only: no root component to shift
    subtree_energy(q, sd, g0, g1, out, sc, skip);
    return;
  }
  const FrameArrays& fa = frame_arrays(index, sd);
  for (std::size_t i = 0; i < n; ++i) {
    if (skip != nullptr && skip[i]) continue;
    const FrameRef r = frame_ref(sd, fa, g0 + i, sc, q.need_joints, q.local_joints);
    out[i] = partial_approximate_energy(sd.model, *pq, r, t, sc.state);
  }
}

// ---------------------------------------------------------------------------
// Per-frame lower bound of h(Q_F -> F) for partial query frames (heading or
// joint rotations); docs/search.md "Partial queries" proves it.

struct PartialBoundPlan {
  bool whole = false;               // root position / heading given: every segment is static in Q_F
  std::vector<std::size_t> segs;    // affected segments (model.segments index)
  std::vector<double> rot_coef;     // per listed segment: 1/2 lambda_min / T^2 (slightly reduced)
  std::vector<std::uint8_t> turns;  // per listed segment: rotated by the heading turn
  std::vector<int> sub_slot;  // per listed segment: slot in sub_joints whose angle applies, -1
  bool heading = false;
  double psi_q = 0.0;
  // Joint-rotation subtrees (not whole-body): composite rotations per slot.
  std::vector<int> sub_joints, sub_parent_slot;
  std::vector<const Eigen::Quaterniond*> sub_given;  // the query's local rotation, null if F's
  // Per slot: the query's composite rotation and its squared norm when every
  // joint from the subtree's top down to the slot is given (the same for all
  // frames), else not fixed.
  std::vector<std::uint8_t> mq_fixed;
  std::vector<Eigen::Quaterniond> mq;
  std::vector<double> nq;
  // Per listed segment whose joint tops a given subtree (its parent is F's,
  // its rotation given): the parent joint, else -1; COM offset, m g, m / (2 T^2).
  // Its translational term is computed exactly (subtree_energy's arithmetic).
  std::vector<int> top_parent;
  std::vector<Eigen::Vector3d> top_com;
  std::vector<double> top_mg, top_mh;
  // Whole-body COM term (no joint rotations): root position components.
  bool com_term = false;
  std::array<bool, 3> given{false, false, false};
  Eigen::Vector3d root_q = Eigen::Vector3d::Zero();
  double mass = 0.0, gravity = 0.0, half_inv_t2 = 0.0;
  // Joint rotations only (not whole): the same bound in float from per-joint
  // columns (attach_columns, partial_bounds_columns); empty otherwise.
  struct ColumnSlot {
    // F's local rotation column of the slot's joint; null: not computed.
    const float* lrot = nullptr;
    int parent = -1;              // parent slot, -1 at the top of a subtree
    // The query's composite: 0 fixed (mq), 1 the parent's times the given
    // local rotation, 2 the parent's times F's.
    std::uint8_t mq_mode = 0;
    std::array<float, 4> given{};  // the given local rotation (w x y z), its squared norm
    float ngiven = 0.0f;
    std::array<float, 4> mq{};  // the fixed composite, its squared norm
    float nq = 0.0f;
  };
  struct ColumnSegment {
    const float *kb = nullptr, *kr = nullptr;  // scan-table fields 3 and 8
    float rot_coef = 0.0f;
    std::size_t slot = 0;
    // A subtree's top segment (its translational term): its parent's world
    // rotation column, the COM offset c and L_Q c (L_Q the given local
    // rotation), m g, m / (2 T^2).
    bool top = false;
    const float* parent_rot = nullptr;
    std::array<float, 3> c{}, lq_c{};
    float mg = 0.0f, mh = 0.0f;
  };
  std::vector<ColumnSlot> col_slots;
  std::vector<ColumnSegment> col_segs;
  std::size_t col_stride = 0;
};

PartialBoundPlan make_partial_bound_plan(const ResolvedFrame& q, const SkelData& sd, double t) {
  PartialBoundPlan p;
  const PartialQuery& pq = q.partial;
  const DynamicsModel& model = sd.model;
  const std::size_t nj = model.joint_count();
  const auto root = static_cast<std::size_t>(model.root());
  p.whole = pq.moves_whole_body;
  p.half_inv_t2 = 0.5 / (t * t);
  p.mass = sd.segment_mass;
  p.gravity = model.params.gravity_mps2;
  p.heading = pq.spec.root_heading_rad.has_value() && pq.in_subtree[root] == 0;
  if (p.heading) p.psi_q = *pq.spec.root_heading_rad;
  std::vector<int> slot(nj, -1);
  if (!p.whole) {
    for (int jj : pq.subtree_joints) {
      const auto j = static_cast<std::size_t>(jj);
      slot[j] = static_cast<int>(p.sub_joints.size());
      p.sub_joints.push_back(jj);
      const int par = model.parents[j];
      p.sub_parent_slot.push_back(par >= 0 ? slot[static_cast<std::size_t>(par)] : -1);
      const int gi = pq.given_rotation[j];
      p.sub_given.push_back(gi >= 0 ? &pq.spec.joint_rotations[static_cast<std::size_t>(gi)].second
                                    : nullptr);
      const int ps = p.sub_parent_slot.back();
      const bool fixed = gi >= 0 && (ps < 0 || p.mq_fixed[static_cast<std::size_t>(ps)] != 0);
      p.mq_fixed.push_back(fixed);
      p.mq.push_back(!fixed ? Eigen::Quaterniond::Identity()
                            : (ps < 0 ? *p.sub_given.back()
                                      : p.mq[static_cast<std::size_t>(ps)] * *p.sub_given.back()));
      p.nq.push_back(p.mq.back().coeffs().squaredNorm());
    }
  }
  for (std::size_t s = 0; s < sd.segments; ++s) {
    const auto j = static_cast<std::size_t>(model.segments[s]);
    if (!pq.affected[j]) continue;
    p.segs.push_back(s);
    // lambda_min from an eigen-solver: shave a relative 1e-6 off for its rounding.
    p.rot_coef.push_back(sd.lambda_min[s] * (1.0 - 1e-6) * p.half_inv_t2);
    p.turns.push_back(p.whole && p.heading && pq.in_subtree[j] == 0);
    p.sub_slot.push_back(p.whole ? -1 : slot[j]);
    const int sl = p.whole ? -1 : slot[j];
    const bool top = sl >= 0 && p.sub_parent_slot[static_cast<std::size_t>(sl)] < 0 &&
                     p.sub_given[static_cast<std::size_t>(sl)] != nullptr && model.parents[j] >= 0;
    p.top_parent.push_back(top ? model.parents[j] : -1);
    p.top_com.push_back(model.coms_local_m[j]);
    p.top_mg.push_back(model.masses_kg[j] * model.params.gravity_mps2);
    p.top_mh.push_back(model.masses_kg[j] * p.half_inv_t2);
  }
  p.com_term = p.whole && pq.subtree_joints.empty();
  for (std::size_t a = 0; a < 3; ++a) {
    p.given[a] = pq.spec.root_position_m[a].has_value();
    if (p.given[a]) p.root_q[static_cast<Eigen::Index>(a)] = *pq.spec.root_position_m[a];
  }
  return p;
}

// For a plan of joint rotations only: the columns and float constants
// partial_bounds_columns reads (the frame columns are streamed on first use).
void attach_columns(PartialBoundPlan& p, const SkelData& sd, const Index& index) {
  if (p.whole || p.heading || p.com_term || p.sub_joints.empty()) return;
  // A subtree's top joint is given (the subtrees are those of given joints),
  // and every listed segment lies in a subtree: else the reference serves.
  for (std::size_t t = 0; t < p.sub_joints.size(); ++t)
    if (p.sub_parent_slot[t] < 0 && !p.mq_fixed[t]) return;
  for (int sl : p.sub_slot)
    if (sl < 0) return;
  const HScanTable& tb = sd.table;
  auto f4 = [](const Eigen::Quaterniond& q) {
    return std::array<float, 4>{static_cast<float>(q.w()), static_cast<float>(q.x()),
                                static_cast<float>(q.y()), static_cast<float>(q.z())};
  };
  // A slot whose local rotation is F's in Q_F as well (neither given nor
  // below a given one on its chain: mode 2) has its parent slot's angle, as
  // right-multiplying both composites by the same rotation keeps the angle
  // between them (and scales the inner product and both squared norms by
  // |l|^2): it is computed only where a slot below needs its composites.
  const std::size_t ns = p.sub_joints.size();
  std::vector<std::uint8_t> needed(ns, 0);
  for (std::size_t t = ns; t-- > 0;) {
    needed[t] = needed[t] || p.mq_fixed[t] || p.sub_given[t] != nullptr;
    if (needed[t] && p.sub_parent_slot[t] >= 0)
      needed[static_cast<std::size_t>(p.sub_parent_slot[t])] = 1;
  }
  std::vector<std::size_t> lrot_joints, rot_joints;
  for (std::size_t t = 0; t < ns; ++t)
    if (needed[t]) lrot_joints.push_back(static_cast<std::size_t>(p.sub_joints[t]));
  for (int par : p.top_parent)
    if (par >= 0) rot_joints.push_back(static_cast<std::size_t>(par));
  ensure_columns(index, sd, JointColumn::local_rotation, lrot_joints);
  ensure_columns(index, sd, JointColumn::world_rotation, rot_joints);
  for (std::size_t t = 0; t < ns; ++t) {
    PartialBoundPlan::ColumnSlot c;
    if (needed[t])
      c.lrot =
          joint_column(sd, JointColumn::local_rotation, static_cast<std::size_t>(p.sub_joints[t]));
    c.parent = p.sub_parent_slot[t];
    c.mq_mode = p.mq_fixed[t] ? 0 : p.sub_given[t] != nullptr ? 1 : 2;
    if (p.sub_given[t] != nullptr) {
      c.given = f4(*p.sub_given[t]);
      c.ngiven = static_cast<float>(p.sub_given[t]->coeffs().squaredNorm());
    }
    c.mq = f4(p.mq[t]);
    c.nq = static_cast<float>(p.nq[t]);
    p.col_slots.push_back(c);
  }
  for (std::size_t i = 0; i < p.segs.size(); ++i) {
    const std::size_t s = p.segs[i];
    PartialBoundPlan::ColumnSegment c;
    c.kb = tb.field(s, 3);
    c.kr = tb.field(s, 8);
    c.rot_coef = static_cast<float>(p.rot_coef[i]);
    c.slot = static_cast<std::size_t>(p.sub_slot[i]);
    while (!needed[c.slot]) c.slot = static_cast<std::size_t>(p.sub_parent_slot[c.slot]);
    c.top = p.top_parent[i] >= 0;
    if (c.top) {
      // The top joint's slot is given and fixed: its F composite is F's local rotation.
      c.parent_rot =
          joint_column(sd, JointColumn::world_rotation, static_cast<std::size_t>(p.top_parent[i]));
      const Eigen::Vector3d lqc = p.sub_given[c.slot]->normalized() * p.top_com[i];
      for (std::size_t a = 0; a < 3; ++a) {
        c.c[a] = static_cast<float>(p.top_com[i][static_cast<Eigen::Index>(a)]);
        c.lq_c[a] = static_cast<float>(lqc[static_cast<Eigen::Index>(a)]);
      }
      c.mg = static_cast<float>(p.top_mg[i]);
      c.mh = static_cast<float>(p.top_mh[i]);
    }
    p.col_segs.push_back(c);
  }
  p.col_stride = sd.col_stride;
}

// A lower bound of theta^2, theta in [0, pi] the angle between the rotations
// of two non-zero quaternions x, y with squared norms nx, ny: with
// d = |<x, y>| / (|x| |y|) = cos(theta / 2), 1 - d^2 = sin^2(theta / 2) and
// sin t <= t give theta^2 >= 4 (1 - d^2) (no acos, no square root).
double quat_angle_sq_lower(const Eigen::Quaterniond& x, double nx, const Eigen::Quaterniond& y,
                           double ny) {
  const double c = x.coeffs().dot(y.coeffs());
  return 4.0 * std::max(0.0, 1.0 - c * c / (nx * ny));
}

// The translational h term of scan-table segment b of frame g against a
// static A (K_A = 0) whose segment COM is ca: m g |d_y| + dK(0, K_u, K_B) =
// m g |d_y| + max(K_B, 2 K_u - K_B), K_u = m / (2 T^2) |c_B - ca|^2 (mh the
// last factor, K_B >= 0). The subtree kernel and the partial bound's top
// segments both add it, so the bound is that very value.
double static_translation_h(const HScanTable& tb, std::size_t b, std::size_t g,
                            const Eigen::Vector3d& ca, double mg, double mh) {
  const double dx = static_cast<double>(tb.field(b, 0)[g]) - ca.x();
  const double dy = static_cast<double>(tb.field(b, 1)[g]) - ca.y();
  const double dz = static_cast<double>(tb.field(b, 2)[g]) - ca.z();
  const double ku = mh * (dx * dx + dy * dy + dz * dz);
  const double kb = tb.field(b, 3)[g];
  return mg * std::abs(dy) + std::max(kb, 2.0 * ku - kb);
}

constexpr double kAngleSlack = 1e-4;     // rad: float32 storage and FK rounding of the angles
constexpr std::size_t kBoundLanes = 64;  // frames per pass of partial_bounds_columns

// partial_frame_bounds_reference's bound for a plan with columns (joint
// rotations only), in float, kBoundLanes frames at a time: the composite
// rotations of every slot for those frames, then each segment's terms, loop
// by loop over the frames (vectorised: AVX-512, AVX2 or SSE clone). The
// same formulas; the float roundings (relative ~1e-6, far below the angle
// slack and the engine's comparison slack, LB (1 - 1e-4) - 1e-3 J) are
// covered as in the box and sketch bounds. `lanes`: 10 kBoundLanes floats
// per slot, scratch.
MOCAP_SEARCH_MULTIVERSION
void partial_bounds_columns(const PartialBoundPlan& p, std::size_t g0, std::size_t g1, double* out,
                            float* lanes) {
  constexpr std::size_t W = kBoundLanes;
  constexpr std::size_t kSlot = 10 * W;  // mf (4 W), nf (W), mq (4 W), nq (W)
  const std::size_t cs = p.col_stride;
  const float slack2 = static_cast<float>(2.0 * std::numbers::pi * kAngleSlack);
  alignas(64) float acc[W];
  for (std::size_t g = g0; g < g1; g += W) {
    const std::size_t n = std::min(W, g1 - g);
    for (std::size_t t = 0; t < p.col_slots.size(); ++t) {
      const PartialBoundPlan::ColumnSlot& sl = p.col_slots[t];
      if (sl.lrot == nullptr) continue;
      float* __restrict mf = lanes + t * kSlot;
      float* __restrict nf = mf + 4 * W;
      float* __restrict mq = mf + 5 * W;
      float* __restrict nq = mf + 9 * W;
      const float* __restrict lw = sl.lrot + g;
      const float* __restrict lx = lw + cs;
      const float* __restrict ly = lw + 2 * cs;
      const float* __restrict lz = lw + 3 * cs;
      if (sl.parent < 0) {
        for (std::size_t i = 0; i < n; ++i) {
          mf[i] = lw[i];
          mf[W + i] = lx[i];
          mf[2 * W + i] = ly[i];
          mf[3 * W + i] = lz[i];
          nf[i] = lw[i] * lw[i] + lx[i] * lx[i] + ly[i] * ly[i] + lz[i] * lz[i];
        }
      } else {
        const float* __restrict pf = lanes + static_cast<std::size_t>(sl.parent) * kSlot;
        for (std::size_t i = 0; i < n; ++i) {
          const float aw = pf[i], ax = pf[W + i], ay = pf[2 * W + i], az = pf[3 * W + i];
          const float bw = lw[i], bx = lx[i], by = ly[i], bz = lz[i];
          mf[i] = aw * bw - ax * bx - ay * by - az * bz;
          mf[W + i] = aw * bx + ax * bw + ay * bz - az * by;
          mf[2 * W + i] = aw * by - ax * bz + ay * bw + az * bx;
          mf[3 * W + i] = aw * bz + ax * by - ay * bx + az * bw;
          nf[i] = pf[4 * W + i] * (bw * bw + bx * bx + by * by + bz * bz);
        }
      }
      if (sl.mq_mode == 0) {
        for (std::size_t i = 0; i < n; ++i) {
          mq[i] = sl.mq[0];
          mq[W + i] = sl.mq[1];
          mq[2 * W + i] = sl.mq[2];
          mq[3 * W + i] = sl.mq[3];
          nq[i] = sl.nq;
        }
      } else {
        // The parent's composite times the given local rotation or F's.
        const float* __restrict pq = lanes + static_cast<std::size_t>(sl.parent) * kSlot + 5 * W;
        const bool given = sl.mq_mode == 1;
        for (std::size_t i = 0; i < n; ++i) {
          const float aw = pq[i], ax = pq[W + i], ay = pq[2 * W + i], az = pq[3 * W + i];
          const float bw = given ? sl.given[0] : lw[i], bx = given ? sl.given[1] : lx[i],
                      by = given ? sl.given[2] : ly[i], bz = given ? sl.given[3] : lz[i];
          mq[i] = aw * bw - ax * bx - ay * by - az * bz;
          mq[W + i] = aw * bx + ax * bw + ay * bz - az * by;
          mq[2 * W + i] = aw * by - ax * bz + ay * bw + az * bx;
          mq[3 * W + i] = aw * bz + ax * by - ay * bx + az * bw;
          nq[i] = pq[4 * W + i] * (given ? sl.ngiven : bw * bw + bx * bx + by * by + bz * bz);
        }
      }
    }
    for (std::size_t i = 0; i < W; ++i) acc[i] = 0.0f;
    for (const PartialBoundPlan::ColumnSegment& sg : p.col_segs) {
      const float* __restrict mf = lanes + sg.slot * kSlot;
      const float* __restrict nf = mf + 4 * W;
      const float* __restrict mq = mf + 5 * W;
      const float* __restrict nq = mf + 9 * W;
      const float* __restrict kr = sg.kr + g;
      const float* __restrict kb = sg.kb + g;
      for (std::size_t i = 0; i < n; ++i) {
        // quat_angle_sq_lower, then the rotational term as the reference.
        const float c = mq[i] * mf[i] + mq[W + i] * mf[W + i] + mq[2 * W + i] * mf[2 * W + i] +
                        mq[3 * W + i] * mf[3 * W + i];
        const float theta2 = 4.0f * std::max(0.0f, 1.0f - c * c / (nq[i] * nf[i]));
        const float ku = sg.rot_coef * std::max(0.0f, theta2 - slack2);
        acc[i] += std::max(kr[i], 2.0f * ku - kr[i]);
      }
      if (!sg.top) {
        for (std::size_t i = 0; i < n; ++i) acc[i] += kb[i];
        continue;
      }
      // static_translation_h with Q_F's COM x_j(F) + R_p(F) L_Q c against F's
      // x_j(F) + R_p(F) L_F c: d = R_p (L_F c - L_Q c), so |d| = |L_F c - L_Q c|,
      // and d_y needs R_p's rotation of that vector. L_F is the top slot's F
      // composite (mf, unnormalised: v = q c q* / |q|^2), R_p unnormalised too.
      // The stored COM and joint position agree with this to float rounding
      // (~1e-6 m, ~1e-5 J here), covered by the engine's comparison slack.
      const float* __restrict rw = sg.parent_rot + g;
      const float* __restrict rx = rw + cs;
      const float* __restrict ry = rw + 2 * cs;
      const float* __restrict rz = rw + 3 * cs;
      const float ox = sg.c[0], oy = sg.c[1], oz = sg.c[2];
      for (std::size_t i = 0; i < n; ++i) {
        const float qw = mf[i], qx = mf[W + i], qy = mf[2 * W + i], qz = mf[3 * W + i];
        const float uu = qx * qx + qy * qy + qz * qz;
        const float uc = qx * ox + qy * oy + qz * oz;
        const float k0 = qw * qw - uu;
        const float inv = 1.0f / nf[i];
        const float ex =
            (k0 * ox + 2.0f * uc * qx + 2.0f * qw * (qy * oz - qz * oy)) * inv - sg.lq_c[0];
        const float ey =
            (k0 * oy + 2.0f * uc * qy + 2.0f * qw * (qz * ox - qx * oz)) * inv - sg.lq_c[1];
        const float ez =
            (k0 * oz + 2.0f * uc * qz + 2.0f * qw * (qx * oy - qy * ox)) * inv - sg.lq_c[2];
        const float aw = rw[i], ax = rx[i], ay = ry[i], az = rz[i];
        const float ae = ax * ex + ay * ey + az * ez;
        const float dy = ((aw * aw - (ax * ax + ay * ay + az * az)) * ey + 2.0f * ae * ay +
                          2.0f * aw * (az * ex - ax * ez)) /
                         (aw * aw + ax * ax + ay * ay + az * az);
        const float ku = sg.mh * (ex * ex + ey * ey + ez * ez);
        acc[i] += sg.mg * std::fabs(dy) + std::max(kb[i], 2.0f * ku - kb[i]);
      }
    }
    for (std::size_t i = 0; i < n; ++i) out[g - g0 + i] = static_cast<double>(acc[i]);
  }
}

// Lower bound of h(Q_F -> F) for skeleton frames [g0, g1) into out, in
// double from the frame arrays (every kind of partial frame; the reference
// for partial_bounds_columns).
void partial_frame_bounds_reference(const PartialBoundPlan& p, const SkelData& sd,
                                    const FrameArrays& fa, std::size_t g0, std::size_t g1,
                                    double* out, Scratch& sc) {
  const HScanTable& tb = sd.table;
  const std::size_t nj = sd.model.joint_count();
  const auto root = static_cast<std::size_t>(sd.model.root());
  sc.mq.resize(p.sub_joints.size());
  sc.mf.resize(p.sub_joints.size());
  sc.nq.resize(p.sub_joints.size());
  sc.nf.resize(p.sub_joints.size());
  // The frame arrays hold all joints of a frame together (stride nj): the
  // rows a few frames ahead are prefetched (the hardware prefetcher falls
  // behind on this stride: the loads took about a quarter of the pass; 8
  // frames ahead measured about 10 % faster on arm queries, 24 no better).
  constexpr std::size_t kAhead = 8;
  const std::size_t first_joint =
      p.sub_joints.empty() ? 0 : static_cast<std::size_t>(p.sub_joints.front());
  for (std::size_t g = g0; g < g1; ++g) {
    if (!p.sub_joints.empty() && g + kAhead < g1) {
      __builtin_prefetch(fa.lrot + ((g + kAhead) * nj + first_joint) * 4);
      for (std::size_t i = 0; i < p.segs.size(); ++i)
        if (p.top_parent[i] >= 0) {
          const auto j = static_cast<std::size_t>(sd.model.segments[p.segs[i]]);
          __builtin_prefetch(fa.rot +
                             ((g + kAhead) * nj + static_cast<std::size_t>(p.top_parent[i])) * 4);
          __builtin_prefetch(fa.pos + ((g + kAhead) * nj + j) * 3);
        }
    }
    for (std::size_t t = 0; t < p.sub_joints.size(); ++t) {
      const float* l = fa.lrot + (g * nj + static_cast<std::size_t>(p.sub_joints[t])) * 4;
      // Not normalised: the angle bound divides by the squared norms (which multiply).
      const Eigen::Quaterniond lf(static_cast<double>(l[0]), static_cast<double>(l[1]),
                                  static_cast<double>(l[2]), static_cast<double>(l[3]));
      const double nlf = lf.coeffs().squaredNorm();
      const int ps = p.sub_parent_slot[t];
      // Slot t's composite rotation (and squared norm): its parent slot's times
      // the local one, or the local one at the top of a subtree.
      auto chain = [&](std::vector<Eigen::Quaterniond>& m, std::vector<double>& nm,
                       const Eigen::Quaterniond& local, double nlocal) {
        if (ps < 0) {
          m[t] = local;
          nm[t] = nlocal;
        } else {
          m[t] = m[static_cast<std::size_t>(ps)] * local;
          nm[t] = nm[static_cast<std::size_t>(ps)] * nlocal;
        }
      };
      chain(sc.mf, sc.nf, lf, nlf);
      if (p.mq_fixed[t]) {
        sc.mq[t] = p.mq[t];
        sc.nq[t] = p.nq[t];
      } else if (p.sub_given[t] != nullptr) {
        chain(sc.mq, sc.nq, *p.sub_given[t], p.sub_given[t]->coeffs().squaredNorm());
      } else {
        chain(sc.mq, sc.nq, lf, nlf);
      }
    }
    double turn = 0.0;
    if (p.heading) {
      const float* r = fa.rot + (g * nj + root) * 4;
      const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
      turn = std::fmod(std::abs(p.psi_q - heading_rad(rr)), 2.0 * std::numbers::pi);
      if (turn > std::numbers::pi) turn = 2.0 * std::numbers::pi - turn;
    }
    double kt = 0.0, rot = 0.0;
    for (std::size_t i = 0; i < p.segs.size(); ++i) {
      const std::size_t s = p.segs[i];
      if (p.top_parent[i] >= 0) {
        // Q_F's COM: F's joint position + R_p(F) L_Q c (as subtree_energy computes it).
        const auto j = static_cast<std::size_t>(sd.model.segments[s]);
        const float* r = fa.rot + (g * nj + static_cast<std::size_t>(p.top_parent[i])) * 4;
        const float* x = fa.pos + (g * nj + j) * 3;
        const Eigen::Quaterniond rq = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized() *
                                      *p.sub_given[static_cast<std::size_t>(p.sub_slot[i])];
        const Eigen::Vector3d ca = Eigen::Vector3d(x[0], x[1], x[2]) + rq * p.top_com[i];
        kt += static_translation_h(tb, s, g, ca, p.top_mg[i], p.top_mh[i]);
      } else {
        kt += static_cast<double>(tb.field(s, 3)[g]);
      }
      const double kr = tb.field(s, 8)[g];
      // (theta - s)^2 >= theta^2 - 2 pi s for theta in [0, pi], s the slack.
      double theta2 = 0.0;
      if (p.turns[i]) {
        theta2 = turn * turn;
      } else if (p.sub_slot[i] >= 0) {
        const auto t = static_cast<std::size_t>(p.sub_slot[i]);
        theta2 = quat_angle_sq_lower(sc.mq[t], sc.nq[t], sc.mf[t], sc.nf[t]);
      }
      const double ku =
          p.rot_coef[i] * std::max(0.0, theta2 - 2.0 * std::numbers::pi * kAngleSlack);
      rot += std::max(kr, 2.0 * ku - kr);
    }
    double trans = kt;
    if (p.com_term) {
      // Whole-body COM c (segments): Q_F is F turned about the vertical
      // through the root, then shifted on the given axes.
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (std::size_t s = 0; s < sd.segments; ++s)
        for (std::size_t a = 0; a < 3; ++a)
          c[static_cast<Eigen::Index>(a)] += sd.masses[s] * static_cast<double>(tb.field(s, a)[g]);
      c /= p.mass;
      const Eigen::Vector3d root_f(tb.root_positions[g], tb.root_positions[tb.stride + g],
                                   tb.root_positions[2 * tb.stride + g]);
      Eigen::Vector3d v = c - root_f;
      if (p.heading) {
        const float* r = fa.rot + (g * nj + root) * 4;
        const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
        v = Eigen::AngleAxisd(p.psi_q - heading_rad(rr), Eigen::Vector3d::UnitY()) * v;
      }
      Eigen::Vector3d cq = root_f + v;
      for (std::size_t a = 0; a < 3; ++a)
        if (p.given[a])
          cq[static_cast<Eigen::Index>(a)] +=
              p.root_q[static_cast<Eigen::Index>(a)] - root_f[static_cast<Eigen::Index>(a)];
      const Eigen::Vector3d d = cq - c;
      trans = std::max(kt, p.mass * d.squaredNorm() * p.half_inv_t2) +
              p.mass * p.gravity * std::abs(d.y());
    }
    out[g - g0] = trans + rot;
  }
}

// Lower bound of h(Q_F -> F) for skeleton frames [g0, g1) into out: from
// the columns where the plan has them (attach_columns), else the reference
// (fa: the frame arrays, frame_arrays).
void partial_frame_bounds(const PartialBoundPlan& p, const SkelData& sd, const FrameArrays* fa,
                          std::size_t g0, std::size_t g1, double* out, Scratch& sc) {
  if (p.col_segs.empty()) {
    partial_frame_bounds_reference(p, sd, *fa, g0, g1, out, sc);
    return;
  }
  sc.lanes.resize(p.col_slots.size() * 10 * kBoundLanes);
  partial_bounds_columns(p, g0, g1, out, sc.lanes.data());
}

// The joints partial_approximate_energy reads of a database frame (frame_ref).
void set_needed_joints(ResolvedFrame& q, const DynamicsModel& model) {
  q.need_joints.clear();
  q.local_joints.clear();
  if (q.kind != FrameKind::partial || q.partial.moves_whole_body) return;
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

// Prepares q.subtree / q.subtree_segments for partial frames that give
// joint rotations only (docs/search.md "Joint-rotation frames"), with the
// frame-array columns subtree_energy reads (loaded on first use).
void set_subtree_plan(ResolvedFrame& q, const SkelData& sd, const Index& index, double t) {
  q.subtree.clear();
  q.subtree_segments.clear();
  if (q.kind != FrameKind::partial || q.partial.moves_whole_body ||
      q.partial.subtree_joints.empty())
    return;
  const DynamicsModel& model = sd.model;
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
  ensure_columns(index, sd, JointColumn::world_rotation, rot_joints);
  ensure_columns(index, sd, JointColumn::local_rotation, lrot_joints);
  ensure_columns(index, sd, JointColumn::position, pos_joints);
  for (ResolvedFrame::SubtreeJoint& sj : q.subtree) {
    sj.parent_rot = joint_column(sd, JointColumn::world_rotation, sj.parent);
    if (!sj.given) sj.lrot = joint_column(sd, JointColumn::local_rotation, sj.joint);
    sj.pos = joint_column(sd, JointColumn::position, sj.joint);
    if (sj.parent_slot >= 0) sj.parent_pos = joint_column(sd, JointColumn::position, sj.parent);
  }
  const double half_inv_t2 = 0.5 / (t * t);
  for (int jj : pq.affected_joints) {
    const auto j = static_cast<std::size_t>(jj);
    if (!(model.masses_kg[j] > 0.0) || slot[j] < 0 || sd.segment_of_joint[j] < 0) continue;
    ResolvedFrame::SubtreeSegment sg;
    sg.slot = static_cast<std::size_t>(slot[j]);
    sg.segment = static_cast<std::size_t>(sd.segment_of_joint[j]);
    sg.mg = model.masses_kg[j] * model.params.gravity_mps2;
    sg.mh = model.masses_kg[j] * half_inv_t2;
    sg.com_local = model.coms_local_m[j];
    sg.principal = model.principal_frames[j];
    for (int k = 0; k < 3; ++k)
      sg.d[static_cast<std::size_t>(k)] = model.principal_moments_kgm2[j][k] * half_inv_t2;
    q.subtree_segments.push_back(sg);
  }
}

// h(Q_F -> F) for skeleton frames [g0, g1) of a partial frame with a subtree
// plan (joint rotations only), in double: forward kinematics of the given
// subtrees on F's stored pose (as complete_partial_query), then per segment
// of the subtrees the h-scan formula with a static A (K_A = K_A^rot = 0)
// against F's scan-table fields (COM, KE, principal orientation, KE_rot).
// Frames with skip[i] != 0 are left alone. docs/search.md "Joint-rotation
// frames"; test Search.SubtreeEnergyEqualsPartialEnergySet1.
//
// Vectorised over frames: kSubtreeLanes frames at a time, every input copied
// into lane arrays first (a short last group padded with identity poses), so
// that every frame takes the same instructions wherever it falls (the value
// of a frame does not depend on the range it is evaluated in: exact and
// brute stay bit-identical). `lanes`: subtree_lane_doubles(q) doubles.
constexpr std::size_t kSubtreeLanes = 16;
std::size_t subtree_lane_doubles(const ResolvedFrame& q) {
  return (q.subtree.size() * 7 + 24) * kSubtreeLanes;
}

MOCAP_SEARCH_MULTIVERSION
void subtree_energy_lanes(const ResolvedFrame& q, const SkelData& sd, std::size_t g0,
                          std::size_t g1, double* out, double* lanes, const std::uint8_t* skip) {
  constexpr std::size_t W = kSubtreeLanes;
  const std::size_t cs = sd.col_stride;
  const HScanTable& tb = sd.table;
  const std::size_t ns = q.subtree.size();
  // Per slot: the joint's position (3 W) and world rotation (4 W) in Q_F;
  // then scratch rows: the parent's rotation (4 W), the local rotation (4 W),
  // two positions (6 W), the table fields of a segment (9 W), the total (W).
  double* const pr = lanes + ns * 7 * W;
  double* const lr = pr + 4 * W;
  double* const p0 = lr + 4 * W;
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
      load(sj.parent_rot, cs, 4, g, n, pr, kIdentity);
      if (sj.given) {
        const Eigen::Quaterniond& l = sj.local;
        for (std::size_t i = 0; i < W; ++i) {
          lr[i] = l.w();
          lr[W + i] = l.x();
          lr[2 * W + i] = l.y();
          lr[3 * W + i] = l.z();
        }
      } else {
        load(sj.lrot, cs, 4, g, n, lr, kIdentity);
      }
      for (double* qv : {pr, lr}) {
        if (qv == lr && sj.given) break;
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
        qmul(pr, lr, r);
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
          const double w = pr[i], ux = -pr[W + i], uy = -pr[2 * W + i], uz = -pr[3 * W + i];
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
        qmul(rp, lr, r);
      }
    }
    for (std::size_t i = 0; i < W; ++i) total[i] = 0.0;
    for (const ResolvedFrame::SubtreeSegment& sg : q.subtree_segments) {
      const double* const x = lanes + sg.slot * 7 * W;
      const double* const r = x + 3 * W;
      const std::size_t b = sg.segment;
      for (std::size_t k = 0; k < HScanTable::kFields; ++k) {
        const float* src = tb.field(b, k) + g;
        for (std::size_t i = 0; i < n; ++i) fld[k * W + i] = static_cast<double>(src[i]);
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

void subtree_energy(const ResolvedFrame& q, const SkelData& sd, std::size_t g0, std::size_t g1,
                    double* out, Scratch& sc, const std::uint8_t* skip) {
  sc.subtree_lanes.resize(subtree_lane_doubles(q));
  subtree_energy_lanes(q, sd, g0, g1, out, sc.subtree_lanes.data(), skip);
}

struct Entry {
  double score;
  std::size_t clip, s, e;
  double a, b, cost;
};
bool entry_less(const Entry& x, const Entry& y) {
  if (x.score != y.score) return x.score < y.score;
  if (x.clip != y.clip) return x.clip < y.clip;
  if (x.e != y.e) return x.e < y.e;
  return x.s < y.s;
}

// The shared top-r list of one pair; tau is the r-th best score (inf until full).
class TopR {
 public:
  explicit TopR(std::size_t r) : r_(r) {}
  double tau() const { return tau_.load(std::memory_order_acquire); }
  void insert(const Entry& e) {
    std::lock_guard lock(mutex_);
    auto it = std::lower_bound(entries_.begin(), entries_.end(), e, entry_less);
    entries_.insert(it, e);
    if (entries_.size() > r_) entries_.pop_back();
    if (entries_.size() == r_) tau_.store(entries_.back().score, std::memory_order_release);
  }
  std::vector<Entry> take() { return std::move(entries_); }

 private:
  std::size_t r_;
  std::mutex mutex_;
  std::vector<Entry> entries_;
  std::atomic<double> tau_{kInf};
};

// h values of one query frame already computed for another pair of the same
// query (world mode: a(.) of Q^h+1 in pair h+1 equals b(.) in pair h, h being
// symmetric). Frames of a clip are written by the thread evaluating that
// clip; pairs run one after another.
struct FrameCache {
  std::unique_ptr<double[]> values;
  std::vector<std::uint8_t> done;  // per skeleton frame
};

struct PairContext {
  const SearchEngine::Impl* eng;
  const SkelData* sd;
  const ResolvedFrame* qa;
  const ResolvedFrame* qb;
  double t, lambda;
  bool relative;
  Eigen::Vector2d offset_a, offset_b;  // relative mode x/z offsets
  SearchMode mode;
  double max_length_s;
  // Per skeleton frame lower bounds of a / b for partial query frames (world mode), or null.
  const double* frame_lb_a = nullptr;
  const double* frame_lb_b = nullptr;
  // Box-bound forms of qa / qb (world mode).
  const BoundQuery* ba = nullptr;
  const BoundQuery* bb = nullptr;
  // Values shared with the neighbouring pair (world mode), or null.
  FrameCache* cache_a = nullptr;
  FrameCache* cache_b = nullptr;
};

struct ClipCounters {
  std::uint64_t evaluated = 0, pruned = 0;
  bool clip_pruned = false;
};

// One whole chunk [f0, f1) of a clip (its block bl) for a full or root-only
// query frame: copied when the query's other pair computed it (cv / cd: the
// shared frame cache from the clip's first frame, null without one), else
// evaluated with the block's tile, counted and cached.
//
// With `partner` (a finite threshold `thr`; full query frames, `bq` its
// bound form), frame f of the chunk matters only if h(f) + partner[f - f0]
// can be <= thr, partner[i] being a lower bound of the best rest of a pair
// through frame f0 + i: the frames' chain-sketch bounds are computed first
// (2.2 KB on a 7-chain skeleton against the tile's 12 KB), and when no frame
// can matter by them the chunk is left at +inf, counted as pruned and not
// cached (docs/search.md "Chain sketches").
void scan_whole_chunk(const PairContext& c, const ClipInfo& ci, const ResolvedFrame& q,
                      std::size_t bl, std::size_t f0, std::size_t f1, double* dst, double* cv,
                      std::uint8_t* cd, Scratch& sc, ClipCounters& cnt,
                      const BoundQuery* bq = nullptr, const double* partner = nullptr,
                      double thr = kInf) {
  if (cd != nullptr && cd[f0]) {
    std::copy(cv + f0, cv + f1, dst + f0);
    return;
  }
  const SkelData& sd = *c.sd;
  const std::size_t row = ci.block_start + bl;
  if (partner != nullptr && bq != nullptr && bq->kind == FrameKind::full && std::isfinite(thr)) {
    float lb[kBlock];
    chain_sketch_bounds(bq->chain_sketch.data(),
                        sd.chain_sketch.data() + row * sd.chains * kSketchFields * kBlock,
                        sd.chains, lb);
    bool any = false;
    for (std::size_t f = f0; f < f1; ++f)
      any = any || !(safe(static_cast<double>(lb[f - f0]) + partner[f - f0]) > thr);
    if (!any) {
      std::fill(dst + f0, dst + f1, kInf);
      cnt.pruned += f1 - f0;
      return;
    }
  }
  const HScanView tile = sd.tile(row, f1 - f0);
  evaluate(q, sd, *c.eng->index, c.t, ci.frame_start + f0, ci.frame_start + f1, dst + f0, sc,
           std::nullopt, nullptr, &tile);
  cnt.evaluated += f1 - f0;
  if (cd != nullptr) {
    std::copy(dst + f0, dst + f1, cv + f0);
    std::fill(cd + f0, cd + f1, std::uint8_t{1});
  }
}

// World mode: per-frame lower bounds (block boxes, partial-frame bounds),
// a(s) and b(e) where they can matter, then the running minimum.
bool eval_clip_world(const PairContext& c, const ClipInfo& ci, double tau, Scratch& sc,
                     ClipCounters& cnt, Entry& out) {
  const SkelData& sd = *c.sd;
  const std::size_t k = ci.frame_count;
  const std::size_t nb = (k + kBlock - 1) / kBlock;
  sc.a.assign(k, kInf);
  sc.b.assign(k, kInf);
  sc.skip_a.assign(k, 0);
  sc.skip_b.assign(k, 0);
  const bool prune = c.mode != SearchMode::brute;
  if (prune) {
    sc.la.resize(k);
    sc.lb.resize(k);
    const bool box_a = c.qa->kind != FrameKind::partial, box_b = c.qb->kind != FrameKind::partial;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t row = ci.block_start + bl;
      const double xa = box_a ? static_cast<double>(block_box_bound(*c.ba, sd, row)) : 0.0;
      const double xb = box_b ? static_cast<double>(block_box_bound(*c.bb, sd, row)) : 0.0;
      const std::size_t f1 = std::min(k, bl * kBlock + kBlock);
      for (std::size_t f = bl * kBlock; f < f1; ++f) {
        sc.la[f] = xa;
        sc.lb[f] = xb;
      }
    }
    if (c.frame_lb_a != nullptr)
      for (std::size_t f = 0; f < k; ++f)
        sc.la[f] = std::max(sc.la[f], c.frame_lb_a[ci.frame_start + f]);
    if (c.frame_lb_b != nullptr)
      for (std::size_t f = 0; f < k; ++f)
        sc.lb[f] = std::max(sc.lb[f], c.frame_lb_b[ci.frame_start + f]);
    // s is needed only if la(s) + min_{e>s} lb(e) can reach tau; e only if
    // lb(e) + min_{s<e} la(s) can.
    double clip_lb = kInf, suffix = kInf;
    for (std::size_t f = k; f-- > 0;) {
      const double x = sc.la[f] + suffix;
      clip_lb = std::min(clip_lb, x);
      sc.skip_a[f] = safe(x) > tau;
      suffix = std::min(suffix, sc.lb[f]);
    }
    if (safe(clip_lb) > tau) {
      cnt.clip_pruned = true;
      cnt.pruned += 2 * k;
      return false;
    }
    double prefix_min = kInf;
    for (std::size_t f = 0; f < k; ++f) {
      sc.skip_b[f] = safe(sc.lb[f] + prefix_min) > tau;
      prefix_min = std::min(prefix_min, sc.la[f]);
    }
  }
  // Full and root-only query frames are scanned in whole 16-frame chunks
  // (the same chunks in every mode: bit-identical values); partial ones per frame.
  auto side = [&](const ResolvedFrame& q, std::vector<std::uint8_t>& skip, double* dst,
                  FrameCache* cache) {
    double* cv = cache ? cache->values.get() + ci.frame_start : nullptr;
    std::uint8_t* cd = cache ? cache->done.data() + ci.frame_start : nullptr;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = bl * kBlock, f1 = std::min(k, f0 + kBlock);
      std::size_t need = 0;
      for (std::size_t f = f0; f < f1; ++f) need += skip[f] == 0;
      if (need == 0) {
        cnt.pruned += f1 - f0;
        continue;
      }
      if (q.kind == FrameKind::partial) {
        std::size_t fresh = need;
        if (cd != nullptr) {
          // Frames the other pair computed: copy; mark them skipped for evaluate().
          for (std::size_t f = f0; f < f1; ++f)
            if (skip[f] == 0 && cd[f]) {
              dst[f] = cv[f];
              skip[f] = 2;
              --fresh;
            }
        }
        if (fresh > 0)
          evaluate(q, sd, *c.eng->index, c.t, ci.frame_start + f0, ci.frame_start + f1, dst + f0,
                   sc, std::nullopt, skip.data() + f0);
        if (cd != nullptr)
          for (std::size_t f = f0; f < f1; ++f)
            if (skip[f] == 0) {
              cv[f] = dst[f];
              cd[f] = 1;
            }
        cnt.evaluated += fresh;
        cnt.pruned += (f1 - f0) - need;
      } else {
        scan_whole_chunk(c, ci, q, bl, f0, f1, dst, cv, cd, sc, cnt);
      }
    }
  };
  if (!prune) {
    side(*c.qa, sc.skip_a, sc.a.data(), c.cache_a);
    side(*c.qb, sc.skip_b, sc.b.data(), c.cache_b);
  } else {
    // The side with fewer blocks to scan first; then the other side is
    // decided again with its true values in place of the bounds: a frame of
    // the first side that was not computed can be in no pair scoring <= tau,
    // so it counts as +inf (docs/search.md "Frame pruning").
    auto blocks_needed = [&](const std::vector<std::uint8_t>& skip) {
      std::size_t count = 0;
      for (std::size_t bl = 0; bl < nb; ++bl)
        for (std::size_t f = bl * kBlock; f < std::min(k, bl * kBlock + kBlock); ++f)
          if (skip[f] == 0) {
            ++count;
            break;
          }
      return count;
    };
    if (blocks_needed(sc.skip_a) <= blocks_needed(sc.skip_b)) {
      side(*c.qa, sc.skip_a, sc.a.data(), c.cache_a);
      double prefix_min = kInf;
      for (std::size_t f = 0; f < k; ++f) {
        if (sc.skip_b[f] == 0) sc.skip_b[f] = safe(sc.lb[f] + prefix_min) > tau;
        prefix_min = std::min(prefix_min, sc.a[f]);
      }
      side(*c.qb, sc.skip_b, sc.b.data(), c.cache_b);
    } else {
      side(*c.qb, sc.skip_b, sc.b.data(), c.cache_b);
      double suffix = kInf;
      for (std::size_t f = k; f-- > 0;) {
        if (sc.skip_a[f] == 0) sc.skip_a[f] = safe(sc.la[f] + suffix) > tau;
        suffix = std::min(suffix, sc.b[f]);
      }
      side(*c.qa, sc.skip_a, sc.a.data(), c.cache_a);
    }
  }
  const std::span<const double> prefix = clip_prefix(*c.eng->index, sd, ci);
  ClipBest best;
  if (!best_partial_motion(sc.a.data(), sc.b.data(), prefix.data(), k, c.lambda, best))
    return false;
  out = {best.score,
         ci.clip,
         best.s,
         best.e,
         sc.a[best.s],
         sc.b[best.e],
         prefix[best.e] - prefix[best.s]};
  return true;
}

// World mode, exact, both query frames bounded by boxes only (full or
// root-only, no per-frame bounds): eval_clip_world's decisions taken per
// 16-frame block. lba / lbb are the box bounds of the clip's blocks (as
// double); every bound of a frame is its block's, so a block's frames differ
// only by which neighbours count as "s < e" (the first / last frame of a
// block). On top of those decisions the clip prunes against its own best
// pair so far (docs/search.md "The clip's own best"): a probe pair of blocks
// first while tau is infinite, and the second side's blocks in the order of
// their bounds. The chunks are eval_clip_world's 16-frame tiles (same
// values, same answer); fewer of them are scanned.
bool eval_clip_blocks(const PairContext& c, const ClipInfo& ci, double tau, const double* lba,
                      const double* lbb, Scratch& sc, ClipCounters& cnt, Entry& out) {
  const SkelData& sd = *c.sd;
  const std::size_t k = ci.frame_count;
  const std::size_t nb = (k + kBlock - 1) / kBlock;
  auto first = [](std::size_t bl) { return bl * kBlock; };
  auto frames = [&](std::size_t bl) { return std::min(k, bl * kBlock + kBlock) - bl * kBlock; };
  // sb[b] = min_{g >= b} lbb[g] (sb[nb] = inf); pa[b + 1] = min_{g <= b} lba[g] (pa[0] = inf).
  std::vector<double>& sb = sc.sb;
  std::vector<double>& pa = sc.pa;
  sb.resize(nb + 1);
  pa.resize(nb + 1);
  sb[nb] = kInf;
  for (std::size_t bl = nb; bl-- > 0;) sb[bl] = std::min(sb[bl + 1], lbb[bl]);
  pa[0] = kInf;
  for (std::size_t bl = 0; bl < nb; ++bl) pa[bl + 1] = std::min(pa[bl], lba[bl]);
  // Frame s of block b needs a(s) if lba[b] + min_{e > s} lb(e) can reach tau:
  // sb[b] for all but the block's last frame, sb[b + 1] for it. Frame e
  // needs b(e) if lbb[b] + min_{s < e} la(s) can: pa[b + 1], or pa[b] for
  // the block's first frame.
  std::vector<std::uint8_t>& need_a = sc.need_a;
  std::vector<std::uint8_t>& need_b = sc.need_b;
  need_a.assign(nb, 0);
  need_b.assign(nb, 0);
  sc.done_a.assign(nb, 0);
  sc.done_b.assign(nb, 0);
  if (sc.a.size() < k) {
    sc.a.resize(k);
    sc.b.resize(k);
  }
  double* a = sc.a.data();
  double* b = sc.b.data();
  const std::span<const double> prefix = clip_prefix(*c.eng->index, sd, ci);
  const double lambda = c.lambda;
  // lambda P[f], without reading P when lambda = 0 (the same value: 0).
  auto lp = [&](std::size_t f) { return lambda != 0.0 ? lambda * prefix[f] : 0.0; };
  auto cache_values = [&](FrameCache* cache) {
    return cache ? cache->values.get() + ci.frame_start : nullptr;
  };
  auto cache_done = [&](FrameCache* cache) {
    return cache ? cache->done.data() + ci.frame_start : nullptr;
  };
  // Probe (only while fewer than r clips are scored, tau infinite): the
  // block pair x <= y of least lba[x] + lbb[y] is scanned first; its best
  // pair s < e is a real score of this clip, so the clip's optimum is at most
  // that: it serves as the clip's tau (every decision below stays sound).
  if (!std::isfinite(tau) && k >= 2) {
    double least = kInf;
    std::size_t px = 0, py = 0;
    for (std::size_t x = 0; x < nb; ++x)
      for (std::size_t y = x; y < nb; ++y)
        if ((x != y || frames(x) >= 2) && lba[x] + lbb[y] < least) {
          least = lba[x] + lbb[y];
          px = x;
          py = y;
        }
    if (std::isfinite(least)) {
      scan_whole_chunk(c, ci, *c.qa, px, first(px), first(px) + frames(px), a,
                       cache_values(c.cache_a), cache_done(c.cache_a), sc, cnt);
      scan_whole_chunk(c, ci, *c.qb, py, first(py), first(py) + frames(py), b,
                       cache_values(c.cache_b), cache_done(c.cache_b), sc, cnt);
      sc.done_a[px] = sc.done_b[py] = 1;
      for (std::size_t s = first(px); s < first(px) + frames(px); ++s)
        for (std::size_t e = std::max(s + 1, first(py)); e < first(py) + frames(py); ++e)
          tau = std::min(tau, (b[e] + lp(e)) + (a[s] - lp(s)));
    }
  }
  double clip_lb = kInf;
  std::size_t count_a = 0, count_b = 0;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    const double xa = lba[bl] + (frames(bl) >= 2 ? sb[bl] : sb[bl + 1]);
    clip_lb = std::min(clip_lb, xa);
    need_a[bl] = !(safe(xa) > tau);
    const double xb = lbb[bl] + (frames(bl) >= 2 ? pa[bl + 1] : pa[bl]);
    need_b[bl] = !(safe(xb) > tau);
    count_a += need_a[bl];
    count_b += need_b[bl];
  }
  if (safe(clip_lb) > tau) {
    cnt.clip_pruned = true;
    cnt.pruned += 2 * k;
    return false;
  }
  // Scans the needed blocks of the first side (chunks shared with the other
  // pair: copied; blocks the probe scanned: kept).
  // A frame's partner bound (scan_whole_chunk): for a(s), the least lbb of
  // the blocks with a frame after s; for b(e), the least lba of the blocks
  // with a frame before e; on the second side, the first side's best partner.
  double partner[kBlock];
  auto side = [&](const ResolvedFrame& q, const std::vector<std::uint8_t>& need,
                  const std::vector<std::uint8_t>& done, double* dst, FrameCache* cache) {
    const bool is_a = &q == c.qa;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      if (!need[bl]) {
        cnt.pruned += f1 - f0;
      } else if (!done[bl]) {
        for (std::size_t f = f0; f < f1; ++f)
          partner[f - f0] =
              is_a ? (f + 1 == f1 ? sb[bl + 1] : sb[bl]) : (f == f0 ? pa[bl] : pa[bl + 1]);
        scan_whole_chunk(c, ci, q, bl, f0, f1, dst, cache_values(cache), cache_done(cache), sc, cnt,
                         is_a ? c.ba : c.bb, partner, tau);
      }
    }
  };
  // Scans the needed blocks of the second side in the order of key[bl] =
  // its bound + a lower bound of the first side's best partner (least
  // first), with u the clip's best score so far (tau at first): a block
  // whose key exceeds u cannot hold a pair scoring <= u and is dropped
  // (need = 0). partner(f): the computed first side's best partner of frame
  // f (min over s < f of a(s) - lambda P[s], or over e > f of b(e) + lambda P[e]).
  auto second_side = [&](const ResolvedFrame& q, std::vector<std::uint8_t>& need,
                         const std::vector<std::uint8_t>& done, const double* lbx,
                         const std::vector<double>& key_other, double* dst, FrameCache* cache,
                         double sign) {
    std::vector<std::size_t>& order = sc.order;
    order.clear();
    for (std::size_t bl = 0; bl < nb; ++bl) {
      if (need[bl])
        order.push_back(bl);
      else
        cnt.pruned += frames(bl);
    }
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      const double kx = lbx[x] + key_other[x], ky = lbx[y] + key_other[y];
      return kx != ky ? kx < ky : x < y;
    });
    double u = tau;
    for (const std::size_t bl : order) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      if (safe(lbx[bl] + key_other[bl]) > u) {
        need[bl] = 0;
        cnt.pruned += f1 - f0;
        continue;
      }
      if (!done[bl]) {
        for (std::size_t f = f0; f < f1; ++f) partner[f - f0] = sign * lp(f) + sc.run[f];
        scan_whole_chunk(c, ci, q, bl, f0, f1, dst, cache_values(cache), cache_done(cache), sc, cnt,
                         &q == c.qa ? c.ba : c.bb, partner, u);
      }
      for (std::size_t f = f0; f < f1; ++f)
        if (std::isfinite(dst[f]) && std::isfinite(sc.run[f]))
          u = std::min(u, (dst[f] + sign * lp(f)) + sc.run[f]);
    }
  };
  sc.run.resize(k);
  // The side with fewer blocks first; then the other side decided again with
  // its true values (+inf where not computed) in place of its bounds, for the
  // frames its bounds kept (docs/search.md "Frame pruning").
  std::vector<double>& key = sc.key;
  key.resize(nb);
  if (count_a <= count_b) {
    side(*c.qa, need_a, sc.done_a, a, c.cache_a);
    double pm = kInf;  // min_{s < first frame of the block} of the computed a(s)
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), n = frames(bl);
      // min_{s < last frame of the block} of the computed a(s)
      double pm_last = pm;
      if (need_a[bl])
        for (std::size_t f = f0; f + 1 < f0 + n; ++f) pm_last = std::min(pm_last, a[f]);
      if (need_b[bl]) {
        const bool first_frame = !(safe(lbb[bl] + pa[bl]) > tau) && !(safe(lbb[bl] + pm) > tau);
        const bool rest = n >= 2 && !(safe(lbb[bl] + pa[bl + 1]) > tau) &&
                          !(safe(lbb[bl] + pm_last) > tau);
        need_b[bl] = first_frame || rest;
      }
      key[bl] = std::max(pa[bl + 1], pm_last);  // <= a(s) + lambda (P[e] - P[s]) for s < e in bl
      if (need_a[bl]) pm = std::min(pm_last, a[f0 + n - 1]);
    }
    // run[e] = min_{s < e} of the computed a(s) - lambda P[s]
    double m = kInf;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      for (std::size_t f = f0; f < f1; ++f) {
        sc.run[f] = m;
        if (need_a[bl] && std::isfinite(a[f])) m = std::min(m, a[f] - lp(f));
      }
    }
    second_side(*c.qb, need_b, sc.done_b, lbb, key, b, c.cache_b, 1.0);
  } else {
    side(*c.qb, need_b, sc.done_b, b, c.cache_b);
    double sm = kInf;  // min_{e > last frame of the block} of the computed b(e)
    for (std::size_t bl = nb; bl-- > 0;) {
      const std::size_t f0 = first(bl), n = frames(bl);
      // min_{e > first frame of the block} of the computed b(e)
      double sm_first = sm;
      if (need_b[bl])
        for (std::size_t f = f0 + 1; f < f0 + n; ++f) sm_first = std::min(sm_first, b[f]);
      if (need_a[bl]) {
        const bool last = !(safe(lba[bl] + sb[bl + 1]) > tau) && !(safe(lba[bl] + sm) > tau);
        const bool rest = n >= 2 && !(safe(lba[bl] + sb[bl]) > tau) &&
                          !(safe(lba[bl] + sm_first) > tau);
        need_a[bl] = last || rest;
      }
      key[bl] = std::max(sb[bl], sm_first);  // <= b(e) + lambda (P[e] - P[s]) for e > s in bl
      if (need_b[bl]) sm = std::min(sm_first, b[f0]);
    }
    // run[s] = min_{e > s} of the computed b(e) + lambda P[e]
    double m = kInf;
    for (std::size_t bl = nb; bl-- > 0;) {
      const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
      for (std::size_t f = f1; f-- > f0;) {
        sc.run[f] = m;
        if (need_b[bl] && std::isfinite(b[f])) m = std::min(m, b[f] + lp(f));
      }
    }
    second_side(*c.qa, need_a, sc.done_a, lba, key, a, c.cache_a, -1.0);
  }
  // Running minimum (best_partial_motion) over the computed values, +inf
  // elsewhere: blocks with neither side computed change nothing and are skipped.
  bool have = false;
  double run_min = kInf;
  std::size_t run_s = 0;
  ClipBest best;
  for (std::size_t bl = 0; bl < nb; ++bl) {
    if (!need_a[bl] && !need_b[bl]) continue;
    const std::size_t f0 = first(bl), f1 = f0 + frames(bl);
    for (std::size_t f = f0; f < f1; ++f) {
      // e = f with s < f, then s = f for the later e.
      if (need_b[bl] && f > 0 && std::isfinite(b[f]) && std::isfinite(run_min)) {
        const double score = (b[f] + lp(f)) + run_min;
        if (score < best.score || !have) {
          best = {score, run_s, f};
          have = true;
        }
      }
      if (need_a[bl] && std::isfinite(a[f])) {
        const double v = a[f] - lp(f);
        if (v < run_min) {
          run_min = v;
          run_s = f;
        }
      }
    }
  }
  if (!have) return false;
  out = {best.score, ci.clip, best.s, best.e, a[best.s], b[best.e], prefix[best.e] - prefix[best.s]};
  return true;
}

// Relative mode: a(s) with Q^h placed on F^s, b(s, e) with Q^h+1 placed
// relative to F^s; O(K L).
bool eval_clip_relative(const PairContext& c, const ClipInfo& ci, double tau, Scratch& sc,
                        ClipCounters& cnt, Entry& out) {
  const SkelData& sd = *c.sd;
  const std::size_t k = ci.frame_count;
  if (k < 2) return false;
  const double dt = c.eng->index->clips()[ci.clip].frame_time_s;
  const std::size_t l =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(c.max_length_s / dt)));
  const bool prune = c.mode != SearchMode::brute;
  const float* root = sd.table.root_positions.data();
  const std::size_t stride = sd.table.stride;
  auto anchor = [&](std::size_t f, const Eigen::Vector2d& off) {
    const std::size_t g = ci.frame_start + f;
    return Eigen::Vector2d(static_cast<double>(root[g]) + off[0],
                           static_cast<double>(root[2 * stride + g]) + off[1]);
  };
  std::uint64_t total = 0;
  for (std::size_t s = 0; s + 1 < k; ++s) total += 1 + std::min(l, k - 1 - s);
  sc.a.assign(k, kInf);
  double min_a = kInf;
  for (std::size_t s = 0; s + 1 < k; ++s) {
    evaluate(*c.qa, sd, *c.eng->index, c.t, ci.frame_start + s, ci.frame_start + s + 1,
             sc.a.data() + s, sc, anchor(s, c.offset_a));
    min_a = std::min(min_a, sc.a[s]);
  }
  cnt.evaluated += k - 1;
  if (prune && safe(min_a) > tau) {
    cnt.clip_pruned = true;
    cnt.pruned += total - (k - 1);
    return false;
  }
  const std::span<const double> prefix = clip_prefix(*c.eng->index, sd, ci);
  ClipBest best;
  bool have = false;
  sc.b.resize(l);
  for (std::size_t s = 0; s + 1 < k; ++s) {
    const std::size_t e1 = std::min(k - 1, s + l);
    if (prune && safe(sc.a[s]) > tau) {
      cnt.pruned += e1 - s;
      continue;
    }
    evaluate(*c.qb, sd, *c.eng->index, c.t, ci.frame_start + s + 1, ci.frame_start + e1 + 1,
             sc.b.data(), sc, anchor(s, c.offset_b));
    cnt.evaluated += e1 - s;
    for (std::size_t e = s + 1; e <= e1; ++e) {
      const double score =
          (sc.b[e - s - 1] + c.lambda * prefix[e]) + (sc.a[s] - c.lambda * prefix[s]);
      if (better(score, e, s, best, have)) {
        best = {score, s, e};
        out.b = sc.b[e - s - 1];
        have = true;
      }
    }
  }
  if (!have) return false;
  out = {best.score, ci.clip, best.s, best.e, sc.a[best.s], out.b, prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace

// ---------------------------------------------------------------------------
// A query

namespace {

constexpr std::size_t kCharacterCacheEntries = 4;

// Everything of a character that the energy depends on (not its name).
std::string character_key(const Character& c) {
  std::string out = fmt::format("{:.17g}|{}", c.total_mass_kg, c.sex == Sex::male ? "m" : "f");
  for (const auto& [k, v] : c.class_mass_kg)
    out += fmt::format("|cm{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.class_mass_scale)
    out += fmt::format("|cs{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.joint_mass_kg) out += fmt::format("|jm{}={:.17g}", k, v);
  for (const auto& [k, v] : c.class_length_scale)
    out += fmt::format("|cl{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.joint_length_scale) out += fmt::format("|jl{}={:.17g}", k, v);
  return out;
}

bool same_character(const Character& x, const Character& y) {
  return x.total_mass_kg == y.total_mass_kg && x.sex == y.sex &&
         x.class_mass_kg == y.class_mass_kg && x.class_mass_scale == y.class_mass_scale &&
         x.joint_mass_kg == y.joint_mass_kg && x.class_length_scale == y.class_length_scale &&
         x.joint_length_scale == y.joint_length_scale;
}

struct PairRun {
  std::vector<Entry> top;
  SearchStats stats;
};

}  // namespace

struct QueryRunner {
  QueryRunner(const SearchEngine::Impl& e, const Query& query, const SearchOptions& options,
              const std::vector<std::unique_ptr<SkelData>>& tables)
      : eng(e), q(query), opt(options), skels(tables), scratch(e.scratch) {}
  const SearchEngine::Impl& eng;
  const Query& q;
  const SearchOptions& opt;
  // The tables of the query's character (the index's or a query character's).
  const std::vector<std::unique_ptr<SkelData>>& skels;
  // resolved[k][i]: query frame i on skeleton k; bounds[k][i] its box-bound form.
  std::vector<std::vector<ResolvedFrame>> resolved;
  std::vector<std::vector<BoundQuery>> bounds;
  // cache[k][i]: values of query frame i shared by pairs i-1 and i (world
  // mode, interior frames of queries with 3 or more frames); empty otherwise.
  std::vector<std::vector<FrameCache>> cache;
  tbb::enumerable_thread_specific<Scratch>& scratch;  // the engine's

  void prepare_caches() {
    cache.clear();
    for (std::size_t k = 0; k < skels.size(); ++k) {
      cache.emplace_back();
      cache.back().resize(q.frames.size());
    }
    if (q.relative) return;
    for (std::size_t k = 0; k < skels.size(); ++k)
      for (std::size_t i = 1; i + 1 < q.frames.size(); ++i) {
        const std::size_t n = skels[k]->sk->frame_count;
        cache[k][i].values.reset(new double[n]);
        cache[k][i].done.assign(n, 0);
      }
  }
  FrameCache* cache_of(std::size_t k, std::size_t i) {
    return cache.empty() || !cache[k][i].values ? nullptr : &cache[k][i];
  }
  // tiles[k][i]: query frame i's bounds on skeleton k over every group
  // (group_bounds) and over the clips of the groups opened so far
  // (clip_tile_bounds), computed once per query frame and shared by its
  // two pairs, and by the seeding and the sweep of a pair.
  struct FrameTiles {
    std::vector<float> groups;             // [group]
    std::vector<float> clips;              // [group][kLanes]
    std::vector<std::uint8_t> clips_done;  // [group]
  };
  std::vector<std::vector<FrameTiles>> tiles;
  // Computes query frame i's group bounds on skeleton k if not done yet and
  // makes room for its clip tiles (one thread: before a pair's groups are
  // taken).
  const float* group_lbs(std::size_t k, std::size_t i) {
    if (tiles.empty()) tiles.assign(skels.size(), std::vector<FrameTiles>(q.frames.size()));
    FrameTiles& t = tiles[k][i];
    if (t.clips_done.empty()) {
      group_bounds(bounds[k][i], *skels[k], t.groups);
      t.clips.resize(t.groups.size() * kLanes);
      t.clips_done.assign(t.groups.size(), 0);
    }
    return t.groups.data();
  }
  // Query frame i's bounds over the kLanes clips of group g of skeleton k
  // (after group_lbs(k, i); a group is opened by one thread at a time).
  const float* clip_lbs(std::size_t k, std::size_t i, std::size_t g) {
    FrameTiles& t = tiles[k][i];
    float* out = t.clips.data() + g * kLanes;
    if (!t.clips_done[g]) {
      clip_tile_bounds(bounds[k][i], *skels[k], g, out);
      t.clips_done[g] = 1;
    }
    return out;
  }
  // frame_lb[k][i]: per skeleton frame lower bound of h(query frame i -> F)
  // for partial query frames (exact mode, world), computed once per query
  // frame and shared by its two pairs; empty otherwise.
  std::vector<std::vector<std::vector<double>>> frame_lb;

  void compute_frame_bounds() {
    frame_lb.assign(skels.size(), std::vector<std::vector<double>>(q.frames.size()));
    for (std::size_t k = 0; k < skels.size(); ++k) {
      const SkelData& sd = *skels[k];
      const std::size_t n = sd.sk->frame_count;
      for (std::size_t i = 0; i < q.frames.size(); ++i) {
        if (resolved[k][i].kind != FrameKind::partial || n == 0) continue;
        PartialBoundPlan plan = make_partial_bound_plan(resolved[k][i], sd, q.transition_time_s);
        attach_columns(plan, sd, *eng.index);
        // The reference (frames the columns do not serve) reads the frame arrays.
        const FrameArrays* fa = plan.col_segs.empty() ? &frame_arrays(*eng.index, sd) : nullptr;
        std::vector<double>& out = frame_lb[k][i];
        out.resize(n);
        auto chunk = [&](std::size_t g0, std::size_t g1) {
          partial_frame_bounds(plan, sd, fa, g0, g1, out.data() + g0, scratch.local());
        };
        if (opt.parallel_clips)
          tbb::parallel_for(
              tbb::blocked_range<std::size_t>(0, n, 4096),
              [&](const tbb::blocked_range<std::size_t>& rg) { chunk(rg.begin(), rg.end()); });
        else
          chunk(0, n);
      }
    }
  }

  const double* frame_bounds_of(std::size_t k, std::size_t i) const {
    if (frame_lb.empty() || frame_lb[k][i].empty()) return nullptr;
    return frame_lb[k][i].data();
  }

  bool passes(std::size_t clip) const {
    if (q.filter.empty()) return true;
    const IndexClip& c = eng.index->clips()[clip];
    const std::string name = std::filesystem::path(c.path).filename().string();
    const std::string content =
        eng.content_key >= 0 ? c.labels[static_cast<std::size_t>(eng.content_key)] : "";
    const std::string style =
        eng.style_key >= 0 ? c.labels[static_cast<std::size_t>(eng.style_key)] : "";
    return q.filter.accepts(name, content, style);
  }

  PairContext context(std::size_t k, std::size_t h, SearchMode mode) {
    PairContext c{&eng,
                  skels[k].get(),
                  &resolved[k][h],
                  &resolved[k][h + 1],
                  q.transition_time_s,
                  q.path_weight,
                  q.relative,
                  Eigen::Vector2d::Zero(),
                  Eigen::Vector2d::Zero(),
                  mode,
                  opt.max_length_s,
                  nullptr,
                  nullptr,
                  &bounds[k][h],
                  &bounds[k][h + 1],
                  cache_of(k, h),
                  cache_of(k, h + 1)};
    if (mode == SearchMode::exact && !q.relative) {
      c.frame_lb_a = frame_bounds_of(k, h);
      c.frame_lb_b = frame_bounds_of(k, h + 1);
    }
    if (q.relative) {
      // Hand-written frames: given x/z are the offsets. BVH frames: offsets
      // from the pair's first query frame when it is a BVH frame, else 0.
      auto offset = [&](const ResolvedFrame& f) {
        if (!f.from_bvh)
          return Eigen::Vector2d(f.given[0] ? f.root_m[0] : 0.0, f.given[2] ? f.root_m[2] : 0.0);
        const ResolvedFrame& first = *c.qa;
        if (!first.from_bvh) return Eigen::Vector2d::Zero().eval();
        return Eigen::Vector2d(f.root_m[0] - first.root_m[0], f.root_m[2] - first.root_m[2]);
      };
      c.offset_a = offset(*c.qa);
      c.offset_b = offset(*c.qb);
    }
    return c;
  }

  // Candidate clips (skeleton, row) of pair h for approx mode; nullopt = all.
  std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx_candidates(
      std::size_t h) const {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t k = 0; k < skels.size(); ++k) {
      const ResolvedFrame& qa = resolved[k][h];
      const ResolvedFrame& qb = resolved[k][h + 1];
      if (qa.kind != FrameKind::full || qb.kind != FrameKind::full || q.relative)
        return std::nullopt;
    }
    for (std::size_t k = 0; k < skels.size(); ++k) {
      const SkelData& sd = *skels[k];
      const std::size_t n = sd.sk->frame_count;
      if (n == 0) continue;
      ensure_forest(*eng.index, sd, opt);
      const std::size_t knn = std::min<std::size_t>(
          n, static_cast<std::size_t>(opt.approx_neighbours_per_result) * q.top);
      std::set<std::size_t> rows;
      std::vector<std::size_t> idx;
      for (const ResolvedFrame* f : {&resolved[k][h], &resolved[k][h + 1]}) {
        sd.flann->knn(f->kd.data(), knn, opt.approx_checks, idx);
        for (std::size_t i : idx) rows.insert(sd.frame_row[i]);
      }
      for (std::size_t r : rows) out.emplace_back(k, r);
    }
    return out;
  }

  PairRun run_pair(std::size_t h, SearchMode mode) {
    PairRun pr;
    std::vector<std::pair<std::size_t, std::size_t>> cands;
    std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx;
    if (mode == SearchMode::approx) approx = approx_candidates(h);
    const SearchMode eval_mode = mode == SearchMode::approx ? SearchMode::exact : mode;
    if (approx) {
      for (auto [k, r] : *approx)
        if (passes(skels[k]->clips[r].clip)) cands.emplace_back(k, r);
      for (std::size_t k = 0; k < skels.size(); ++k)
        for (const ClipInfo& ci : skels[k]->clips)
          if (passes(ci.clip)) ++pr.stats.clips;
      pr.stats.clips_pruned += pr.stats.clips - cands.size();
    } else {
      for (std::size_t k = 0; k < skels.size(); ++k)
        for (std::size_t r = 0; r < skels[k]->clips.size(); ++r)
          if (passes(skels[k]->clips[r].clip)) cands.emplace_back(k, r);
      pr.stats.clips = cands.size();
    }
    // Work in groups of kGroup consecutive clip rows of a skeleton (similar
    // clips are adjacent: files sorted by name). A group's bound (its union
    // box) orders the groups and prunes whole groups; inside a group, clip
    // bounds order and prune the clips. Likely winners come first, so tau
    // falls fast; the answer does not depend on the order (docs/search.md
    // "Search order").
    const bool bounded = eval_mode == SearchMode::exact && !q.relative;
    struct Work {
      double lb;
      std::size_t clip;
      std::size_t k, r;
      std::size_t cand;  // index in `cands`
    };
    struct Group {
      double lb;
      std::size_t first, count;  // range of `cands`
    };
    std::vector<Group> groups;
    // Every group's bound for both query frames, 16 groups at a time.
    std::vector<std::array<const float*, 2>> group_lb(skels.size());
    if (bounded)
      for (std::size_t k = 0; k < skels.size(); ++k)
        for (std::size_t side = 0; side < 2; ++side) group_lb[k][side] = group_lbs(k, h + side);
    for (std::size_t i = 0; i < cands.size();) {
      const auto [k, r] = cands[i];
      std::size_t j = i + 1;
      while (j < cands.size() && cands[j].first == k && cands[j].second / kGroup == r / kGroup) ++j;
      double glb = 0.0;
      if (bounded)
        glb = static_cast<double>(group_lb[k][0][r / kGroup]) +
              static_cast<double>(group_lb[k][1][r / kGroup]);
      groups.push_back({glb, i, j - i});
      i = j;
    }
    std::sort(groups.begin(), groups.end(), [&](const Group& x, const Group& y) {
      if (x.lb != y.lb) return x.lb < y.lb;
      return x.first < y.first;
    });
    // Clip bound: boxes, and the per-frame bounds of partial query frames:
    // min over s < e of (max(xa, fa[s]) + max(xb, fb[e])).
    // xa, xb: the clip's tile bounds (clip_tile_bounds over its group's tile).
    auto clip_bound = [&](std::size_t k, std::size_t r, double xa, double xb) {
      const SkelData& sd = *skels[k];
      const double* fa = frame_bounds_of(k, h);
      const double* fb = frame_bounds_of(k, h + 1);
      if (fa == nullptr && fb == nullptr) return xa + xb;
      const ClipInfo& ci = sd.clips[r];
      double best = kInf, suffix = kInf;
      for (std::size_t f = ci.frame_count; f-- > 0;) {
        const std::size_t g = ci.frame_start + f;
        best = std::min(best, (fa ? std::max(xa, fa[g]) : xa) + suffix);
        suffix = std::min(suffix, fb ? std::max(xb, fb[g]) : xb);
      }
      return std::max(xa + xb, best);
    };
    TopR top(q.top);
    std::atomic<std::uint64_t> evaluated{0}, pruned{0}, clips_pruned{0};
    std::vector<PairContext> contexts;
    for (std::size_t k = 0; k < skels.size(); ++k) contexts.push_back(context(k, h, eval_mode));
    // Full or root-only query frames on both sides: block-level evaluation.
    std::vector<std::uint8_t> blocks_only(skels.size());
    for (std::size_t k = 0; k < skels.size(); ++k)
      blocks_only[k] = bounded && bounds[k][h].kind != FrameKind::partial &&
                       bounds[k][h + 1].kind != FrameKind::partial &&
                       frame_bounds_of(k, h) == nullptr && frame_bounds_of(k, h + 1) == nullptr;
    // The bounds of a clip's 16-frame blocks, both query frames: the box
    // bounds; for a full query frame first the least whole-body sketch
    // bound of the block's frames, raised to the box bound only where the
    // sketches cannot rule the block out against tau (docs/search.md
    // "Whole-body sketches": a block left at its sketch bound is not
    // needed either way).
    auto block_bounds_of = [&](std::size_t k, const ClipInfo& ci, double tau, Scratch& sc) {
      const SkelData& sd = *skels[k];
      const std::size_t nb = (ci.frame_count + kBlock - 1) / kBlock;
      const BoundQuery& qa = bounds[k][h];
      const BoundQuery& qb = bounds[k][h + 1];
      const bool sketch_a = qa.kind == FrameKind::full, sketch_b = qb.kind == FrameKind::full;
      auto box = [&](const BoundQuery& bq, std::size_t bl) {
        return static_cast<double>(block_box_bound(bq, sd, ci.block_start + bl));
      };
      sc.blk_a.resize(nb);
      sc.blk_b.resize(nb);
      for (std::size_t bl = 0; bl < nb; ++bl) {
        float xa = 0.0f, xb = 0.0f;
        if (sketch_a || sketch_b)
          sketch_block_bounds(qa.sketch.data(), qb.sketch.data(),
                              sd.sketch.data() + (ci.block_start + bl) * kSketchFields * kBlock, xa,
                              xb);
        sc.blk_a[bl] = sketch_a ? static_cast<double>(xa) : box(qa, bl);
        sc.blk_b[bl] = sketch_b ? static_cast<double>(xb) : box(qb, bl);
      }
      if (!sketch_a && !sketch_b) return;
      // PA / SB of the sketch bounds (a block pairs with itself and the
      // blocks after it); the box is needed where they do not exceed tau.
      // The needed rows are all requested (prefetched) before the first
      // box is computed, so their cache misses overlap.
      sc.blk_pa.resize(nb);
      sc.blk_need.resize(nb);
      double prefix = kInf, suffix = kInf;
      for (std::size_t bl = 0; bl < nb; ++bl)
        sc.blk_pa[bl] = prefix = std::min(prefix, sc.blk_a[bl]);
      for (std::size_t bl = nb; bl-- > 0;) {
        suffix = std::min(suffix, sc.blk_b[bl]);
        const bool need_a = sketch_a && !(safe(sc.blk_a[bl] + suffix) > tau);
        const bool need_b = sketch_b && !(safe(sc.blk_b[bl] + sc.blk_pa[bl]) > tau);
        sc.blk_need[bl] = static_cast<std::uint8_t>(need_a | (need_b << 1));
        if (need_a || need_b) prefetch_block_box(sd, ci.block_start + bl);
      }
      for (std::size_t bl = 0; bl < nb; ++bl) {
        if (sc.blk_need[bl] & 1) sc.blk_a[bl] = std::max(sc.blk_a[bl], box(qa, bl));
        if (sc.blk_need[bl] & 2) sc.blk_b[bl] = std::max(sc.blk_b[bl], box(qb, bl));
      }
    };
    // Evaluates one candidate against tau (its bound does not exceed tau)
    // and offers its best partial motion to the top.
    auto eval_work = [&](const Work& w, double tau, Scratch& sc, std::uint64_t& ev,
                         std::uint64_t& pf, std::uint64_t& pc) {
      const ClipInfo& ci = skels[w.k]->clips[w.r];
      ClipCounters cnt;
      Entry e{};
      bool ok = false;
      if (q.relative) {
        ok = eval_clip_relative(contexts[w.k], ci, tau, sc, cnt, e);
      } else if (blocks_only[w.k]) {
        block_bounds_of(w.k, ci, tau, sc);
        ok = eval_clip_blocks(contexts[w.k], ci, tau, sc.blk_a.data(), sc.blk_b.data(), sc, cnt, e);
      } else {
        ok = eval_clip_world(contexts[w.k], ci, tau, sc, cnt, e);
      }
      if (ok) top.insert(e);
      ev += cnt.evaluated;
      pf += cnt.pruned;
      pc += cnt.clip_pruned;
    };
    // The candidates the seeding evaluated (by index in `cands`).
    std::vector<std::uint8_t> seeded(cands.size(), 0);
    // The group's candidates not seeded (bounds 0).
    auto unseeded = [&](const Group& grp, std::vector<Work>& work) {
      work.clear();
      for (std::size_t i = grp.first; i < grp.first + grp.count; ++i)
        if (!seeded[i])
          work.push_back({0.0, skels[cands[i].first]->clips[cands[i].second].clip, cands[i].first,
                          cands[i].second, i});
    };
    // The same with their clip bounds when bounded.
    auto group_work = [&](const Group& grp, std::vector<Work>& work) {
      unseeded(grp, work);
      if (!bounded || work.empty()) return;
      // The group's clip bounds: one lane-major tile per side.
      const std::size_t gk = cands[grp.first].first;
      const std::size_t g = cands[grp.first].second / kGroup;
      const float* xa = clip_lbs(gk, h, g);
      const float* xb = clip_lbs(gk, h + 1, g);
      for (Work& w : work) w.lb = clip_bound(w.k, w.r, xa[w.r % kLanes], xb[w.r % kLanes]);
    };
    auto by_bound = [](const Work& x, const Work& y) {
      if (x.lb != y.lb) return x.lb < y.lb;
      return x.clip < y.clip;
    };
    // Seeding (docs/search.md "Search order"): best-first over the groups
    // (by group bound) and the clips of the groups opened (by clip bound)
    // until 2r clips are evaluated, so that tau is finite and low before the
    // sweep below; those clips are skipped there. One thread: the 2r clips
    // of least bound among the groups of least bound, in the order of their
    // bounds, wherever they lie.
    if (bounded) {
      Scratch& sc = scratch.local();
      std::uint64_t ev = 0, pf = 0, pc = 0;
      std::vector<Work> pool, work;
      auto later = [&](const Work& x, const Work& y) { return by_bound(y, x); };
      std::size_t next = 0, done = 0;
      while (done < 2 * q.top) {
        if (next < groups.size() && (pool.empty() || !(pool.front().lb < groups[next].lb))) {
          group_work(groups[next++], work);
          for (const Work& w : work) {
            pool.push_back(w);
            std::push_heap(pool.begin(), pool.end(), later);
          }
          continue;
        }
        if (pool.empty()) break;
        std::pop_heap(pool.begin(), pool.end(), later);
        const Work w = pool.back();
        pool.pop_back();
        const double tau = top.tau();
        // Every bound left is at least this one: the sweep prunes them all.
        if (safe(w.lb) > tau) break;
        eval_work(w, tau, sc, ev, pf, pc);
        seeded[w.cand] = 1;
        ++done;
      }
      evaluated += ev;
      pruned += pf;
      clips_pruned += pc;
    }
    auto run_group = [&](const Group& grp, std::vector<Work>& work) {
      std::uint64_t ev = 0, pf = 0, pc = 0;
      auto prune_all = [&](std::size_t from) {
        for (std::size_t j = from; j < work.size(); ++j) {
          pf += q.relative ? 0 : 2 * skels[work[j].k]->clips[work[j].r].frame_count;
          ++pc;
        }
      };
      Scratch& sc = scratch.local();
      if (bounded && safe(grp.lb) > top.tau()) {
        unseeded(grp, work);
        prune_all(0);
      } else {
        group_work(grp, work);
        std::sort(work.begin(), work.end(), by_bound);
        for (std::size_t i = 0; i < work.size(); ++i) {
          const double tau = top.tau();
          if (bounded && safe(work[i].lb) > tau) {
            // The rest of the group has bounds >= this one and tau only decreases.
            prune_all(i);
            break;
          }
          eval_work(work[i], tau, sc, ev, pf, pc);
        }
      }
      evaluated += ev;
      pruned += pf;
      clips_pruned += pc;
    };
    if (opt.parallel_clips) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groups.size(), 1),
                        [&](const tbb::blocked_range<std::size_t>& rg) {
                          std::vector<Work> work;
                          for (std::size_t i = rg.begin(); i != rg.end(); ++i)
                            run_group(groups[i], work);
                        });
    } else {
      std::vector<Work> work;
      for (const Group& grp : groups) run_group(grp, work);
    }
    pr.top = top.take();
    pr.stats.frames_evaluated = evaluated;
    pr.stats.frames_pruned += pruned;
    pr.stats.clips_pruned += clips_pruned;
    return pr;
  }
};

QueryOutcome SearchEngine::run(const Query& q, const SearchOptions& opt) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *impl_;
  if (q.frames.size() < 2)
    throw InputError("query " + q.id, 0, "frames: at least 2 query frames are needed");
  if (!(opt.max_length_s > 0.0))
    throw std::invalid_argument("SearchOptions::max_length_s must be > 0");
  // The query's character: the index's tables, or tables recomputed for it
  // (built once per engine and character, shared by the queries using it).
  std::shared_ptr<Impl::CharacterTables> tables;
  if (q.character) {
    Character ch;
    try {
      ch = read_character_file(*q.character);
    } catch (const InputError& e) {
      throw InputError("query " + q.id, 0, std::string("character: ") + e.what());
    }
    if (!m.character || !same_character(ch, *m.character)) {
      const std::string key = character_key(ch);
      {
        std::lock_guard lock(m.characters_mutex);
        auto it = m.characters.find(key);
        if (it == m.characters.end()) {
          // Bounded: drop the others (queries running with them keep their tables alive).
          if (m.characters.size() >= kCharacterCacheEntries) m.characters.clear();
          it = m.characters.emplace(key, std::make_shared<Impl::CharacterTables>()).first;
        }
        tables = it->second;
      }
      // Isolated (see clip_prefix): the builder's parallel_for must not run
      // another query's task that would wait on this flag.
      std::call_once(tables->once, [&] {
        tbb::this_task_arena::isolate([&] {
          try {
            for (std::uint32_t k = 0; k < m.index->skeletons().size(); ++k)
              tables->skels.push_back(make_character_skel_data(*m.index, k, ch));
          } catch (const std::exception& e) {
            tables->skels.clear();
            tables->error = e.what();
          }
        });
      });
      if (!tables->error.empty())
        throw InputError("query " + q.id, 0,
                         fmt::format("character {}: {}", q.character->string(), tables->error));
    }
  }
  const auto& skels = tables ? tables->skels : m.skels;
  QueryRunner run(m, q, opt, skels);
  run.resolved.resize(skels.size());
  run.bounds.resize(skels.size());
  // Each frame's BVH file is looked up once, for the first skeleton.
  std::vector<std::shared_ptr<const QueryBvhFile>> files(q.frames.size());
  for (std::size_t k = 0; k < skels.size(); ++k)
    for (std::size_t i = 0; i < q.frames.size(); ++i) {
      run.resolved[k].push_back(search_detail::resolve_frame(
          q, i, *skels[k]->sk, skels[k]->model, q.transition_time_s, m.t_index, m.bvh_cache,
          m.index->info().unit_option, &files[i]));
      set_needed_joints(run.resolved[k].back(), skels[k]->model);
      set_subtree_plan(run.resolved[k].back(), *skels[k], *m.index, q.transition_time_s);
      run.bounds[k].push_back(make_bound_query(run.resolved[k].back(), *skels[k]));
    }
  run.prepare_caches();
  if ((opt.mode == SearchMode::exact || opt.mode == SearchMode::approx) && !q.relative)
    run.compute_frame_bounds();
  QueryOutcome out;
  out.id = q.id;
  double recall_sum = 0.0;
  for (std::size_t h = 0; h + 1 < q.frames.size(); ++h) {
    PairRun pr = run.run_pair(h, opt.mode);
    if (opt.mode == SearchMode::approx && opt.compute_recall) {
      const PairRun ex = run.run_pair(h, SearchMode::exact);
      std::set<std::size_t> exact_clips;
      for (const Entry& e : ex.top) exact_clips.insert(e.clip);
      std::size_t hit = 0;
      for (const Entry& e : pr.top) hit += exact_clips.count(e.clip);
      recall_sum += exact_clips.empty()
                        ? 1.0
                        : static_cast<double>(hit) / static_cast<double>(exact_clips.size());
    }
    PairResults res;
    res.from = h;
    res.to = h + 1;
    for (std::size_t i = 0; i < pr.top.size(); ++i) {
      const Entry& e = pr.top[i];
      SearchResult r;
      r.rank = i + 1;
      r.clip_index = e.clip;
      const IndexClip& c = m.index->clips()[e.clip];
      r.clip = c.path;
      for (std::size_t key = 0; key < m.index->label_keys().size(); ++key)
        if (!c.labels[key].empty())
          r.labels.emplace_back(m.index->label_keys()[key], c.labels[key]);
      r.start_frame = e.s;
      r.end_frame = e.e;
      r.score_J = e.score;
      r.h_in_J = e.a;
      r.h_out_J = e.b;
      r.path_cost_J = e.cost;
      res.results.push_back(std::move(r));
    }
    out.pairs.push_back(std::move(res));
    out.stats.clips += pr.stats.clips;
    out.stats.clips_pruned += pr.stats.clips_pruned;
    out.stats.frames_evaluated += pr.stats.frames_evaluated;
    out.stats.frames_pruned += pr.stats.frames_pruned;
  }
  if (opt.mode == SearchMode::approx && opt.compute_recall)
    out.stats.recall = recall_sum / static_cast<double>(q.frames.size() - 1);
  out.stats.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void SearchEngine::frame_bounds(const Query& q, std::size_t i, std::size_t k,
                                std::vector<double>& lower, std::vector<double>& h,
                                std::vector<double>* engine_h, std::vector<double>* sketch_lower,
                                std::vector<double>* chain_lower,
                                std::vector<double>* partial_lower,
                                std::vector<double>* partial_reference) const {
  const Impl& m = *impl_;
  if (k >= m.skels.size() || i >= q.frames.size())
    throw std::invalid_argument("frame_bounds: no such skeleton or frame");
  const SkelData& sd = *m.skels[k];
  ResolvedFrame f =
      search_detail::resolve_frame(q, i, *sd.sk, sd.model, q.transition_time_s, m.t_index,
                                   m.bvh_cache, m.index->info().unit_option);
  set_needed_joints(f, sd.model);
  const std::size_t n = sd.sk->frame_count;
  lower.assign(n, 0.0);
  h.assign(n, kInf);
  if (sketch_lower != nullptr) sketch_lower->assign(n, 0.0);
  if (chain_lower != nullptr) chain_lower->assign(n, 0.0);
  Scratch sc;
  if (partial_reference != nullptr) partial_reference->assign(n, 0.0);
  if (f.kind == FrameKind::partial) {
    PartialBoundPlan plan = make_partial_bound_plan(f, sd, q.transition_time_s);
    const FrameArrays& fa = frame_arrays(*m.index, sd);
    if (partial_reference != nullptr)
      partial_frame_bounds_reference(plan, sd, fa, 0, n, partial_reference->data(), sc);
    attach_columns(plan, sd, *m.index);
    partial_frame_bounds(plan, sd, &fa, 0, n, lower.data(), sc);
  }
  if (partial_lower != nullptr) *partial_lower = lower;
  const BoundQuery bq = make_bound_query(f, sd);
  // The clip and group levels (run_pair's group_bounds and clip_tile_bounds):
  // each is a lower bound for every frame of its clips, so it joins the maximum.
  std::vector<float> clip_lb(sd.clips.size(), 0.0f), group_lb;
  group_bounds(bq, sd, group_lb);
  for (std::size_t g = 0; g * kGroup < sd.clips.size(); ++g) {
    float tile[kLanes];
    clip_tile_bounds(bq, sd, g, tile);
    const float group = group_lb[g];
    for (std::size_t r = g * kGroup; r < std::min(sd.clips.size(), g * kGroup + kGroup); ++r)
      clip_lb[r] = std::max(tile[r % kLanes], group);
  }
  for (std::size_t r = 0; r < sd.clips.size(); ++r) {
    const ClipInfo& ci = sd.clips[r];
    for (std::size_t g = ci.frame_start; g < ci.frame_start + ci.frame_count; ++g)
      lower[g] = std::max(lower[g], static_cast<double>(clip_lb[r]));
  }
  for (const ClipInfo& ci : sd.clips)
    for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
      const std::size_t row = ci.block_start + bl;
      const double x = block_box_bound(bq, sd, row);
      const std::size_t g0 = ci.frame_start + bl * kBlock,
                        g1 = ci.frame_start + std::min(ci.frame_count, bl * kBlock + kBlock);
      const float* sketch = sd.sketch.data() + row * kSketchFields * kBlock;
      float chain[kBlock];
      if (bq.kind == FrameKind::full)
        chain_sketch_bounds(bq.chain_sketch.data(),
                            sd.chain_sketch.data() + row * sd.chains * kSketchFields * kBlock,
                            sd.chains, chain);
      for (std::size_t g = g0; g < g1; ++g) {
        lower[g] = std::max(lower[g], x);
        if (bq.kind == FrameKind::full) {
          const std::size_t l = g - g0;
          const auto whole = static_cast<double>(
              sketch_term(bq.sketch.data(), sketch[l], sketch[kBlock + l], sketch[2 * kBlock + l],
                          sketch[3 * kBlock + l], sketch[4 * kBlock + l]));
          lower[g] = std::max({lower[g], whole, static_cast<double>(chain[l])});
          if (sketch_lower != nullptr) (*sketch_lower)[g] = whole;
          if (chain_lower != nullptr) (*chain_lower)[g] = chain[l];
        }
      }
      const HScanView tile = sd.tile(row, g1 - g0);
      evaluate(f, sd, *m.index, q.transition_time_s, g0, g1, h.data() + g0, sc, std::nullopt,
               nullptr, &tile);
    }
  if (engine_h != nullptr) {
    *engine_h = h;
    set_subtree_plan(f, sd, *m.index, q.transition_time_s);
    if (!f.subtree.empty()) subtree_energy(f, sd, 0, n, engine_h->data(), sc);
  }
}

// ---------------------------------------------------------------------------
// Batches and output

std::vector<BatchEntry> read_query_batch(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open the query file");
  std::vector<BatchEntry> out;
  std::string line;
  std::size_t n = 0;
  const std::filesystem::path base = path.parent_path();
  while (std::getline(in, line)) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    BatchEntry e;
    e.id = fmt::format("line {}", n);
    try {
      e.query = parse_query_text(line, path.string(), n, base, e.id);
      e.id = e.query->id;
    } catch (const InputError& err) {
      // Keep the id when the line is valid JSON with one.
      try {
        const auto j = nlohmann::json::parse(line);
        if (j.is_object() && j.contains("id") && j["id"].is_string())
          e.id = j["id"].get<std::string>();
        if (j.is_object() && j.contains("id") && j["id"].is_number_integer())
          e.id = std::to_string(j["id"].get<long long>());
      } catch (const nlohmann::json::exception&) {
      }
      e.error = err.what();
    }
    out.push_back(std::move(e));
  }
  return out;
}

std::vector<BatchEntry> read_single_query(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open the query file");
  std::stringstream ss;
  ss << in.rdbuf();
  BatchEntry e;
  e.id = path.stem().string();
  try {
    e.query = parse_query_text(ss.str(), path.string(), 0, path.parent_path(), e.id);
    e.id = e.query->id;
  } catch (const InputError& err) {
    e.error = err.what();
  }
  return {std::move(e)};
}

void SearchEngine::prepare(const SearchOptions& options, bool whole_body_frames) const {
  for (const auto& sd : impl_->skels) {
    if (whole_body_frames) frame_arrays(*impl_->index, *sd);
    if (options.mode == SearchMode::approx) ensure_forest(*impl_->index, *sd, options);
  }
}

namespace {
// Whether a query frame surely moves the whole body other than by a root
// position alone (a heading, or a root position with joint rotations), so
// that partial_approximate_energy reads the frame arrays. A frame giving
// joint rotations alone moves the whole body when one is the root's: the
// arrays are then loaded on first use. Full frames, root positions alone and
// joint rotations alone read none (joint rotations: per-joint columns,
// streamed on first use).
bool reads_frame_arrays(const QueryFrameSpec& f) {
  if (f.bvh && f.only.empty()) return false;
  bool root_position = false, heading = f.root_heading_deg.has_value(), joints = !f.joints.empty();
  for (const auto& c : f.root_position_m) root_position = root_position || c.has_value();
  for (const std::string& o : f.only) {
    if (o == "root_position" || o == "root_position_xz")
      root_position = true;
    else if (o == "root_heading")
      heading = true;
    else
      joints = true;
  }
  return heading || (root_position && joints);
}
}  // namespace

std::vector<QueryOutcome> run_query_batch(
    const SearchEngine& engine, const std::vector<BatchEntry>& batch, const SearchOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress) {
  bool whole_body = false;
  for (const BatchEntry& e : batch)
    if (e.query)
      for (const QueryFrameSpec& f : e.query->frames)
        whole_body = whole_body || reads_frame_arrays(f);
  engine.prepare(options, whole_body);
  std::vector<QueryOutcome> out(batch.size());
  std::mutex progress_mutex;
  std::size_t done = 0;
  tbb::parallel_for(std::size_t{0}, batch.size(), [&](std::size_t i) {
    const BatchEntry& e = batch[i];
    if (!e.query) {
      out[i].id = e.id;
      out[i].error = e.error;
    } else {
      try {
        out[i] = engine.run(*e.query, options);
      } catch (const std::exception& err) {
        out[i] = QueryOutcome{};
        out[i].id = e.id;
        out[i].error = err.what();
      }
    }
    if (progress) {
      std::lock_guard lock(progress_mutex);
      progress(++done, batch.size());
    }
  });
  return out;
}

std::string query_outcome_json(const QueryOutcome& o) {
  nlohmann::ordered_json j;
  j["id"] = o.id;
  if (o.error) {
    j["error"] = *o.error;
    return j.dump();
  }
  j["pairs"] = nlohmann::ordered_json::array();
  for (const PairResults& p : o.pairs) {
    nlohmann::ordered_json pj;
    pj["from"] = p.from;
    pj["to"] = p.to;
    pj["results"] = nlohmann::ordered_json::array();
    for (const SearchResult& r : p.results) {
      nlohmann::ordered_json rj;
      rj["rank"] = r.rank;
      rj["clip"] = r.clip;
      rj["clip_index"] = r.clip_index;
      nlohmann::ordered_json labels = nlohmann::ordered_json::object();
      for (const auto& [k, v] : r.labels) labels[k] = v;
      rj["labels"] = labels;
      rj["start_frame"] = r.start_frame;
      rj["end_frame"] = r.end_frame;
      rj["score_J"] = r.score_J;
      rj["h_in_J"] = r.h_in_J;
      rj["h_out_J"] = r.h_out_J;
      rj["path_cost_J"] = r.path_cost_J;
      pj["results"].push_back(std::move(rj));
    }
    j["pairs"].push_back(std::move(pj));
  }
  nlohmann::ordered_json s;
  s["clips"] = o.stats.clips;
  s["clips_pruned"] = o.stats.clips_pruned;
  s["frames_evaluated"] = o.stats.frames_evaluated;
  s["frames_pruned"] = o.stats.frames_pruned;
  s["time_ms"] = o.stats.time_ms;
  if (o.stats.recall) s["recall"] = *o.stats.recall;
  j["stats"] = s;
  return j.dump();
}

}  // namespace mocap
