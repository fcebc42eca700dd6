// Retargeting poses across rigs (retarget.hpp): invalid inputs, same_rig,
// identity on the same skeleton, directions of the shared segments, round
// trips between CMU and Bandai Namco rigs, the height rule.
#include "mocap/common/body/retarget.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "raw_clip_builder.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

ClipMotion load(const std::filesystem::path& file) {
  RawClip raw = read_bvh_file(file);
  normalise_up_axis(raw, std::nullopt);
  return clip_motion_from_raw(raw, unit_scale_m(detect_unit(raw)));
}

std::filesystem::path bn_walk() {
  return test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh";
}
std::filesystem::path bn_bow() {
  return test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_bow_active_001.bvh";
}
std::filesystem::path cmu_walk() {
  return test::data_dir() / "cmu" / "131_01.bvh";
}

WorldPose world_of(const ClipMotion& m, std::size_t f) {
  WorldPose w;
  const std::size_t n = m.joint_count();
  w.positions_m.assign(m.world_positions_m.begin() + static_cast<std::ptrdiff_t>(f * n),
                       m.world_positions_m.begin() + static_cast<std::ptrdiff_t>((f + 1) * n));
  w.rotations.assign(m.world_rotations.begin() + static_cast<std::ptrdiff_t>(f * n),
                     m.world_rotations.begin() + static_cast<std::ptrdiff_t>((f + 1) * n));
  return w;
}

// World direction of the directed target joint j: R a.
Eigen::Vector3d target_direction(const RetargetMap& map, const WorldPose& w, std::size_t j) {
  return w.rotations[j] * map.target_axis[j];
}
Eigen::Vector3d source_direction(const RetargetMap& map, const WorldPose& w, std::size_t j) {
  return w.rotations[static_cast<std::size_t>(map.source_joint[j])] * map.source_axis[j];
}

// The body frame's forward direction (+z) of a pose: the pelvis's side axis
// (left = +x) turned about up; a physical definition both rigs share.
Eigen::Vector3d forward(const WorldPose& w, int pelvis, const Eigen::Vector3d& side_axis_local) {
  Eigen::Vector3d left = w.rotations[static_cast<std::size_t>(pelvis)] * side_axis_local;
  left.y() = 0.0;
  return left.normalized().cross(Eigen::Vector3d::UnitY()).normalized();
}

TEST(Retarget, InvalidInputs) {
  // No pelvis: nothing recognised.
  test::RawClipBuilder builder;
  const int a = builder.joint("a", -1, {0, 0, 0}, {});
  const int b = builder.joint("b", a, {0, 1, 0}, {});
  builder.joint("c", b, {0, 1, 0}, {});
  const Skeleton odd = build_skeleton(builder.frame({}).build(), 1.0);
  MOCAP_REQUIRE_DATA();
  const ClipMotion cmu = load(cmu_walk());
  EXPECT_THROW(make_retarget_map(odd, cmu.skeleton), InputError);
  EXPECT_THROW(make_retarget_map(cmu.skeleton, odd), InputError);
  try {
    make_retarget_map(odd, cmu.skeleton);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("pelvis"), std::string::npos) << e.what();
  }
  // A pose of another skeleton than the map's.
  const ClipMotion bn = load(bn_walk());
  const RetargetMap map = make_retarget_map(cmu.skeleton, bn.skeleton);
  LocalPose local;
  WorldPose world;
  EXPECT_THROW(retarget_pose(map, bn.skeleton, world_of(bn, 0), local, world),
               std::invalid_argument);
  EXPECT_THROW(retarget_clip_frame(map, cmu, cmu.frame_count, bn.skeleton, local, world),
               std::out_of_range);
}

TEST(Retarget, SameRig) {
  MOCAP_REQUIRE_DATA();
  const ClipMotion walk = load(bn_walk()), bow = load(bn_bow()), cmu = load(cmu_walk());
  EXPECT_TRUE(same_rig(walk.skeleton, walk.skeleton));
  // Two Bandai Namco actors: other Hips offsets (a placement), the same rest.
  EXPECT_TRUE(same_rig(walk.skeleton, bow.skeleton));
  EXPECT_FALSE(same_rig(walk.skeleton, cmu.skeleton));
  EXPECT_FALSE(same_rig(cmu.skeleton, walk.skeleton));
  // Longer bones: the same rig; a bone turned 30 degrees: another rest pose.
  Skeleton longer = walk.skeleton;
  longer.translation_scales.assign(longer.joint_count(), 1.2);
  EXPECT_TRUE(same_rig(walk.skeleton, longer));
  Skeleton turned = walk.skeleton;
  const int knee = find_joint_by_alias(turned, "LeftLeg");
  ASSERT_GE(knee, 0);
  turned.offsets_m[static_cast<std::size_t>(knee)] =
      Eigen::AngleAxisd(0.52, Eigen::Vector3d::UnitZ()) *
      turned.offsets_m[static_cast<std::size_t>(knee)];
  EXPECT_FALSE(same_rig(walk.skeleton, turned));
  Skeleton renamed = walk.skeleton;
  renamed.names[2] = "Spine1";
  EXPECT_FALSE(same_rig(walk.skeleton, renamed));
}

// A pose retargeted onto its own skeleton is itself.
TEST(Retarget, IdentityOnTheSameSkeleton) {
  MOCAP_REQUIRE_DATA();
  for (const auto& file : {cmu_walk(), bn_walk()}) {
    const ClipMotion m = load(file);
    const RetargetMap map = make_retarget_map(m.skeleton, m.skeleton);
    EXPECT_EQ(map.leg_length_ratio, 1.0);
    for (std::size_t j = 0; j < m.joint_count(); ++j)
      EXPECT_LT(map.correction[j].angularDistance(Eigen::Quaterniond::Identity()), 1e-12);
    LocalPose local;
    WorldPose world;
    for (std::size_t f = 0; f < m.frame_count; f += 97) {
      retarget_clip_frame(map, m, f, m.skeleton, local, world);
      const WorldPose src = world_of(m, f);
      for (std::size_t j = 0; j < m.joint_count(); ++j) {
        EXPECT_LT(world.rotations[j].angularDistance(src.rotations[j]), 1e-9) << file << " " << j;
        // Bandai Namco's position channels differ from its OFFSETs by < 1e-6 m.
        EXPECT_LT((world.positions_m[j] - src.positions_m[j]).norm(), 1e-5) << file << " " << j;
        EXPECT_LT(local.rotations[j].angularDistance(m.local_rotations[f * m.joint_count() + j]),
                  1e-9);
      }
    }
  }
}

// Every directed class points the same way in the world in both rigs, its
// twist (trunk) too; with the ground position and the body frame's forward
// direction kept, directions are equal in the body frame.
TEST(Retarget, SharedSegmentsPointTheSameWayInTheBodyFrame) {
  MOCAP_REQUIRE_DATA();
  const ClipMotion cmu = load(cmu_walk()), bn = load(bn_walk());
  for (const auto& [from, onto] : {std::pair{&cmu, &bn}, std::pair{&bn, &cmu}}) {
    const RetargetMap map = make_retarget_map(from->skeleton, onto->skeleton);
    const RetargetMap back = make_retarget_map(onto->skeleton, from->skeleton);
    const auto pelvis = static_cast<std::size_t>(map.target_pelvis);
    ASSERT_TRUE(map.directed[pelvis]);
    // The pelvis's side axis (the rest vector right -> left thigh) of each rig.
    auto side_axis = [](const Skeleton& s, int root) {
      Eigen::Vector3d v[2];
      for (int k = 0; k < 2; ++k) {
        v[k].setZero();
        for (int j = find_joint_by_alias(s, k == 0 ? "LeftUpLeg" : "RightUpLeg"); j != root;
             j = s.parents[static_cast<std::size_t>(j)])
          v[k] += s.offsets_m[static_cast<std::size_t>(j)];
      }
      return Eigen::Vector3d(v[0] - v[1]);
    };
    // Its part orthogonal to the pelvis's rest axis (retarget.hpp).
    auto orthogonal = [](const Eigen::Vector3d& b, const Eigen::Vector3d& a) {
      return Eigen::Vector3d(b - b.dot(a) * a);
    };
    const Eigen::Vector3d side_t =
        orthogonal(side_axis(onto->skeleton, map.target_pelvis), map.target_axis[pelvis]);
    const Eigen::Vector3d side_s =
        orthogonal(side_axis(from->skeleton, map.source_pelvis), map.source_axis[pelvis]);
    std::size_t directed = 0;
    std::string names;
    for (std::size_t j = 0; j < onto->joint_count(); ++j)
      if (map.directed[j]) {
        ++directed;
        names += onto->skeleton.names[j] + " ";
      }
    EXPECT_EQ(directed, 16u)
        << names;  // trunk 3, neck, 2 x (clavicle, arm, forearm, thigh, shank, foot)
    LocalPose local;
    WorldPose world;
    for (std::size_t f = 0; f < from->frame_count; f += 41) {
      const WorldPose src = world_of(*from, f);
      retarget_clip_frame(map, *from, f, onto->skeleton, local, world);
      for (std::size_t j = 0; j < onto->joint_count(); ++j) {
        if (!map.directed[j]) continue;
        EXPECT_LT((target_direction(map, world, j) - source_direction(map, src, j)).norm(), 1e-9)
            << onto->skeleton.names[j] << " frame " << f;
      }
      // The body frame: same ground position, same forward direction.
      const auto sp = static_cast<std::size_t>(map.source_pelvis);
      EXPECT_NEAR(world.positions_m[pelvis].x(), src.positions_m[sp].x(), 1e-9);
      EXPECT_NEAR(world.positions_m[pelvis].z(), src.positions_m[sp].z(), 1e-9);
      EXPECT_LT(
          (forward(world, map.target_pelvis, side_t) - forward(src, map.source_pelvis, side_s))
              .norm(),
          1e-9);
      // Limbs whose aim is their own child in both rigs: the bone itself.
      for (const char* limb : {"LeftUpLeg", "RightLeg", "LeftUpperArm", "RightForeArm"}) {
        const int jt = find_joint_by_alias(onto->skeleton, limb);
        const int js = find_joint_by_alias(from->skeleton, limb);
        const int ct = onto->skeleton.children(jt).front(),
                  cs = from->skeleton.children(js).front();
        const Eigen::Vector3d bt = world.positions_m[static_cast<std::size_t>(ct)] -
                                   world.positions_m[static_cast<std::size_t>(jt)];
        const Eigen::Vector3d bs = src.positions_m[static_cast<std::size_t>(cs)] -
                                   src.positions_m[static_cast<std::size_t>(js)];
        // Bandai Namco bones follow position channels, within 1e-6 m of the OFFSETs.
        EXPECT_LT((bt.normalized() - bs.normalized()).norm(), 1e-5) << limb << " frame " << f;
      }
      // And back: the same directions on the first rig, to 1e-9.
      LocalPose local2;
      WorldPose world2;
      retarget_pose(back, from->skeleton, world, local2, world2);
      for (std::size_t j = 0; j < from->joint_count(); ++j) {
        if (!back.directed[j]) continue;
        EXPECT_LT((target_direction(back, world2, j) - target_direction(back, src, j)).norm(), 1e-9)
            << from->skeleton.names[j] << " frame " << f;
      }
    }
  }
}

// The lowest foot point lies at the source's height times the leg ratio; a
// standing pose stays upright on the other rig.
TEST(Retarget, HeightFollowsTheFeetScaledByLegLength) {
  MOCAP_REQUIRE_DATA();
  const ClipMotion cmu = load(cmu_walk()), bn = load(bn_walk());
  const RetargetMap map = make_retarget_map(cmu.skeleton, bn.skeleton);
  EXPECT_GT(map.leg_length_ratio, 0.7);
  EXPECT_LT(map.leg_length_ratio, 1.4);
  ASSERT_EQ(map.foot_points.size(), 4u);
  LocalPose local;
  WorldPose world;
  for (std::size_t f = 0; f < cmu.frame_count; f += 113) {
    const WorldPose src = world_of(cmu, f);
    retarget_pose(map, bn.skeleton, src, local, world);
    double low_s = 1e9, low_t = 1e9;
    for (const auto& [s, t] : map.foot_points) {
      low_s = std::min(low_s, src.positions_m[static_cast<std::size_t>(s)].y());
      low_t = std::min(low_t, world.positions_m[static_cast<std::size_t>(t)].y());
    }
    EXPECT_NEAR(low_t, map.leg_length_ratio * low_s, 1e-9);
    // Upright: the head above the pelvis above the feet.
    const auto head = static_cast<std::size_t>(find_joint_by_alias(bn.skeleton, "Head"));
    const auto hips = static_cast<std::size_t>(map.target_pelvis);
    EXPECT_GT(world.positions_m[head].y(), world.positions_m[hips].y() + 0.4);
    EXPECT_GT(world.positions_m[hips].y(), low_t + 0.6);
  }
}

// The average of rotations: sign-free (q and -q are one rotation), the
// middle of rotations spread evenly about an axis, identity without frames.
TEST(Retarget, TypicalLocalRotationsAverageSignFree) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -1).normalized();
  std::vector<Eigen::Quaterniond> locals;  // 2 joints
  for (int k = -3; k <= 3; ++k) {
    Eigen::Quaterniond q(Eigen::AngleAxisd(1.0 + 0.2 * k, axis));
    if (k % 2 != 0) q.coeffs() *= -1.0;
    locals.push_back(q);
    locals.push_back(Eigen::Quaterniond(Eigen::AngleAxisd(3.1 + 0.01 * k, axis)));
  }
  const auto mean = typical_local_rotations(locals, 2);
  ASSERT_EQ(mean.size(), 2u);
  EXPECT_LT(mean[0].angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(1.0, axis))), 1e-9);
  // Near a half turn, where w changes sign from frame to frame.
  EXPECT_LT(mean[1].angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(3.1, axis))), 1e-9);
  EXPECT_GE(mean[1].w(), 0.0);
  const auto none = typical_local_rotations(std::span<const Eigen::Quaterniond>(), 3);
  ASSERT_EQ(none.size(), 3u);
  EXPECT_EQ(none[2].w(), 1.0);
  MOCAP_REQUIRE_DATA();
  const Skeleton cmu = load(cmu_walk()).skeleton;
  EXPECT_THROW(make_retarget_map(cmu, cmu, std::vector<Eigen::Quaterniond>(1)),
               std::invalid_argument);
}

// With the target's typical pose: directions stay exact, joints that are
// not directed representatives take their typical local rotation, limbs
// are turned about their axis to the typical twist. The rigs turn bone
// frames differently about the bones (Bandai Namco's left thigh points up at
// rest, its right one down): a CMU walk on Bandai Namco has limb local
// rotations near Bandai Namco's typical ones with the typical pose, and a
// thigh half a turn away without it; a Bandai Namco walk carried to CMU and
// back stays near its own.
TEST(Retarget, TypicalPoseGivesNeutralJointsAndLimbTwists) {
  MOCAP_REQUIRE_DATA();
  const ClipMotion cmu = load(cmu_walk()), bn = load(bn_walk());
  const auto typical_bn = typical_local_rotations(bn.local_rotations, bn.joint_count());
  const auto typical_cmu = typical_local_rotations(cmu.local_rotations, cmu.joint_count());
  const RetargetMap to_cmu = make_retarget_map(bn.skeleton, cmu.skeleton, typical_cmu);
  const RetargetMap back = make_retarget_map(cmu.skeleton, bn.skeleton, typical_bn);
  const RetargetMap to_bn_plain = make_retarget_map(cmu.skeleton, bn.skeleton);
  const char* const limbs[] = {"LeftUpLeg",    "RightUpLeg",    "LeftLeg",     "RightLeg",
                               "LeftUpperArm", "RightUpperArm", "LeftForeArm", "RightForeArm"};
  LocalPose lc, lb;
  WorldPose wc, wb;
  double round_trip = 0.0;
  for (std::size_t f = 0; f < bn.frame_count; f += 17) {
    const WorldPose src = world_of(bn, f);
    retarget_pose(to_cmu, cmu.skeleton, src, lc, wc);
    for (std::size_t j = 0; j < cmu.joint_count(); ++j) {
      if (to_cmu.directed[j]) {
        EXPECT_LT((target_direction(to_cmu, wc, j) - source_direction(to_cmu, src, j)).norm(),
                  1e-9);
        if (!to_cmu.has_side_axis[j]) {
          // No twist left about the axis between the local rotation and the typical one.
          const Eigen::Quaterniond d = lc.rotations[j].conjugate() * typical_cmu[j];
          EXPECT_LT(std::abs(d.vec().dot(to_cmu.target_axis[j])), 1e-9) << cmu.skeleton.names[j];
        }
      } else if (cmu.skeleton.parents[j] >= 0) {
        EXPECT_LT(lc.rotations[j].angularDistance(typical_cmu[j]), 1e-9) << cmu.skeleton.names[j];
      }
    }
    retarget_pose(back, bn.skeleton, wc, lb, wb);
    for (const char* limb : limbs) {
      const auto j = static_cast<std::size_t>(find_joint_by_alias(bn.skeleton, limb));
      round_trip =
          std::max(round_trip,
                   lb.rotations[j].angularDistance(bn.local_rotations[f * bn.joint_count() + j]));
    }
  }
  EXPECT_LT(round_trip, 1.0);  // radians: the limbs' own twists give way to the typical ones
  // Mean angle to the typical local rotation over a CMU walk's limbs.
  double typical = 0.0, plain = 0.0;
  std::size_t count = 0;
  for (std::size_t f = 480; f < 700; f += 11) {
    retarget_clip_frame(back, cmu, f, bn.skeleton, lb, wb);
    retarget_clip_frame(to_bn_plain, cmu, f, bn.skeleton, lc, wc);
    for (const char* limb : limbs) {
      const auto j = static_cast<std::size_t>(find_joint_by_alias(bn.skeleton, limb));
      typical += lb.rotations[j].angularDistance(typical_bn[j]);
      plain += lc.rotations[j].angularDistance(typical_bn[j]);
      ++count;
    }
  }
  // Measured: 0.66 rad (swings differ between the subjects' walks) against
  // 1.51 rad (thighs half a turn off).
  EXPECT_LT(typical / count, 0.8);
  EXPECT_GT(plain / count, 1.2);
}

TEST(Retarget, ComparedClasses) {
  MOCAP_REQUIRE_DATA();
  const ClipMotion cmu = load(cmu_walk()), bn = load(bn_walk());
  auto names = [](const RetargetMap& m) {
    std::string s;
    for (const auto& [c, side] : m.compared_classes) s += class_key_name(c, side) + ",";
    return s;
  };
  // Onto Bandai Namco: its head, hands and toes are point masses below
  // compared segments (their End Sites are zero), so they are compared too.
  EXPECT_EQ(names(make_retarget_map(cmu.skeleton, bn.skeleton)),
            "head,neck,upper_trunk,middle_trunk,lower_trunk,left clavicle,right clavicle,"
            "left upper_arm,right upper_arm,left forearm,right forearm,left hand,right hand,"
            "left thigh,right thigh,left shank,right shank,left foot,right foot,left toes,"
            "right toes,");
  // Onto CMU: head, hands and toes have bones there whose direction Bandai
  // Namco does not give.
  const RetargetMap onto_cmu = make_retarget_map(bn.skeleton, cmu.skeleton);
  EXPECT_EQ(names(onto_cmu),
            "neck,upper_trunk,middle_trunk,lower_trunk,left clavicle,right clavicle,"
            "left upper_arm,right upper_arm,left forearm,right forearm,left thigh,right thigh,"
            "left shank,right shank,left foot,right foot,");
  for (const char* j : {"Head", "LeftWrist", "LeftToe", "LHipJoint", "LFingers"})
    EXPECT_FALSE(onto_cmu.compared[static_cast<std::size_t>(cmu.skeleton.find(j))]) << j;
  for (const char* j : {"Hips", "lowerback", "Chest", "Chest2", "lowerneck", "Neck", "LeftHip"})
    EXPECT_TRUE(onto_cmu.compared[static_cast<std::size_t>(cmu.skeleton.find(j))]) << j;
  // Joints without a counterpart keep the neutral pose: identity locally.
  LocalPose local;
  WorldPose world;
  retarget_pose(onto_cmu, cmu.skeleton, world_of(bn, 50), local, world);
  for (const char* j : {"LHipJoint", "LFingers", "Chest"})
    EXPECT_LT(local.rotations[static_cast<std::size_t>(cmu.skeleton.find(j))].angularDistance(
                  Eigen::Quaterniond::Identity()),
              1e-12)
        << j;
}

}  // namespace
}  // namespace mocap
