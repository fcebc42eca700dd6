// Building a skeleton's bound tables (bound_tables.hpp).
#include "bounds/bound_tables.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "mocap/common/util/half.hpp"
#include "mocap/common/util/memory.hpp"

namespace mocap::search_detail {

void init_scan_tiles(SkeletonTables& tables) {
  const std::size_t blocks = tables.clips.empty()
                                 ? 0
                                 : tables.clips.back().block_start +
                                       (tables.clips.back().frame_count + kBlock - 1) / kBlock;
  // Tiles: rows of `stride` floats (kBlock: whole 64-byte lines), each tile
  // starting on a line; the first one aligned. A clip's last block has its
  // frame count as its stride. A line more at the end: the relative bounds
  // read whole kBlock-lane rows (the lanes past a short tile's are dropped).
  constexpr std::size_t kLine = 64 / sizeof(float);
  static_assert(kBlock % kLine == 0, "a tile row is whole cache lines");
  auto line_offset = [](const std::vector<float>& v) {
    const auto a = reinterpret_cast<std::uintptr_t>(v.data()) / sizeof(float);
    return (kLine - a % kLine) % kLine;
  };
  const std::size_t rows = tables.segments * HScanTable::kFields;
  tables.tile_lines.assign(blocks, 0);
  tables.tile_strides.assign(blocks, 0);
  std::size_t lines = 0;
  for (const ClipInfo& ci : tables.clips)
    for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
      const std::size_t stride = std::min(kBlock, ci.frame_count - bl * kBlock);
      if (lines > std::numeric_limits<std::uint32_t>::max())
        throw std::length_error("search tables: more than 2^32 tile lines");
      tables.tile_lines[ci.block_start + bl] = static_cast<std::uint32_t>(lines);
      tables.tile_strides[ci.block_start + bl] = static_cast<std::uint8_t>(stride);
      lines += (rows * stride + kLine - 1) / kLine;
    }
  assign_huge(tables.tile_values, (lines + 2) * kLine, 0.0f);
  tables.tile_offset = line_offset(tables.tile_values);
  tables.root_positions.assign(3 * tables.frame_count, 0.0f);
}

void set_tile_rows(SkeletonTables& tables, std::size_t first, std::size_t count,
                   const float* rows) {
  const std::size_t w = tables.segments * HScanTable::kFields;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 2048),
                    [&](const tbb::blocked_range<std::size_t>& rg) {
                      for (std::size_t i = rg.begin(); i != rg.end(); ++i) {
                        const std::size_t g = first + i;
                        const ClipInfo& ci = tables.clips[tables.frame_row[g]];
                        const std::size_t local = g - ci.frame_start;
                        const std::size_t block = ci.block_start + local / kBlock;
                        const std::size_t stride = tables.tile_stride(block);
                        float* tile = tables.tile_data(block) + local % kBlock;
                        const float* row = rows + i * w;
                        for (std::size_t f = 0; f < w; ++f) tile[f * stride] = row[f];
                      }
                    });
}

void set_root_rows(SkeletonTables& tables, std::size_t first, std::size_t count,
                   const float* rows) {
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t a = 0; a < 3; ++a)
      tables.root_positions[a * tables.frame_count + first + i] = rows[i * 3 + a];
}

void set_tiles_from_table(SkeletonTables& tables, const HScanTable& table) {
  const std::size_t w = tables.segments * HScanTable::kFields;
  tbb::parallel_for(std::size_t{0}, tables.clips.size(), [&](std::size_t r) {
    const ClipInfo& ci = tables.clips[r];
    std::vector<float> rows(ci.frame_count * w), roots(ci.frame_count * 3);
    for (std::size_t f = 0; f < w; ++f)
      for (std::size_t i = 0; i < ci.frame_count; ++i)
        rows[i * w + f] = table.values[f * table.stride + ci.frame_start + i];
    for (std::size_t a = 0; a < 3; ++a)
      for (std::size_t i = 0; i < ci.frame_count; ++i)
        roots[i * 3 + a] = table.root_positions[a * table.stride + ci.frame_start + i];
    set_tile_rows(tables, ci.frame_start, ci.frame_count, rows.data());
    set_root_rows(tables, ci.frame_start, ci.frame_count, roots.data());
  });
}

namespace {

// A box row of kBoundFields rows of `padded` floats (segments `real` of
// them) and its root box (min xyz, max xyz).
struct BoxShape {
  std::size_t s, real, w;  // padded row length, real segments, floats per box row
};

constexpr float kInfF = std::numeric_limits<float>::infinity();

// An empty box: minima +inf and maxima -inf over the real segments (the
// padding stays 0: a zero box and zero query constants make a zero term).
void init_box(const BoxShape& sh, float* row, float* root) {
  for (std::size_t f = 0; f < 3; ++f)
    for (std::size_t b = 0; b < sh.real; ++b) {
      row[f * sh.s + b] = kInfF;
      row[(f + 3) * sh.s + b] = -kInfF;
    }
  for (std::size_t b = 0; b < sh.real; ++b) {
    row[6 * sh.s + b] = row[8 * sh.s + b] = kInfF;
    row[7 * sh.s + b] = row[9 * sh.s + b] = -kInfF;
  }
  for (std::size_t a = 0; a < 3; ++a) {
    root[a] = kInfF;
    root[a + 3] = -kInfF;
  }
}

// Widens the box `row` (bound row and root box) to hold the box `from`.
void unite_box(const BoxShape& sh, float* row, float* root, const float* from,
               const float* from_root) {
  for (std::size_t i = 0; i < sh.w; ++i)
    row[i] = is_min_bound_field(i / sh.s) ? std::min(row[i], from[i]) : std::max(row[i], from[i]);
  for (std::size_t a = 0; a < 3; ++a) {
    root[a] = std::min(root[a], from_root[a]);
    root[a + 3] = std::max(root[a + 3], from_root[a + 3]);
  }
}

// The whole-body sketch and the chain sketches (as halves) of each frame of
// block `block` (count frames, in its tile), lane l of the block's rows;
// lanes past count repeat its last frame.
void block_sketches(SkeletonTables& tables, std::size_t block, std::size_t count,
                    std::vector<std::array<double, kSketchFields>>& chain_values) {
  const float* tile = tables.tile_data(block);
  const std::size_t stride = tables.tile_stride(block);
  auto value = [&](std::size_t b, std::size_t q, std::size_t l) {
    return tile[(b * HScanTable::kFields + q) * stride + l];
  };
  float* sketch = tables.sketch.data() + block * kSketchFields * kBlock;
  std::uint16_t* chain =
      tables.chain_sketch.data() + block * tables.chains * kSketchFields * kBlock;
  for (std::size_t l = 0; l < kBlock; ++l) {
    const std::size_t g = std::min(l, count - 1);
    auto com = [&](std::size_t b, std::size_t a) { return value(b, HScanField::com_x + a, g); };
    auto ke = [&](std::size_t b) { return value(b, HScanField::kinetic, g); };
    auto rot = [&](std::size_t b) { return value(b, HScanField::kinetic_rot, g); };
    const auto v = whole_body_sketch(tables, com, ke, rot);
    for (std::size_t i = 0; i < kSketchFields; ++i)
      sketch[i * kBlock + l] = static_cast<float>(v[i]);
    chain_sketches(tables, com, ke, rot, chain_values.data());
    for (std::size_t ch = 0; ch < tables.chains; ++ch)
      for (std::size_t i = 0; i < kSketchFields; ++i)
        chain[(ch * kSketchFields + i) * kBlock + l] =
            float_to_half_nearest(static_cast<float>(chain_values[ch][i]));
  }
}

// The box of block `block` (count frames from frame g0): per segment the
// least and greatest COM x y z, KE and KE_rot of its frames (m, J), and its
// roots' box, into row and root (init_box'ed).
void block_box_row(const SkeletonTables& tables, const BoxShape& sh, std::size_t block,
                   std::size_t g0, std::size_t count, float* row, float* root) {
  const float* tile = tables.tile_data(block);
  const std::size_t stride = tables.tile_stride(block);
  using F = HScanField;
  // Scan fields COM x y z, KE, KE_rot -> (min, max) bound fields.
  constexpr std::size_t src[5] = {F::com_x, F::com_y, F::com_z, F::kinetic, F::kinetic_rot},
                        lo_f[5] = {0, 1, 2, 6, 8}, hi_f[5] = {3, 4, 5, 7, 9};
  for (std::size_t b = 0; b < sh.real; ++b)
    for (std::size_t i = 0; i < 5; ++i) {
      float& lo = row[lo_f[i] * sh.s + b];
      float& hi = row[hi_f[i] * sh.s + b];
      const float* v = tile + (b * HScanTable::kFields + src[i]) * stride;
      for (std::size_t l = 0; l < count; ++l) {
        lo = std::min(lo, v[l]);
        hi = std::max(hi, v[l]);
      }
    }
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t l = 0; l < count; ++l) {
      const float v = tables.root_position(a, g0 + l);
      root[a] = std::min(root[a], v);
      root[a + 3] = std::max(root[a + 3], v);
    }
}

// Clip r's block rows (sketches, chain sketches, boxes) and its clip row,
// the union of its blocks' boxes.
void clip_bound_rows(SkeletonTables& tables, const BoxShape& sh, std::size_t r) {
  const ClipInfo& ci = tables.clips[r];
  std::vector<std::array<double, kSketchFields>> chain_values(tables.chains);
  float* crow = tables.clip_bounds.data() + r * sh.w;
  float* croot = tables.clip_root.data() + r * 6;
  init_box(sh, crow, croot);
  for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
    const std::size_t block = ci.block_start + bl;
    float* row = tables.block_bounds.data() + block * sh.w;
    float* root = tables.block_root.data() + block * 6;
    init_box(sh, row, root);
    const std::size_t g0 = ci.frame_start + bl * kBlock,
                      g1 = ci.frame_start + std::min(ci.frame_count, bl * kBlock + kBlock);
    block_sketches(tables, block, g1 - g0, chain_values);
    block_box_row(tables, sh, block, g0, g1 - g0, row, root);
    unite_box(sh, crow, croot, row, root);
  }
}

// Lane-major copies (box_bounds_lanes) of `count` box rows and root boxes:
// tile t holds rows [kLanes t, kLanes t + kLanes) as [kBoundFields][real]
// [kLanes] floats and [6][kLanes] (unused lanes zero).
void lane_major(const BoxShape& sh, const std::vector<float>& rows, const std::vector<float>& roots,
                std::size_t count, std::vector<float>& out, std::vector<float>& out_root) {
  const std::size_t tiles = (count + kLanes - 1) / kLanes, tw = kBoundFields * sh.real * kLanes;
  out.assign(tiles * tw, 0.0f);
  out_root.assign(tiles * 6 * kLanes, 0.0f);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t t = i / kLanes, l = i % kLanes;
    for (std::size_t f = 0; f < kBoundFields; ++f)
      for (std::size_t b = 0; b < sh.real; ++b)
        out[t * tw + (f * sh.real + b) * kLanes + l] = rows[i * sh.w + f * sh.s + b];
    for (std::size_t a = 0; a < 6; ++a) out_root[(t * 6 + a) * kLanes + l] = roots[i * 6 + a];
  }
}

// Sketch ranges of the clips (lane-major, clip_sketch_soa) and of the groups
// of kGroup clips (group_sketch_soa), from the block sketches; an empty
// clip's range is 0.
void sketch_ranges(SkeletonTables& tables, std::size_t groups) {
  tables.clip_sketch_soa.assign(groups * kSketchRange * kLanes, 0.0f);
  const std::size_t group_tiles = (groups + kLanes - 1) / kLanes;
  tables.group_sketch_soa.assign(group_tiles * kSketchRange * kLanes, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    std::array<float, kSketchRange> grange;
    for (std::size_t i = 0; i < kSketchFields; ++i) {
      grange[i] = kInfF;
      grange[kSketchFields + i] = -kInfF;
    }
    for (std::size_t r = g * kGroup; r < std::min(tables.clips.size(), g * kGroup + kGroup); ++r) {
      const ClipInfo& ci = tables.clips[r];
      float* tile = tables.clip_sketch_soa.data() + g * kSketchRange * kLanes;
      const std::size_t l = r % kLanes;
      for (std::size_t i = 0; i < kSketchFields; ++i) {
        float lo = kInfF, hi = -kInfF;
        for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
          const float* v =
              tables.sketch.data() + ((ci.block_start + bl) * kSketchFields + i) * kBlock;
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
      tables.group_sketch_soa[((g / kLanes) * kSketchRange + i) * kLanes + g % kLanes] = grange[i];
  }
}

}  // namespace

// Block and clip bound tables from the scan tiles (parallel over clips).
void build_bound_tables(SkeletonTables& tables) {
  // Rows of `padded` floats; the padding stays 0 (a zero box and zero query
  // constants make a zero term).
  const BoxShape sh{tables.padded, tables.segments, kBoundFields * tables.padded};
  const std::size_t w = sh.w;
  const std::size_t blocks = tables.clips.empty()
                                 ? 0
                                 : tables.clips.back().block_start +
                                       (tables.clips.back().frame_count + kBlock - 1) / kBlock;
  tables.block_bounds.assign(blocks * w, 0.0f);
  tables.block_root.assign(blocks * 6, 0.0f);
  tables.clip_bounds.assign(tables.clips.size() * w, 0.0f);
  tables.clip_root.assign(tables.clips.size() * 6, 0.0f);
  assign_huge(tables.sketch, blocks * kSketchFields * kBlock, 0.0f);
  assign_huge(tables.chain_sketch, blocks * tables.chains * kSketchFields * kBlock,
              std::uint16_t{0});
  tbb::parallel_for(std::size_t{0}, tables.clips.size(),
                    [&](std::size_t r) { clip_bound_rows(tables, sh, r); });
  // The blocks' rows as halves rounded outwards; the float rows are not needed any more.
  assign_huge(tables.block_box, tables.block_bounds.size(), std::uint16_t{0});
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t row) {
    for (std::size_t i = 0; i < w; ++i)
      tables.block_box[row * w + i] =
          float_to_half(tables.block_bounds[row * w + i], !is_min_bound_field(i / sh.s));
  });
  std::vector<float>().swap(tables.block_bounds);
  lane_major(sh, tables.clip_bounds, tables.clip_root, tables.clips.size(), tables.clip_soa,
             tables.clip_root_soa);
  const std::size_t groups = (tables.clips.size() + kGroup - 1) / kGroup;
  sketch_ranges(tables, groups);
  std::vector<float> group_rows(groups * w, 0.0f), group_root(groups * 6, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    float* grow = group_rows.data() + g * w;
    float* groot = group_root.data() + g * 6;
    init_box(sh, grow, groot);
    for (std::size_t r = g * kGroup; r < std::min(tables.clips.size(), g * kGroup + kGroup); ++r)
      unite_box(sh, grow, groot, tables.clip_bounds.data() + r * w,
                tables.clip_root.data() + r * 6);
  }
  lane_major(sh, group_rows, group_root, groups, tables.group_soa, tables.group_root_soa);
  // The clip rows live on in their lane-major copies.
  std::vector<float>().swap(tables.clip_bounds);
  std::vector<float>().swap(tables.clip_root);
}

}  // namespace mocap::search_detail
