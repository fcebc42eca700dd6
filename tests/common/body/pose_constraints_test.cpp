// Body-frame constraints (pose_constraints.hpp): invalid inputs first, then
// each kind met after the solve (checked by forward kinematics of the
// solved local rotations, independent of the solver's own turns), the
// tolerance, reach, invariance under a turn and move of the whole body, and
// children keeping their local rotations.
#include "mocap/common/body/pose_constraints.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace mocap {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A small body: pelvis, spine, neck; right arm; right leg. Rest pose
// standing, facing +z, world rotations identity.
struct Body {
  std::vector<int> parents{-1, 0, 1, 2, 3, 4, 0, 6, 7};
  std::vector<Eigen::Vector3d> pos{{0, 1, 0},       {0, 1.1, 0},     {0, 1.5, 0},
                                   {-0.2, 1.45, 0}, {-0.2, 1.15, 0}, {-0.2, 0.9, 0},
                                   {-0.1, 0.95, 0}, {-0.1, 0.5, 0},  {-0.1, 0.05, 0}};
  std::vector<Eigen::Quaterniond> rot =
      std::vector<Eigen::Quaterniond>(9, Eigen::Quaterniond::Identity());
  enum { kHips, kSpine, kNeck, kArm, kForeArm, kHand, kUpLeg, kLeg, kFoot };
};

// The pose with the driven joints' local rotations replaced (forward
// kinematics from the original local translations and rotations).
void apply(const Body& b, const std::vector<int>& driven, const std::vector<Eigen::Quaterniond>& l,
           std::vector<Eigen::Vector3d>& pos, std::vector<Eigen::Quaterniond>& rot) {
  const std::size_t n = b.parents.size();
  pos = b.pos;
  rot = b.rot;
  for (std::size_t j = 0; j < n; ++j) {
    const int p = b.parents[j];
    if (p < 0) continue;
    const auto pp = static_cast<std::size_t>(p);
    const Eigen::Vector3d t = b.rot[pp].conjugate() * (b.pos[j] - b.pos[pp]);
    Eigen::Quaterniond local = b.rot[pp].conjugate() * b.rot[j];
    for (std::size_t k = 0; k < driven.size(); ++k)
      if (driven[k] == static_cast<int>(j)) local = l[k];
    rot[j] = rot[pp] * local;
    pos[j] = pos[pp] + rot[pp] * t;
  }
}

// Solves, applies and returns the residual of every constraint.
std::vector<double> solve_and_measure(const Body& b, std::vector<PoseConstraint> cs,
                                      std::vector<Eigen::Quaterniond>* locals = nullptr) {
  sort_constraints(cs);
  const std::vector<int> driven = driven_joints(cs, b.parents.size());
  std::vector<Eigen::Quaterniond> l(driven.size());
  PoseConstraintScratch scratch;
  solve_pose_constraints(b.parents, 0, cs, b.pos.data(), b.rot.data(), scratch, l.data());
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  apply(b, driven, l, pos, rot);
  std::vector<double> out;
  for (const PoseConstraint& c : cs)
    out.push_back(constraint_residual(b.parents, 0, c, pos.data(), rot.data()));
  if (locals != nullptr) *locals = l;
  return out;
}

PoseConstraint angle(PoseConstraintKind kind, int joint, int end, double deg, int middle = -1) {
  PoseConstraint c;
  c.kind = kind;
  c.name = "a";
  c.joint = joint;
  c.end = end;
  c.middle = middle;
  c.angle_rad = deg * kDeg;
  return c;
}

TEST(PoseConstraints, InvalidDrivenJoints) {
  PoseConstraint a =
      angle(PoseConstraintKind::hinge_flexion, Body::kForeArm, Body::kHand, 90, Body::kArm);
  PoseConstraint e;
  e.kind = PoseConstraintKind::effector;
  e.joint = Body::kArm;
  e.middle = Body::kForeArm;
  e.end = Body::kHand;
  EXPECT_THROW(driven_joints({a, e}, 9), std::invalid_argument);  // the forearm twice
  PoseConstraint far = a;
  far.joint = 9;
  EXPECT_THROW(driven_joints({far}, 9), std::invalid_argument);
  EXPECT_EQ(driven_joints({e}, 9), (std::vector<int>{Body::kArm, Body::kForeArm}));
}

TEST(PoseConstraints, EachKindIsMet) {
  const Body b;
  PoseConstraint dir;
  dir.kind = PoseConstraintKind::direction;
  dir.joint = Body::kArm;
  dir.end = Body::kForeArm;
  dir.target = Eigen::Vector3d(0, 1, 1).normalized();
  PoseConstraint trunk = angle(PoseConstraintKind::sagittal_flexion, Body::kSpine, Body::kNeck, 40);
  PoseConstraint hip = angle(PoseConstraintKind::sagittal_flexion, Body::kUpLeg, Body::kLeg, 70);
  hip.from_down = true;
  PoseConstraint knee =
      angle(PoseConstraintKind::hinge_flexion, Body::kLeg, Body::kFoot, 90, Body::kUpLeg);
  knee.bend_hint = -Eigen::Vector3d::UnitZ();
  PoseConstraint elbow =
      angle(PoseConstraintKind::hinge_flexion, Body::kForeArm, Body::kHand, 120, Body::kArm);
  PoseConstraint shoulder = angle(PoseConstraintKind::elevation, Body::kArm, Body::kForeArm, 90);
  shoulder.bend_hint = -Eigen::Vector3d::UnitX();
  PoseConstraint hand;
  hand.kind = PoseConstraintKind::effector;
  hand.joint = Body::kArm;
  hand.middle = Body::kForeArm;
  hand.end = Body::kHand;
  hand.target = Eigen::Vector3d(-0.3, 1.6, 0.25);
  for (const auto& cs : std::vector<std::vector<PoseConstraint>>{{dir},
                                                                 {trunk},
                                                                 {hip},
                                                                 {knee},
                                                                 {elbow},
                                                                 {shoulder},
                                                                 {hand},
                                                                 {trunk, hand},
                                                                 {trunk, dir},
                                                                 {hip, knee},
                                                                 {trunk, shoulder, elbow}}) {
    const std::vector<double> r = solve_and_measure(b, cs);
    for (std::size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r[i], 0.0, 1e-7) << i;
  }
  // The trunk leans forward (+z), the knee bends backward, the shoulder sideways.
  std::vector<Eigen::Quaterniond> l;
  solve_and_measure(b, {trunk}, &l);
  EXPECT_GT((l[0] * Eigen::Vector3d::UnitY()).z(), 0.5);
  solve_and_measure(b, {knee}, &l);
  EXPECT_LT((l[0] * -Eigen::Vector3d::UnitY()).z(), -0.5);
  solve_and_measure(b, {shoulder}, &l);
  EXPECT_LT((l[0] * -Eigen::Vector3d::UnitY()).x(), -0.9);
}

TEST(PoseConstraints, ToleranceLeavesAMetPoseAlone) {
  const Body b;
  PoseConstraint trunk = angle(PoseConstraintKind::sagittal_flexion, Body::kSpine, Body::kNeck, 8);
  trunk.tolerance = 10 * kDeg;  // upright is within 10 degrees of 8
  PoseConstraintScratch scratch;
  Eigen::Quaterniond l;
  solve_pose_constraints(b.parents, 0, {trunk}, b.pos.data(), b.rot.data(), scratch, &l);
  EXPECT_NEAR(l.angularDistance(Eigen::Quaterniond::Identity()), 0.0, 1e-12);
  for (std::uint8_t t : scratch.turned) EXPECT_EQ(t, 0);
  // Outside it: moved to the tolerance's edge, not to the target.
  trunk.angle_rad = 30 * kDeg;
  const std::vector<double> r = solve_and_measure(b, {trunk});
  EXPECT_NEAR(r[0], 10.0, 1e-7);
}

TEST(PoseConstraints, EffectorOutOfReachStretchesTowardsTheTarget) {
  const Body b;
  PoseConstraint hand;
  hand.kind = PoseConstraintKind::effector;
  hand.joint = Body::kArm;
  hand.middle = Body::kForeArm;
  hand.end = Body::kHand;
  hand.target = Eigen::Vector3d(-0.2, 1.45, 3.0);  // 3 m ahead of the shoulder
  std::vector<Eigen::Quaterniond> l;
  const std::vector<double> r = solve_and_measure(b, {hand}, &l);
  const double reach = 0.3 + 0.25;
  EXPECT_NEAR(r[0], 3.0 - reach, 1e-6);
}

TEST(PoseConstraints, BodyFrameInvariance) {
  Body b;
  PoseConstraint hand;
  hand.kind = PoseConstraintKind::effector;
  hand.joint = Body::kArm;
  hand.middle = Body::kForeArm;
  hand.end = Body::kHand;
  hand.target = Eigen::Vector3d(-0.3, 1.6, 0.25);
  PoseConstraint trunk = angle(PoseConstraintKind::sagittal_flexion, Body::kSpine, Body::kNeck, 30);
  std::vector<Eigen::Quaterniond> a, c;
  solve_and_measure(b, {trunk, hand}, &a);
  // The whole body turned 70 degrees about +y and moved: the same local rotations.
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(70 * kDeg, Eigen::Vector3d::UnitY()));
  for (auto& p : b.pos) p = turn * p + Eigen::Vector3d(3, 0, -2);
  for (auto& q : b.rot) q = turn * q;
  const std::vector<double> r = solve_and_measure(b, {trunk, hand}, &c);
  for (double x : r) EXPECT_NEAR(x, 0.0, 1e-7);
  ASSERT_EQ(a.size(), c.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i].angularDistance(c[i]), 0.0, 1e-7);
}

TEST(PoseConstraints, ChildrenKeepTheirLocalRotations) {
  Body b;
  // A bent wrist: the hand's local rotation must survive the elbow's change.
  b.rot[Body::kHand] = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()));
  PoseConstraint elbow =
      angle(PoseConstraintKind::hinge_flexion, Body::kForeArm, Body::kHand, 90, Body::kArm);
  const std::vector<int> driven = driven_joints({elbow}, 9);
  std::vector<Eigen::Quaterniond> l(1);
  PoseConstraintScratch scratch;
  solve_pose_constraints(b.parents, 0, {elbow}, b.pos.data(), b.rot.data(), scratch, l.data());
  const Eigen::Quaterniond hand_local =
      scratch.rot[Body::kForeArm].conjugate() * scratch.rot[Body::kHand];
  const Eigen::Quaterniond before = b.rot[Body::kForeArm].conjugate() * b.rot[Body::kHand];
  EXPECT_NEAR(hand_local.angularDistance(before), 0.0, 1e-12);
  EXPECT_EQ(scratch.turned[Body::kHand], 1);
  EXPECT_EQ(scratch.turned[Body::kArm], 0);
}

TEST(PoseConstraints, GivenLocalRotationIsKeptExactly) {
  const Body b;
  PoseConstraint given;
  given.kind = PoseConstraintKind::local_rotation;
  given.joint = Body::kForeArm;
  given.local = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()));
  PoseConstraint shoulder = angle(PoseConstraintKind::elevation, Body::kArm, Body::kForeArm, 60);
  std::vector<PoseConstraint> cs{given, shoulder};
  sort_constraints(cs);
  std::vector<Eigen::Quaterniond> l(2);
  PoseConstraintScratch scratch;
  solve_pose_constraints(b.parents, 0, cs, b.pos.data(), b.rot.data(), scratch, l.data());
  EXPECT_EQ(l[1].coeffs(), given.local.coeffs());  // driven order: arm, forearm
  EXPECT_NEAR(constraint_residual(b.parents, 0, given, b.pos.data(), b.rot.data()), 0.7 / kDeg,
              1e-9);
}

}  // namespace
}  // namespace mocap
