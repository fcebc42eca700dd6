// search/src/scan/frame_energy.cpp: database_frame, the converted database
// frame that the exact evaluation of whole-body partial frames reads. Its
// segment COMs and their velocities are made from the frame arrays'
// positions and world rotations and those of the frame's clip neighbours
// (the arrays keep no COMs): they equal the index's derived arrays (the
// double-precision dynamics of the stored rows) to float precision on every
// frame of set 1, the clips' first and last frames included; its positions,
// rotations and angular velocities are the arrays' own.
#include "scan/frame_energy.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>

#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/io/index.hpp"
#include "search_fixtures.hpp"
#include "test_support.hpp"

using namespace mocap;
using namespace mocap::search_detail;

namespace {

double distance(const Eigen::Vector3d& a, const float* b) {
  return (a - Eigen::Vector3d(b[0], b[1], b[2])).norm();
}

}  // namespace

TEST(DatabaseFrame, ComsAndRatesEqualTheIndexDerivedArraysSet1) {
  MOCAP_REQUIRE_DATA();
  const Index index = Index::open(test::set1_index("frame-energy-set1"));
  std::size_t frames = 0, ends = 0;
  double worst_com = 0.0, worst_vel = 0.0;
  for (std::uint32_t k = 0; k < index.skeletons().size(); ++k) {
    const std::unique_ptr<SkeletonData> sk =
        build_index_skeleton(index, k, index.array(k, "frames", "energy_prefix_J").f64.data());
    const SkeletonTables& tables = sk->tables;
    const std::size_t nj = tables.model.joint_count();
    const float* com = index.array(k, "frames", "segment_com_m").f32.data();
    const float* vel = index.array(k, "frames", "segment_com_velocity_mps").f32.data();
    const float* angvel = index.array(k, "frames", "segment_angular_velocity_radps").f32.data();
    const float* pos = index.array(k, "frames", "joint_positions_m").f32.data();
    Scratch scratch;
    for (const ClipInfo& clip : tables.clips)
      for (std::size_t f = 0; f < clip.frame_count; ++f) {
        const std::size_t g = clip.frame_start + f;
        const FrameRef r = database_frame(*sk, index, g, scratch);
        ++frames;
        if (f == 0 || f + 1 == clip.frame_count) ++ends;
        for (std::size_t j = 0; j < nj; ++j) {
          const std::size_t i = (g * nj + j) * 3;
          ASSERT_EQ(distance(r.state.joint_positions_m[j], pos + i), 0.0) << g << " " << j;
          ASSERT_EQ(distance(r.state.angular_velocities_radps[j], angvel + i), 0.0)
              << g << " " << j;
          const double dc = distance(r.state.coms_m[j], com + i);
          const double dv = distance(r.state.com_velocities_mps[j], vel + i);
          ASSERT_LT(dc, 1e-6) << "COM, frame " << g << " joint " << j;
          ASSERT_LT(dv, 1e-5 + 1e-5 * r.state.com_velocities_mps[j].norm())
              << "COM velocity, frame " << g << " (clip frame " << f << " of " << clip.frame_count
              << ") joint " << j;
          worst_com = std::max(worst_com, dc);
          worst_vel = std::max(worst_vel, dv);
        }
      }
  }
  EXPECT_GT(frames, 10000u);
  EXPECT_GT(ends, 100u);
  std::printf("database_frame vs derived arrays: worst COM %.3g m, worst velocity %.3g m/s\n",
              worst_com, worst_vel);
}
