#pragma once
// Internal to mocap_search: what the engine keeps per index skeleton. Three
// parts with three lifetimes:
//  - SkeletonTables: immutable once built (the engine's constructor, or a
//    query character's first query): model constants, clip rows, the h scan
//    table as 16-frame tiles, the root positions, box-bound and sketch
//    tables (bound_tables.hpp); read concurrently without locks;
//  - CharacterFrames: a query character's own per-frame arrays (positions,
//    COMs, velocities, kd features recomputed for its bone lengths and body),
//    also immutable; absent for the index's character;
//  - SkeletonCaches: what is loaded on first use (frame arrays, per-joint
//    columns, a query character's energy prefix sums, the FLANN forest),
//    each behind a once_flag or a mutex; the accessors below are thread-safe.
// SkeletonData holds the three. Units: metres, joules, kg, seconds.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/search.hpp"
#include "scan/flann_knn.hpp"

namespace mocap::search_detail {

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
constexpr std::size_t kSketchRange = 2 * kSketchFields;      // min fields, then max fields
constexpr std::size_t kSketchConstants = kSketchFields + 2;  // a query's: fields, M g, M / T^2
static_assert(kGroup == kLanes, "a group's clip bounds are one lane-major tile");

// One clip of a skeleton (clip rows are the skeleton's clips in index order).
struct ClipInfo {
  std::size_t clip = 0;         // global clip index
  std::size_t frame_start = 0;  // skeleton row of frame 0
  std::size_t frame_count = 0;
  std::size_t block_start = 0;  // row of block 0 in the block tables (16-frame blocks)
  std::size_t row = 0;          // the clip's row in the index's clip table
  double frame_time_s = 0.0;    // the clip's frame time (frame_ref's rates)
};

// The per-frame arrays partial_approximate_energy reads (frame_ref), row
// major [N][J][3 or 4]: joint positions, world rotations, angular
// velocities, local rotations. Segment COMs and their velocities are not
// kept: frame_ref makes them for the frames it evaluates from the positions
// and rotations of the frame and its clip neighbours (sequence_state's
// differences).
struct FrameArrays {
  const float *pos, *rot, *angvel, *lrot;
};

// The immutable tables of one skeleton for one character.
struct SkeletonTables {
  std::uint32_t k = 0;                // skeleton index in the Index
  const IndexSkeleton* sk = nullptr;  // the index's, or CharacterFrames::skeleton
  DynamicsModel model;
  std::size_t frame_count = 0;  // the skeleton's frames (N)
  std::size_t segments = 0;
  std::size_t padded = 0;      // segments rounded up to a multiple of 8 (bound tables)
  std::vector<double> masses;  // per segment
  double segment_mass = 0.0;
  std::vector<double> lambda_min;        // per segment: smallest principal moment (kg m^2)
  std::vector<int> segment_of_joint;     // joint -> segment index, -1 if massless
  std::vector<ClipInfo> clips;           // by row
  std::vector<std::uint32_t> frame_row;  // skeleton frame -> clip row
  // The h scan table (energy.hpp HScanTable's values: per segment COM x y z,
  // KE, orientation w x y z, KE_rot), held once, as one tile per 16-frame
  // block (the blocks of block_bounds): a block's 16 x S x 9 values are
  // contiguous, so scanning a block reads 12 KB in one stream instead of
  // S x 9 rows far apart. Block `row`'s tile is HScanTable's layout with
  // stride tile_stride(row) at tile_data(row) (64-byte aligned, on huge
  // pages: assign_huge): kBlock, or for a clip's last block its frame count
  // (a short tile holds no unused lanes). Its root rows are those of
  // root_positions (below). Every reader of the scan values
  // (scans, bounds, relative placements, partial bounds, the subtree kernel) reads these very
  // floats, so exact and brute see the same values. scan_value and for_each_tile_piece find a
  // skeleton frame's tile and lane.
  std::vector<float> tile_values;
  std::size_t tile_offset = 0;
  // Per block: where its tile starts, in 64-byte lines after tile_offset,
  // and its stride (its frame count, kBlock but for a clip's last block).
  std::vector<std::uint32_t> tile_lines;
  std::vector<std::uint8_t> tile_strides;
  // Block `row`'s tile, `frames` frames of it (<= its stride); g0 is the
  // skeleton frame of its lane 0.
  HScanView tile(std::size_t row, std::size_t g0, std::size_t frames) const {
    return {tile_data(row),   root_positions.data() + g0, frames,
            tile_stride(row), model.segments.size(),      frame_count};
  }
  // Block `row`'s tile values: field (b, q) of lane l at [(b * 9 + q) * tile_stride(row) + l].
  const float* tile_data(std::size_t row) const {
    return tile_values.data() + tile_offset + std::size_t{tile_lines[row]} * 16;
  }
  float* tile_data(std::size_t row) {
    return tile_values.data() + tile_offset + std::size_t{tile_lines[row]} * 16;
  }
  std::size_t tile_stride(std::size_t row) const { return tile_strides[row]; }
  // Field q (HScanTable order) of segment b at skeleton frame g.
  float scan_value(std::size_t b, std::size_t q, std::size_t g) const {
    const ClipInfo& ci = clips[frame_row[g]];
    const std::size_t local = g - ci.frame_start;
    const std::size_t row = ci.block_start + local / kBlock;
    return tile_data(row)[(b * HScanTable::kFields + q) * tile_stride(row) + local % kBlock];
  }
  // Calls fn(row, lane, count, offset) for the pieces of skeleton frames
  // [g0, g1) that lie in one tile each, in frame order: frames
  // [g0 + offset, g0 + offset + count) are lanes [lane, lane + count) of
  // block `row`.
  template <class Fn>
  void for_each_tile_piece(std::size_t g0, std::size_t g1, Fn&& fn) const {
    std::size_t g = g0;
    while (g < g1) {
      const ClipInfo& ci = clips[frame_row[g]];
      const std::size_t local = g - ci.frame_start, lane = local % kBlock;
      const std::size_t end = std::min({g1, ci.frame_start + ci.frame_count, g + (kBlock - lane)});
      fn(ci.block_start + local / kBlock, lane, end - g, g - g0);
      g = end;
    }
  }
  // The root joint's world position of every frame, [3][frame_count]
  // floats (x row, y row, z row; metres): root_position(a, g).
  std::vector<float> root_positions;
  float root_position(std::size_t a, std::size_t g) const {
    return root_positions[a * frame_count + g];
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
  // IEEE halves rounded to nearest (float_to_half_nearest: each value lies
  // within half_nearest_radius of its half, and the bound is evaluated on
  // those intervals, so it stays a lower bound; half the bytes of floats);
  // chain_mass[c] = the chain's total segment mass (kg).
  std::size_t chains = 0;
  std::vector<std::uint32_t> chain_of_segment;
  std::vector<double> chain_mass;
  std::vector<std::uint16_t> chain_sketch;
  // kd features [N][S*3] of a query character (CharacterFrames::kd_features);
  // null for the index's character: ensure_forest reads the index's on first use.
  const float* kd = nullptr;
  // The index's energy prefix sums of the skeleton's frames (Index::array
  // locks a mutex: fetched once, not per clip); null for a query character.
  const double* prefix_index = nullptr;
  // Row stride of the per-joint columns (SkeletonCaches::columns): the frame
  // count rounded up to a multiple of 16.
  std::size_t col_stride = 0;
};

// A query character's per-frame data on one skeleton: the index's skeleton
// with the character's length scales and body, and the character-dependent
// frame arrays recomputed from the stored world pose (joint positions moved
// for the new bone lengths, rotations unchanged), [N][J][3] floats.
struct CharacterFrames {
  IndexSkeleton skeleton;
  std::vector<double> joint_ratio;  // bone length ratio per joint (1 = the index's)
  std::vector<float> joint_positions_m;
  std::vector<float> kd_features;  // [N][S*3]
};

// The frame-array columns of joint-rotation frames (SkeletonCaches::columns).
enum class JointColumn : std::size_t { local_rotation = 0, world_rotation = 1, position = 2 };
constexpr std::size_t kJointColumnKinds = 3;

// What a skeleton loads on first use (accessors below; thread-safe).
struct SkeletonCaches {
  // Frame arrays for partial queries (index arrays; a query character's
  // character-dependent ones are its own).
  std::once_flag frames_once;
  FrameArrays frames{};
  // Per-joint columns of the frame arrays for joint-rotation frames (their
  // per-frame bound, partial_bounds_columns, and the subtree kernel,
  // subtree_energy_lanes): column kind * joints + joint holds the joint's
  // components (w x y z for rotations, x y z for positions) as rows of
  // SkeletonTables::col_stride floats, one value per skeleton frame. Made on
  // first use (ensure_columns, under columns_mutex: streamed from the index
  // array, the array itself not kept), then read-only.
  std::mutex columns_mutex;
  std::unique_ptr<std::unique_ptr<float[]>[]> columns;
  // Per segment b, its translational and rotational kinetic energy (scan
  // fields 3 and 8, J) as one row each of col_stride floats, one value per
  // skeleton frame, at segment_columns[2 b] and [2 b + 1]: the field-major
  // reads of partial_bounds_columns. Copied from the tiles on first use
  // (ensure_segment_columns, under columns_mutex), then read-only.
  std::unique_ptr<std::unique_ptr<float[]>[]> segment_columns;
  // A query character's energy prefix sums (lambda > 0), built on first use.
  std::once_flag prefix_once;
  std::vector<double> prefix;
  // Each frame's root heading (relative placements; relative_frames.hpp).
  std::once_flag headings_once;
  std::vector<double> headings;
  // cos and sin of each heading (interleaved), for placing points quickly.
  std::vector<double> heading_cos_sin;
  // Each frame's translational and rotational kinetic energy summed over the
  // segments, J (root-only bounds of relative placements; relative_bounds.hpp).
  std::once_flag kinetic_once;
  std::vector<float> kinetic, kinetic_rot;
  // Per frame, the moments a turn of the whole body about the vertical
  // through its root needs (root frames giving a heading;
  // relative_bounds.hpp frame_turn_moments), made on first use.
  std::once_flag turn_once;
  std::vector<float> turn_moments;
  // Per clip row: ranges of the root x, y, z and of the kinetic energy
  // totals (RootBlocks's fields for the whole clip).
  std::vector<std::array<double, 9>> clip_root_boxes;
  // The FLANN forest of the frames' kd features (approx mode).
  std::once_flag forest_once;
  std::unique_ptr<KnnIndex> forest;
  // The skeleton's typical pose (retarget.hpp typical_local_rotations), for
  // query frames of other rigs: streamed from the index on first use.
  std::once_flag typical_once;
  std::vector<Eigen::Quaterniond> typical_pose;
};

// One skeleton for one character: its tables, a query character's frames
// (null for the index's character) and the lazy caches.
struct SkeletonData {
  SkeletonTables tables;
  std::unique_ptr<CharacterFrames> character;
  mutable SkeletonCaches caches;
};

// The skeleton's typical pose (SkeletonCaches::typical_pose), made on first
// use. Throws what reading the index throws.
const std::vector<Eigen::Quaterniond>& typical_pose(const Index& index,
                                                    const SkeletonData& skeleton);

// Model-derived per-segment constants, chains, clip rows, frame -> clip row;
// the caches' column slots.
void init_skeleton_data(const Index& index, std::uint32_t k, DynamicsModel model,
                        SkeletonData& skeleton);

// The index character's data of skeleton k: the h scan table and the root
// positions streamed from the index into the tiles (neither array is kept
// by the index), the energy prefix sums (the skeleton's energy_prefix_J
// array, read by the caller), then the bound tables. TBB-parallel inside.
std::unique_ptr<SkeletonData> build_index_skeleton(const Index& index, std::uint32_t k,
                                                   const double* prefix);

// The frame arrays of a skeleton (loaded once): what
// partial_approximate_energy reads through frame_ref, for partial frames that
// move the whole body (a heading, a root position with joint rotations, a
// root rotation). Joint-rotation frames read per-joint columns instead
// (ensure_columns).
const FrameArrays& frame_arrays(const Index& index, const SkeletonData& skeleton);

// Makes columns `kind` of `joints` available: one pass over the index array
// streams in the rows (Index::stream_rows: blocks of 8,192 frames, checksum
// compared) and keeps the missing joints' columns; a query character's
// positions come from its own array. Throws what the index read throws (no
// half-made column is kept). Thread-safe.
void ensure_columns(const Index& index, const SkeletonData& skeleton, JointColumn kind,
                    const std::vector<std::size_t>& joints);

// Column `kind` of joint j (after ensure_columns).
const float* joint_column(const SkeletonData& skeleton, JointColumn kind, std::size_t j);

// Makes the kinetic-energy columns of `segments` available
// (SkeletonCaches::segment_columns; copied from the tiles). Thread-safe.
void ensure_segment_columns(const SkeletonData& skeleton, const std::vector<std::size_t>& segments);

// Segment b's translational (rotational: `rot`) kinetic energy column
// (after ensure_segment_columns).
const float* segment_column(const SkeletonData& skeleton, std::size_t b, bool rot);

// The FLANN forest of the frame features (approx mode), built once (the
// index's kd_features, read then: exact and brute never need them).
void ensure_forest(const Index& index, const SkeletonData& skeleton, const SearchOptions& options);

// A clip's energy prefix sums (J, frame_count values) for the skeleton's character.
std::span<const double> clip_prefix(const Index& index, const SkeletonData& skeleton,
                                    const ClipInfo& ci);

}  // namespace mocap::search_detail
