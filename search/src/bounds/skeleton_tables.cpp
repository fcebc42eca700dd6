// The engine's per-skeleton data: building it (model constants, clip rows,
// the h scan table from the index) and the caches loaded on first use
// (skeleton_tables.hpp).
#include "bounds/skeleton_tables.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <string_view>

#include "bounds/bound_tables.hpp"
#include "mocap/common/body/retarget.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"

namespace mocap::search_detail {

void init_skeleton_data(const Index& index, std::uint32_t k, DynamicsModel model,
                        SkeletonData& skeleton) {
  SkeletonTables& tables = skeleton.tables;
  tables.k = k;
  tables.sk = &index.skeletons()[k];
  tables.model = std::move(model);
  tables.segments = tables.model.segments.size();
  tables.padded = (tables.segments + 7) / 8 * 8;
  tables.segment_of_joint.assign(tables.model.joint_count(), -1);
  tables.frame_count = tables.sk->frame_count;
  tables.col_stride = (tables.frame_count + 15) / 16 * 16;
  skeleton.caches.columns =
      std::make_unique<std::unique_ptr<float[]>[]>(kJointColumnKinds * tables.model.joint_count());
  skeleton.caches.segment_columns =
      std::make_unique<std::unique_ptr<float[]>[]>(2 * tables.model.segments.size());
  for (int b : tables.model.segments) {
    const auto j = static_cast<std::size_t>(b);
    tables.masses.push_back(tables.model.masses_kg[j]);
    tables.segment_mass += tables.masses.back();
    // Smallest eigenvalue of the (symmetric) local inertia: w^T R I R^T w >= lambda_min |w|^2.
    const Eigen::Vector3d d = tables.model.principal_moments_kgm2[j];
    tables.lambda_min.push_back(std::max(0.0, std::min({d[0], d[1], d[2]})));
    tables.segment_of_joint[j] = static_cast<int>(tables.masses.size() - 1);
  }
  // Kinematic chains: a joint starts one unless its parent has exactly one
  // child (joints are in index order, parents first); chains without a
  // segment are dropped.
  const std::size_t nj = tables.model.joint_count();
  std::vector<int> children(nj, 0), chain_of_joint(nj, -1), id_of_chain;
  for (std::size_t j = 0; j < nj; ++j)
    if (tables.model.parents[j] >= 0) ++children[static_cast<std::size_t>(tables.model.parents[j])];
  int next = 0;
  for (std::size_t j = 0; j < nj; ++j) {
    const int p = tables.model.parents[j];
    chain_of_joint[j] = p >= 0 && children[static_cast<std::size_t>(p)] == 1
                            ? chain_of_joint[static_cast<std::size_t>(p)]
                            : next++;
  }
  id_of_chain.assign(static_cast<std::size_t>(next), -1);
  for (std::size_t b = 0; b < tables.segments; ++b) {
    int& id = id_of_chain[static_cast<std::size_t>(
        chain_of_joint[static_cast<std::size_t>(tables.model.segments[b])])];
    if (id < 0) {
      id = static_cast<int>(tables.chains++);
      tables.chain_mass.push_back(0.0);
    }
    tables.chain_of_segment.push_back(static_cast<std::uint32_t>(id));
    tables.chain_mass[static_cast<std::size_t>(id)] += tables.masses[b];
  }
  const std::size_t n = tables.sk->frame_count;
  std::size_t blocks = 0;
  for (std::size_t row = 0; row < tables.sk->clips.size(); ++row) {
    const IndexClip& c = index.clips()[tables.sk->clips[row]];
    tables.clips.push_back(
        {tables.sk->clips[row], c.frame_start, c.frame_count, blocks, c.row, c.frame_time_s});
    blocks += (c.frame_count + kBlock - 1) / kBlock;
  }
  tables.frame_row.assign(n, 0);
  for (std::size_t row = 0; row < tables.clips.size(); ++row)
    for (std::size_t f = 0; f < tables.clips[row].frame_count; ++f)
      tables.frame_row[tables.clips[row].frame_start + f] = static_cast<std::uint32_t>(row);
  init_scan_tiles(tables);
}

std::unique_ptr<SkeletonData> build_index_skeleton(const Index& index, std::uint32_t k,
                                                   const double* prefix) {
  auto skeleton = std::make_unique<SkeletonData>();
  init_skeleton_data(index, k, index.dynamics_model(k), *skeleton);
  SkeletonTables& tables = skeleton->tables;
  // h_scan [N][S][9] (one row per frame) and root_position_m [N][3] go
  // straight into the tiles, read in blocks of rows (the index keeps
  // neither array: 0.3 GB on set 2).
  index.stream_rows(k, "frames", "h_scan", 8192,
                    [&](std::uint64_t first, std::uint64_t count, const float* rows) {
                      set_tile_rows(tables, first, count, rows);
                    });
  index.stream_rows(k, "frames", "root_position_m", 8192,
                    [&](std::uint64_t first, std::uint64_t count, const float* rows) {
                      set_root_rows(tables, first, count, rows);
                    });
  tables.prefix_index = prefix;
  build_bound_tables(tables);
  return skeleton;
}

const FrameArrays& frame_arrays(const Index& index, const SkeletonData& skeleton) {
  SkeletonCaches& caches = skeleton.caches;
  std::call_once(caches.frames_once, [&] {
    tbb::this_task_arena::isolate([&] {
      // One call (a schema-2 index derives the rotations and rates in one
      // pass): the COMs and their velocities are made per evaluated frame
      // (frame_ref), not kept.
      static constexpr std::array<std::string_view, 4> kFields{
          "joint_positions_m", "world_rotations", "segment_angular_velocity_radps",
          "local_rotations"};
      const std::vector<const IndexArray*> a = index.arrays(skeleton.tables.k, "frames", kFields);
      caches.frames = {a[0]->f32.data(), a[1]->f32.data(), a[2]->f32.data(), a[3]->f32.data()};
      if (skeleton.character) caches.frames.pos = skeleton.character->joint_positions_m.data();
    });
  });
  return caches.frames;
}

void ensure_columns(const Index& index, const SkeletonData& skeleton, JointColumn kind,
                    const std::vector<std::size_t>& joints) {
  const SkeletonTables& tables = skeleton.tables;
  SkeletonCaches& caches = skeleton.caches;
  const std::size_t nj = tables.model.joint_count(), n = tables.sk->frame_count;
  const std::size_t w = kind == JointColumn::position ? 3 : 4;
  const std::size_t base = static_cast<std::size_t>(kind) * nj;
  std::lock_guard lock(caches.columns_mutex);
  std::vector<std::size_t> missing;
  for (std::size_t j : joints)
    if (!caches.columns[base + j] && std::find(missing.begin(), missing.end(), j) == missing.end())
      missing.push_back(j);
  if (missing.empty()) return;
  std::vector<float*> out;
  for (std::size_t j : missing) {
    caches.columns[base + j] = std::make_unique_for_overwrite<float[]>(w * tables.col_stride);
    out.push_back(caches.columns[base + j].get());
  }
  auto take = [&](std::uint64_t first, std::uint64_t count, const float* rows) {
    for (std::size_t m = 0; m < missing.size(); ++m)
      for (std::size_t a = 0; a < w; ++a) {
        float* col = out[m] + a * tables.col_stride + first;
        const float* src = rows + missing[m] * w + a;
        for (std::size_t i = 0; i < count; ++i) col[i] = src[i * nj * w];
      }
  };
  try {
    if (kind == JointColumn::position && skeleton.character) {
      take(0, n, skeleton.character->joint_positions_m.data());
    } else {
      const char* field = kind == JointColumn::local_rotation   ? "local_rotations"
                          : kind == JointColumn::world_rotation ? "world_rotations"
                                                                : "joint_positions_m";
      index.stream_rows(tables.k, "frames", field, 8192, take);
    }
  } catch (...) {
    for (std::size_t j : missing) caches.columns[base + j].reset();  // never half-made
    throw;
  }
}

const float* joint_column(const SkeletonData& skeleton, JointColumn kind, std::size_t j) {
  return skeleton.caches
      .columns[static_cast<std::size_t>(kind) * skeleton.tables.model.joint_count() + j]
      .get();
}

void ensure_segment_columns(const SkeletonData& skeleton,
                            const std::vector<std::size_t>& segments) {
  const SkeletonTables& tables = skeleton.tables;
  SkeletonCaches& caches = skeleton.caches;
  std::lock_guard lock(caches.columns_mutex);
  for (std::size_t b : segments)
    for (std::size_t r = 0; r < 2; ++r) {
      std::unique_ptr<float[]>& col = caches.segment_columns[2 * b + r];
      if (col) continue;
      col = std::make_unique<float[]>(tables.col_stride);  // zero past the last frame
      float* out = col.get();
      const std::size_t q = r == 0 ? 3 : 8;
      tables.for_each_tile_piece(
          0, tables.frame_count,
          [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
            const float* v = tables.tile_data(row) +
                             (b * HScanTable::kFields + q) * tables.tile_stride(row) + lane;
            std::copy(v, v + count, out + offset);
          });
    }
}

const float* segment_column(const SkeletonData& skeleton, std::size_t b, bool rot) {
  return skeleton.caches.segment_columns[2 * b + (rot ? 1 : 0)].get();
}

void ensure_forest(const Index& index, const SkeletonData& skeleton, const SearchOptions& options) {
  const SkeletonTables& tables = skeleton.tables;
  const std::size_t n = tables.sk->frame_count, dim = tables.segments * 3;
  if (n == 0) return;
  std::call_once(skeleton.caches.forest_once, [&] {
    tbb::this_task_arena::isolate([&] {
      const float* kd = tables.kd != nullptr
                            ? tables.kd
                            : index.array(tables.k, "frames", "kd_features").f32.data();
      skeleton.caches.forest = std::make_unique<KnnIndex>(kd, n, dim, options.approx_trees);
    });
  });
}

std::span<const double> clip_prefix(const Index& index, const SkeletonData& skeleton,
                                    const ClipInfo& ci) {
  const SkeletonTables& tables = skeleton.tables;
  if (!skeleton.character) return {tables.prefix_index + ci.frame_start, ci.frame_count};
  SkeletonCaches& caches = skeleton.caches;
  // Isolated: while waiting for its parallel_for, the thread inside call_once
  // must not pick up another clip task that would wait on the same flag.
  std::call_once(caches.prefix_once, [&] {
    tbb::this_task_arena::isolate([&] {
      const std::size_t nj = tables.model.joint_count();
      std::vector<double> out(tables.sk->frame_count, 0.0);
      const float* rot = index.array(tables.k, "frames", "world_rotations").f32.data();
      const float* pos = skeleton.character->joint_positions_m.data();
      tbb::parallel_for(std::size_t{0}, tables.clips.size(), [&](std::size_t r) {
        const ClipInfo& c = tables.clips[r];
        std::vector<Eigen::Vector3d> p(c.frame_count * nj);
        std::vector<Eigen::Quaterniond> q(c.frame_count * nj);
        for (std::size_t i = 0; i < c.frame_count * nj; ++i) {
          const float* x = pos + (c.frame_start * nj + i) * 3;
          const float* w = rot + (c.frame_start * nj + i) * 4;
          p[i] = Eigen::Vector3d(x[0], x[1], x[2]);
          q[i] = Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized();
        }
        ClipDynamics dyn;
        compute_clip_dynamics(tables.model, c.frame_count, index.clips()[c.clip].frame_time_s,
                              p.data(), q.data(), dyn);
        const std::vector<double> pre = energy_prefix_sums(clip_step_energies(tables.model, dyn));
        std::copy(pre.begin(), pre.end(), out.begin() + static_cast<std::ptrdiff_t>(c.frame_start));
      });
      caches.prefix = std::move(out);
    });
  });
  return {caches.prefix.data() + ci.frame_start, ci.frame_count};
}

const std::vector<Eigen::Quaterniond>& typical_pose(const Index& index,
                                                    const SkeletonData& skeleton) {
  SkeletonCaches& caches = skeleton.caches;
  std::call_once(caches.typical_once,
                 [&] { caches.typical_pose = typical_local_rotations(index, skeleton.tables.k); });
  return caches.typical_pose;
}

}  // namespace mocap::search_detail
