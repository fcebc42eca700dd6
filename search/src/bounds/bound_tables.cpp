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

// Block and clip bound tables from the scan tiles (parallel over clips).
void build_bound_tables(SkeletonTables& tables) {
  // Rows of `padded` floats; the padding stays 0 (a zero box and zero query
  // constants make a zero term).
  const std::size_t s = tables.padded, w = kBoundFields * s, real = tables.segments;
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
  tbb::parallel_for(std::size_t{0}, tables.clips.size(), [&](std::size_t r) {
    const ClipInfo& ci = tables.clips[r];
    std::vector<std::array<double, kSketchFields>> chain_values(tables.chains);
    float* crow = tables.clip_bounds.data() + r * w;
    float* croot = tables.clip_root.data() + r * 6;
    init(crow, croot);
    for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
      float* row = tables.block_bounds.data() + (ci.block_start + bl) * w;
      float* root = tables.block_root.data() + (ci.block_start + bl) * 6;
      init(row, root);
      const std::size_t g0 = ci.frame_start + bl * kBlock,
                        g1 = ci.frame_start + std::min(ci.frame_count, bl * kBlock + kBlock);
      const std::size_t count = g1 - g0;
      const float* tile = tables.tile_data(ci.block_start + bl);
      const std::size_t stride = tables.tile_stride(ci.block_start + bl);
      auto value = [&](std::size_t b, std::size_t q, std::size_t l) {
        return tile[(b * HScanTable::kFields + q) * stride + l];
      };
      float* sketch = tables.sketch.data() + (ci.block_start + bl) * kSketchFields * kBlock;
      std::uint16_t* chain = tables.chain_sketch.data() +
                             (ci.block_start + bl) * tables.chains * kSketchFields * kBlock;
      for (std::size_t l = 0; l < kBlock; ++l) {
        const std::size_t g = std::min(l, count - 1);
        auto com = [&](std::size_t b, std::size_t a) { return value(b, a, g); };
        auto ke = [&](std::size_t b) { return value(b, 3, g); };
        auto rot = [&](std::size_t b) { return value(b, 8, g); };
        const auto v = whole_body_sketch(tables, com, ke, rot);
        for (std::size_t i = 0; i < kSketchFields; ++i)
          sketch[i * kBlock + l] = static_cast<float>(v[i]);
        chain_sketches(tables, com, ke, rot, chain_values.data());
        for (std::size_t ch = 0; ch < tables.chains; ++ch)
          for (std::size_t i = 0; i < kSketchFields; ++i)
            chain[(ch * kSketchFields + i) * kBlock + l] =
                float_to_half_nearest(static_cast<float>(chain_values[ch][i]));
      }
      // Scan fields COM x y z, KE, KE_rot -> (min, max) bound fields.
      constexpr std::size_t src[5] = {0, 1, 2, 3, 8}, lo_f[5] = {0, 1, 2, 6, 8},
                            hi_f[5] = {3, 4, 5, 7, 9};
      for (std::size_t b = 0; b < real; ++b)
        for (std::size_t i = 0; i < 5; ++i) {
          float& lo = row[lo_f[i] * s + b];
          float& hi = row[hi_f[i] * s + b];
          for (std::size_t l = 0; l < count; ++l) {
            lo = std::min(lo, value(b, src[i], l));
            hi = std::max(hi, value(b, src[i], l));
          }
        }
      for (std::size_t a = 0; a < 3; ++a)
        for (std::size_t l = 0; l < count; ++l) {
          const float v = tables.root_position(a, g0 + l);
          root[a] = std::min(root[a], v);
          root[a + 3] = std::max(root[a + 3], v);
        }
      unite(crow, croot, row, root);
    }
  });
  // The blocks' rows as halves rounded outwards; the float rows are not needed any more.
  assign_huge(tables.block_box, tables.block_bounds.size(), std::uint16_t{0});
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t row) {
    for (std::size_t i = 0; i < w; ++i)
      tables.block_box[row * w + i] =
          float_to_half(tables.block_bounds[row * w + i], !is_min_bound_field(i / s));
  });
  std::vector<float>().swap(tables.block_bounds);
  // Lane-major copies (box_bounds_lanes).
  auto lanes = [&](const std::vector<float>& rows, const std::vector<float>& roots,
                   std::size_t count, std::vector<float>& out, std::vector<float>& out_root) {
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
  lanes(tables.clip_bounds, tables.clip_root, tables.clips.size(), tables.clip_soa,
        tables.clip_root_soa);
  const std::size_t groups = (tables.clips.size() + kGroup - 1) / kGroup;
  // Sketch ranges of clips (lane-major) and groups, from the block sketches.
  tables.clip_sketch_soa.assign(groups * kSketchRange * kLanes, 0.0f);
  const std::size_t group_tiles = (groups + kLanes - 1) / kLanes;
  tables.group_sketch_soa.assign(group_tiles * kSketchRange * kLanes, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    std::array<float, kSketchRange> grange;
    for (std::size_t i = 0; i < kSketchFields; ++i) {
      grange[i] = inf;
      grange[kSketchFields + i] = -inf;
    }
    for (std::size_t r = g * kGroup; r < std::min(tables.clips.size(), g * kGroup + kGroup); ++r) {
      const ClipInfo& ci = tables.clips[r];
      float* tile = tables.clip_sketch_soa.data() + g * kSketchRange * kLanes;
      const std::size_t l = r % kLanes;
      for (std::size_t i = 0; i < kSketchFields; ++i) {
        float lo = inf, hi = -inf;
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
  std::vector<float> group_rows(groups * w, 0.0f), group_root(groups * 6, 0.0f);
  for (std::size_t g = 0; g < groups; ++g) {
    float* grow = group_rows.data() + g * w;
    float* groot = group_root.data() + g * 6;
    init(grow, groot);
    for (std::size_t r = g * kGroup; r < std::min(tables.clips.size(), g * kGroup + kGroup); ++r) {
      unite(grow, groot, tables.clip_bounds.data() + r * w, tables.clip_root.data() + r * 6);
    }
  }
  lanes(group_rows, group_root, groups, tables.group_soa, tables.group_root_soa);
  // The clip rows live on in their lane-major copies.
  std::vector<float>().swap(tables.clip_bounds);
  std::vector<float>().swap(tables.clip_root);
}

}  // namespace mocap::search_detail
