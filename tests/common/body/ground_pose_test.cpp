// Ground placement (common/ground_pose.hpp): the algebra of GroundPose, the
// body frame of a pose, place_state against a rigid motion built by hand,
// and place_h_scan_query against the query of the placed state.
#include "mocap/common/body/ground_pose.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "energy_fixtures.hpp"
#include "mocap/common/dynamics/energy.hpp"

namespace mocap {
namespace {

void expect_near(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double tol) {
  EXPECT_NEAR((a - b).norm(), 0.0, tol) << a.transpose() << " vs " << b.transpose();
}

TEST(GroundPose, HeadingZeroFacesPlusZAndPlusXIsTheLeft) {
  GroundPose g;
  g.heading_rad = std::numbers::pi / 2;  // facing world +x
  g.position_m = {1.0, 2.0};
  expect_near(g.apply({0, 0, 1}), {2.0, 0.0, 2.0}, 1e-12);  // one metre forward
  expect_near(g.apply({1, 0, 0}), {1.0, 0.0, 1.0}, 1e-12);  // one metre to the left
  expect_near(g.apply({0, 3, 0}), {1.0, 3.0, 2.0}, 1e-12);  // heights unchanged
  expect_near(g.turn({0, 0, 1}), {1.0, 0.0, 0.0}, 1e-12);
  expect_near(g.rotation() * Eigen::Vector3d(0, 0, 1), g.turn({0, 0, 1}), 1e-12);
}

TEST(GroundPose, InverseAndCompositionUndoEachOther) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  for (int trial = 0; trial < 50; ++trial) {
    const GroundPose a{u(rng), {u(rng), u(rng)}}, b{u(rng), {u(rng), u(rng)}};
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    expect_near(a.inverse().apply(a.apply(p)), p, 1e-12);
    expect_near((a * b).apply(p), a.apply(b.apply(p)), 1e-12);
    expect_near((a * a.inverse()).apply(p), p, 1e-12);
  }
}

TEST(GroundPose, BodyFrameOfAPlacedPoseIsThePlacementOfItsBodyFrame) {
  const test::TestBody t = test::make_test_body();
  std::mt19937 rng(3);
  const BodyState s = test::random_state(t, rng);
  const int root = t.model.root();
  ASSERT_GE(root, 0);
  const auto r = static_cast<std::size_t>(root);
  const GroundPose g{2.5, {-1.0, 0.75}};
  BodyState placed = s;
  place_state(g, placed);
  const GroundPose before = ground_pose_of(s.joint_positions_m[r], s.rotations[r]);
  const GroundPose after = ground_pose_of(placed.joint_positions_m[r], placed.rotations[r]);
  const GroundPose expected = g * before;
  EXPECT_NEAR(std::remainder(after.heading_rad - expected.heading_rad, 2 * std::numbers::pi), 0.0,
              1e-12);
  EXPECT_NEAR((after.position_m - expected.position_m).norm(), 0.0, 1e-12);
  // The same as the hand-built rigid motion of the energy tests.
  const BodyState ref = test::transform_state(
      s, g.rotation(), Eigen::Vector3d(g.position_m.x(), 0.0, g.position_m.y()));
  for (std::size_t j = 0; j < s.coms_m.size(); ++j) {
    expect_near(placed.coms_m[j], ref.coms_m[j], 1e-12);
    expect_near(placed.com_velocities_mps[j], ref.com_velocities_mps[j], 1e-12);
    expect_near(placed.angular_velocities_radps[j], ref.angular_velocities_radps[j], 1e-12);
    EXPECT_NEAR(placed.rotations[j].angularDistance(ref.rotations[j]), 0.0, 1e-9);
  }
}

TEST(GroundPose, PlacedScanQueryEqualsTheQueryOfThePlacedState) {
  const test::TestBody t = test::make_test_body();
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const BodyState a = test::random_state(t, rng);
    const BodyState b = test::random_state(t, rng);
    const GroundPose g{(trial - 10) * 0.6, {0.3 * trial, -0.2 * trial}};
    BodyState placed = a;
    place_state(g, placed);
    const double T = 0.5;
    const HScanQuery body = make_h_scan_query(t.model, a.view(), T);
    HScanQuery moved;
    place_h_scan_query(body, g, moved);
    // Scanned against one frame b: the placed query gives h(placed a -> b).
    HScanTable table;
    init_h_scan_table(t.model, 1, table);
    set_h_scan_frame(t.model, b.view(), 0, table);
    float got = 0.0f, want = 0.0f;
    scan_approximate_energy(table, moved, 0, 1, &got);
    const HScanQuery direct = make_h_scan_query(t.model, placed.view(), T);
    scan_approximate_energy(table, direct, 0, 1, &want);
    EXPECT_NEAR(got, want, 1e-4 * (1.0 + std::abs(double{want}))) << trial;
    // h itself does not change when both states move together.
    BodyState b_placed = b;
    place_state(g, b_placed);
    const double h0 = approximate_energy(t.model, a.view(), b.view(), T);
    const double h1 = approximate_energy(t.model, placed.view(), b_placed.view(), T);
    EXPECT_NEAR(h1, h0, 1e-9 * (1.0 + h0)) << trial;
  }
}

}  // namespace
}  // namespace mocap
