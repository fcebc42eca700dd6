// Body model: joint classes, de Leva masses, COMs, inertias, length scales
// (character files and segment-class names: character_test.cpp).
#include "mocap/common/body/body.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "raw_clip_builder.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

using test::RawClipBuilder;
using V = Eigen::Vector3d;

// de Leva (1996) Table 4, male, percent of total mass (the source values the
// implementation must reproduce; docs/body-model.md).
constexpr double kHeadPct = 6.94, kUptPct = 15.96, kMptPct = 16.33, kLptPct = 11.17,
                 kUpperArmPct = 2.71, kForearmPct = 1.62, kHandPct = 0.61, kThighPct = 14.16,
                 kShankPct = 4.33, kFootPct = 1.37;

std::filesystem::path source_dir() {
  return MOCAP_SOURCE_DIR;
}

// ---------------------------------------------------------------------------
// Names (character files and segment classes: character_test.cpp).

TEST(BodySegmentNames, CanonicalJointNames) {
  EXPECT_EQ(canonical_joint_name(SegmentClass::lower_trunk, Side::center), "Hips");
  EXPECT_EQ(canonical_joint_name(SegmentClass::middle_trunk, Side::center), "Spine");
  EXPECT_EQ(canonical_joint_name(SegmentClass::upper_trunk, Side::center), "Chest");
  EXPECT_EQ(canonical_joint_name(SegmentClass::clavicle, Side::left), "LeftShoulder");
  EXPECT_EQ(canonical_joint_name(SegmentClass::upper_arm, Side::right), "RightUpperArm");
  EXPECT_EQ(canonical_joint_name(SegmentClass::thigh, Side::left), "LeftUpLeg");
  EXPECT_EQ(canonical_joint_name(SegmentClass::shank, Side::right), "RightLeg");
  EXPECT_EQ(canonical_joint_name(SegmentClass::toes, Side::left), "LeftToe");
  EXPECT_EQ(canonical_joint_name(SegmentClass::hand, Side::center), "");
  EXPECT_EQ(canonical_joint_name(SegmentClass::none, Side::left), "");
}

// ---------------------------------------------------------------------------
// Hand-built skeletons (metres, Y up, facing +Z, T-pose).

struct HumanoidOptions {
  bool cmu_hip_joints = false;   // zero-length LHipJoint/RHipJoint above the thighs
  bool zero_hand_bones = false;  // hands end in a zero-length child and End Site
  bool extra_unknown = false;    // a tail and a prop nobody recognises
  std::string prefix;            // e.g. "mixamorig:"
};

HumanoidOptions options(bool cmu_hip_joints, bool zero_hand_bones, bool extra_unknown,
                        std::string prefix = "") {
  HumanoidOptions o;
  o.cmu_hip_joints = cmu_hip_joints;
  o.zero_hand_bones = zero_hand_bones;
  o.extra_unknown = extra_unknown;
  o.prefix = std::move(prefix);
  return o;
}

RawClip humanoid(const HumanoidOptions& o = HumanoidOptions()) {
  RawClipBuilder b;
  const std::string p = o.prefix;
  const int hips = b.joint(p + "Hips", -1, V(0, 1.0, 0), {});
  const int spine = b.joint(p + "Spine", hips, V(0, 0.10, 0), {});
  const int spine1 = b.joint(p + "Spine1", spine, V(0, 0.12, 0), {});
  const int spine2 = b.joint(p + "Spine2", spine1, V(0, 0.14, 0), {});
  const int neck = b.joint(p + "Neck", spine2, V(0, 0.16, 0), {});
  const int head = b.joint(p + "Head", neck, V(0, 0.10, 0), {});
  b.end_site(head, V(0, 0.20, 0));
  for (int s = 0; s < 2; ++s) {
    const std::string side = s == 0 ? "Left" : "Right";
    const double x = s == 0 ? 1.0 : -1.0;
    const int clav = b.joint(p + side + "Shoulder", spine2, V(0.05 * x, 0.12, 0), {});
    const int arm = b.joint(p + side + "Arm", clav, V(0.12 * x, 0, 0), {});
    const int fore = b.joint(p + side + "ForeArm", arm, V(0.28 * x, 0, 0), {});
    const int hand = b.joint(p + side + "Hand", fore, V(0.26 * x, 0, 0), {});
    if (o.zero_hand_bones) {
      const int end = b.joint(p + side + "HandEnd", hand, V(0, 0, 0), {});
      b.end_site(end, V(0, 0, 0));
    } else {
      const int finger = b.joint(p + side + "HandIndex1", hand, V(0.09 * x, 0, 0), {});
      b.end_site(finger, V(0.05 * x, 0, 0));
    }
  }
  for (int s = 0; s < 2; ++s) {
    const std::string side = s == 0 ? "Left" : "Right";
    const double x = s == 0 ? 1.0 : -1.0;
    int parent = hips;
    V hip_offset(0.09 * x, -0.07, 0);
    if (o.cmu_hip_joints) {
      parent = b.joint(p + (s == 0 ? "LHipJoint" : "RHipJoint"), hips, V(0, 0, 0), {});
    }
    const int up = b.joint(p + side + "UpLeg", parent, hip_offset, {});
    const int leg = b.joint(p + side + "Leg", up, V(0, -0.42, 0), {});
    const int foot = b.joint(p + side + "Foot", leg, V(0, -0.43, 0), {});
    const int toe = b.joint(p + side + "ToeBase", foot, V(0, -0.05, 0.13), {});
    b.end_site(toe, V(0, 0, 0.06));
  }
  if (o.extra_unknown) {
    const int tail = b.joint(p + "Tail1", hips, V(0, 0, -0.1), {});
    const int tail2 = b.joint(p + "Tail2", tail, V(0, 0, -0.3), {});
    b.end_site(tail2, V(0, 0, -0.3));
    const int prop = b.joint(p + "Sword", spine2, V(0.3, 0, 0.2), {});
    b.end_site(prop, V(0, 1.0, 0));
  }
  return b.build();
}

Skeleton skeleton_of(const RawClip& clip) {
  return build_skeleton(clip, 1.0);
}

int joint(const Skeleton& s, const std::string& name) {
  const int j = s.find(name);
  EXPECT_GE(j, 0) << name;
  return j;
}
const Segment& seg(const Body& b, const Skeleton& s, const std::string& name) {
  return b.segments.at(static_cast<std::size_t>(joint(s, name)));
}

/// Sum of segment masses by (class, side).
std::map<std::pair<SegmentClass, Side>, double> class_masses(const Body& b) {
  std::map<std::pair<SegmentClass, Side>, double> m;
  for (const Segment& s : b.segments) m[{s.cls, s.side}] += s.mass_kg;
  return m;
}

/// Properties every body must have: one segment per joint, mass sum, COM on the
/// bone, inertia symmetric PSD and zero without a bone.
void expect_well_formed(const Body& body, const Skeleton& skel) {
  ASSERT_EQ(body.segments.size(), skel.joint_count());
  double sum = 0.0;
  for (std::size_t j = 0; j < body.segments.size(); ++j) {
    const Segment& s = body.segments[j];
    SCOPED_TRACE(skel.names[j]);
    EXPECT_EQ(s.joint, static_cast<int>(j));
    EXPECT_GE(s.mass_kg, 0.0);
    sum += s.mass_kg;
    EXPECT_NEAR(s.length_m, s.tip_local_m.norm(), 1e-12);
    // COM = f * tip with 0 <= f <= 1.
    EXPECT_LE(s.com_local_m.cross(s.tip_local_m).norm(), 1e-12);
    const double along = s.com_local_m.dot(s.tip_local_m);
    EXPECT_GE(along, -1e-15);
    EXPECT_LE(along, s.tip_local_m.squaredNorm() + 1e-15);
    const Eigen::Matrix3d& inertia = s.inertia_local_kgm2;
    EXPECT_LE((inertia - inertia.transpose()).norm(), 1e-15);
    const Eigen::Vector3d ev =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia).eigenvalues();
    EXPECT_GE(ev.minCoeff(), -1e-12);
    if (s.length_m == 0.0 || s.mass_kg == 0.0) {
      EXPECT_EQ(inertia.norm(), 0.0);
    }
    EXPECT_FALSE(s.cls == SegmentClass::none && s.mass_kg > 0.0) << "class none with mass";
  }
  EXPECT_NEAR(body.total_mass_kg, sum, 1e-9);
}

TEST(BodyHandBuilt, EmptySkeleton) {
  const Skeleton skel = skeleton_of(RawClipBuilder().build());
  EXPECT_TRUE(classify_joints(skel).empty());
  const Body body = build_body(skel, Character{});
  EXPECT_TRUE(body.segments.empty());
  EXPECT_EQ(body.total_mass_kg, 0.0);
  EXPECT_EQ(find_joint_by_alias(skel, "LeftArm"), -1);
}

TEST(BodyHandBuilt, SingleBoneCarriesTheWholeMassAtTheTableCom) {
  // One upper arm hanging down: every other class gives its mass to its
  // nearest present relative, so this bone carries the total.
  RawClipBuilder b;
  const int arm = b.joint("LeftArm", -1, V(0, 0, 0), {});
  b.end_site(arm, V(0, -0.3, 0));
  const Skeleton skel = skeleton_of(b.build());
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  const Segment& s = body.segments[0];
  EXPECT_EQ(s.cls, SegmentClass::upper_arm);
  EXPECT_EQ(s.side, Side::left);
  EXPECT_NEAR(s.mass_kg, 70.0, 1e-9);
  EXPECT_NEAR(s.length_m, 0.3, 1e-12);
  // de Leva male upper arm: COM 57.72 % from the shoulder.
  EXPECT_LT((s.com_local_m - V(0, -0.3 * 0.5772, 0)).norm(), 1e-12);
  // Bone along -Y: long axis Y (r_long 15.8 %), transverse axis X (26.9 %),
  // sagittal axis Z (28.5 %); I = m (r L)^2 per axis.
  const double m = 70.0, len = 0.3;
  EXPECT_NEAR(s.inertia_local_kgm2(0, 0), m * std::pow(0.269 * len, 2), 1e-12);
  EXPECT_NEAR(s.inertia_local_kgm2(1, 1), m * std::pow(0.158 * len, 2), 1e-12);
  EXPECT_NEAR(s.inertia_local_kgm2(2, 2), m * std::pow(0.285 * len, 2), 1e-12);
  EXPECT_NEAR(s.inertia_local_kgm2(0, 1), 0.0, 1e-15);
  EXPECT_NEAR(s.inertia_local_kgm2(1, 2), 0.0, 1e-15);
}

TEST(BodyHandBuilt, InertiaRotatesWithTheBone) {
  // The same segment along a diagonal: the principal moments are unchanged
  // and the long axis is an eigenvector with m (r_long L)^2.
  RawClipBuilder b;
  const int arm = b.joint("LeftArm", -1, V(0, 0, 0), {});
  const V tip = V(0.1, -0.2, 0.2);
  b.end_site(arm, tip);
  const Skeleton skel = skeleton_of(b.build());
  const Segment s = build_body(skel, Character{}).segments[0];
  const double m = 70.0, len = tip.norm();
  const V u = tip / len;
  EXPECT_NEAR(u.dot(s.inertia_local_kgm2 * u), m * std::pow(0.158 * len, 2), 1e-12);
  EXPECT_LT((s.inertia_local_kgm2 * u - m * std::pow(0.158 * len, 2) * u).norm(), 1e-12);
  EXPECT_NEAR(s.inertia_local_kgm2.trace(),
              m * len * len * (0.158 * 0.158 + 0.269 * 0.269 + 0.285 * 0.285), 1e-12);
}

TEST(BodyHandBuilt, HumanoidUsesTheDeLevaTable) {
  const Skeleton skel = skeleton_of(humanoid());
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
  const auto m = class_masses(body);
  const double M = 70.0;
  using SC = SegmentClass;
  EXPECT_NEAR((m.at({SC::upper_arm, Side::left})), kUpperArmPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::forearm, Side::right})), kForearmPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::hand, Side::left})), kHandPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::thigh, Side::right})), kThighPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::shank, Side::left})), kShankPct / 100 * M, 1e-9);
  // Foot and toes share de Leva's foot; head and neck share de Leva's head;
  // clavicles and the upper trunk share de Leva's upper trunk.
  EXPECT_NEAR((m.at({SC::foot, Side::left}) + m.at({SC::toes, Side::left})), kFootPct / 100 * M,
              1e-9);
  EXPECT_GT((m.at({SC::toes, Side::left})), 0.0);
  EXPECT_NEAR((m.at({SC::head, Side::center}) + m.at({SC::neck, Side::center})), kHeadPct / 100 * M,
              1e-9);
  EXPECT_NEAR((m.at({SC::upper_trunk, Side::center}) + m.at({SC::clavicle, Side::left}) +
               m.at({SC::clavicle, Side::right})),
              kUptPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::middle_trunk, Side::center})), kMptPct / 100 * M, 1e-9);
  EXPECT_NEAR((m.at({SC::lower_trunk, Side::center})), kLptPct / 100 * M, 1e-9);

  // Mixamo's Spine and Spine1 are both middle trunk and share it by length.
  const Segment& sp = seg(body, skel, "Spine");
  const Segment& sp1 = seg(body, skel, "Spine1");
  EXPECT_EQ(sp.cls, SC::middle_trunk);
  EXPECT_EQ(sp1.cls, SC::middle_trunk);
  EXPECT_EQ(seg(body, skel, "Spine2").cls, SC::upper_trunk);
  EXPECT_NEAR(sp.mass_kg / sp1.mass_kg, 0.12 / 0.14, 1e-12);
  // Trunk COMs count from the cranial end in de Leva: middle trunk 45.02 %
  // from the xiphoid is 54.98 % from our (lower) joint.
  EXPECT_LT((sp.com_local_m - V(0, 0.12 * (1 - 0.4502), 0)).norm(), 1e-12);
  // The pelvis bone is the mean of its children (spine and both thighs).
  const Segment& hips = seg(body, skel, "Hips");
  EXPECT_EQ(hips.cls, SC::lower_trunk);
  EXPECT_LT((hips.tip_local_m - V(0, (0.10 - 0.07 - 0.07) / 3, 0)).norm(), 1e-12);
  EXPECT_LT((hips.com_local_m - (1 - 0.6115) * hips.tip_local_m).norm(), 1e-12);
  // Chest-like joint: mean of neck and both clavicles.
  EXPECT_LT((seg(body, skel, "Spine2").tip_local_m - V(0, (0.16 + 0.12 + 0.12) / 3, 0)).norm(),
            1e-12);
  // Fingers are not segments.
  EXPECT_EQ(seg(body, skel, "LeftHandIndex1").cls, SC::none);
  EXPECT_EQ(seg(body, skel, "LeftHandIndex1").mass_kg, 0.0);
  // Left and right match.
  for (SC c : {SC::clavicle, SC::upper_arm, SC::forearm, SC::hand, SC::thigh, SC::shank, SC::foot,
               SC::toes})
    EXPECT_NEAR((m.at({c, Side::left})), (m.at({c, Side::right})), 1e-12) << segment_class_name(c);
}

TEST(BodyHandBuilt, MixamoPrefixIsIgnored) {
  const Skeleton plain = skeleton_of(humanoid());
  const Skeleton mixamo = skeleton_of(humanoid(options(false, false, false, "mixamorig:")));
  EXPECT_EQ(classify_joints(plain), classify_joints(mixamo));
}

TEST(BodyHandBuilt, ZeroLengthHipJointStealsNoMass) {
  const Skeleton plain = skeleton_of(humanoid());
  const Skeleton cmu = skeleton_of(humanoid(options(true, false, false)));
  const Body a = build_body(plain, Character{});
  const Body b = build_body(cmu, Character{});
  expect_well_formed(b, cmu);
  EXPECT_NEAR(b.total_mass_kg, 70.0, 1e-9);
  const Segment& hip_joint = seg(b, cmu, "LHipJoint");
  EXPECT_EQ(hip_joint.cls, SegmentClass::none);
  EXPECT_EQ(hip_joint.mass_kg, 0.0);
  // Its bone is the hip-width vector (looked at, but it carries nothing).
  EXPECT_LT((hip_joint.tip_local_m - V(0.09, -0.07, 0)).norm(), 1e-12);
  EXPECT_EQ(seg(b, cmu, "LeftUpLeg").cls, SegmentClass::thigh);
  EXPECT_NEAR(seg(b, cmu, "LeftUpLeg").mass_kg, seg(a, plain, "LeftUpLeg").mass_kg, 1e-12);
  // The pelvis looks through the zero-offset children to their bones.
  EXPECT_LT((seg(b, cmu, "Hips").tip_local_m - seg(a, plain, "Hips").tip_local_m).norm(), 1e-12);
  EXPECT_NEAR(seg(b, cmu, "Hips").mass_kg, seg(a, plain, "Hips").mass_kg, 1e-12);
}

TEST(BodyHandBuilt, ZeroLengthBones) {
  const Skeleton skel = skeleton_of(humanoid(options(false, true, false)));
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
  // A hand whose only child sits at its origin has no bone: it keeps its
  // class and mass as a point mass at its origin.
  const Segment& hand = seg(body, skel, "LeftHand");
  EXPECT_EQ(hand.cls, SegmentClass::hand);
  EXPECT_EQ(hand.length_m, 0.0);
  EXPECT_NEAR(hand.mass_kg, kHandPct / 100 * 70.0, 1e-9);
  EXPECT_EQ(hand.com_local_m, V(0, 0, 0));
  EXPECT_EQ(hand.inertia_local_kgm2.norm(), 0.0);
  EXPECT_NEAR(seg(body, skel, "LeftForeArm").mass_kg, kForearmPct / 100 * 70.0, 1e-9);
  // The zero-offset child after it is an end marker: no class, no mass.
  EXPECT_EQ(seg(body, skel, "LeftHandEnd").cls, SegmentClass::none);
  EXPECT_EQ(seg(body, skel, "LeftHandEnd").mass_kg, 0.0);
}

TEST(BodyHandBuilt, TerminalJointWithZeroEndSiteIsAPointMass) {
  // Bandai Namco's Head, Hand_* and Toes_* end in a zero End Site.
  RawClip clip = humanoid();
  for (RawJoint& j : clip.joints)
    if (j.name == "Head") j.end_site = V(0, 0, 0);
  const Skeleton skel = skeleton_of(clip);
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  const Segment& head = seg(body, skel, "Head");
  EXPECT_EQ(head.cls, SegmentClass::head);
  EXPECT_EQ(head.length_m, 0.0);
  EXPECT_GT(head.mass_kg, 4.0);
  EXPECT_EQ(head.com_local_m, V(0, 0, 0));
  EXPECT_EQ(head.inertia_local_kgm2.norm(), 0.0);
}

TEST(BodyHandBuilt, UnrecognisedJointsGetNoMass) {
  const Skeleton skel = skeleton_of(humanoid(options(false, false, true)));
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
  for (const char* name : {"Tail1", "Tail2", "Sword"}) {
    EXPECT_EQ(seg(body, skel, name).cls, SegmentClass::none) << name;
    EXPECT_EQ(seg(body, skel, name).mass_kg, 0.0) << name;
  }
  // The rest is classified as without them.
  const Body plain = build_body(skeleton_of(humanoid()), Character{});
  EXPECT_NEAR(
      seg(body, skel, "LeftUpLeg").mass_kg,
      plain.segments[static_cast<std::size_t>(skeleton_of(humanoid()).find("LeftUpLeg"))].mass_kg,
      1e-12);
}

TEST(BodyHandBuilt, NoRecognisableJointsSharesMassByLength) {
  RawClipBuilder b;
  const int a = b.joint("Alpha", -1, V(0, 0, 0), {});
  const int c = b.joint("Beta", a, V(1.0, 0, 0), {});
  const int d = b.joint("Gamma", c, V(0, 2.0, 0), {});
  b.end_site(d, V(0, 0, 1.0));
  const Skeleton skel = skeleton_of(b.build());
  for (const auto& [cls, side] : classify_joints(skel)) EXPECT_EQ(cls, SegmentClass::none);
  const Body body = build_body(skel, Character{});
  ASSERT_EQ(body.segments.size(), 3u);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
  EXPECT_NEAR(body.segments[0].mass_kg, 70.0 * 1 / 4, 1e-9);
  EXPECT_NEAR(body.segments[1].mass_kg, 70.0 * 2 / 4, 1e-9);
  EXPECT_NEAR(body.segments[2].mass_kg, 70.0 * 1 / 4, 1e-9);
  // Uniform rods: COM in the middle.
  EXPECT_LT((body.segments[1].com_local_m - V(0, 1.0, 0)).norm(), 1e-12);
  for (const Segment& s : body.segments) {
    const Eigen::Vector3d ev =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(s.inertia_local_kgm2).eigenvalues();
    EXPECT_NEAR(ev.maxCoeff(), s.mass_kg * s.length_m * s.length_m / 12.0, 1e-9);
  }
}

/// One naming convention for the same body: '#' in a name is replaced by the
/// side token. An empty clavicle or hip-joint name leaves that joint out.
struct NameSet {
  std::string left, right;
  std::string pelvis;
  std::vector<std::string> spine, neck;
  std::string head, clavicle, upper_arm, forearm, hand, finger, hip_joint, thigh, shank, foot, toe;
};

std::string named(const std::string& pattern, const std::string& side) {
  std::string out;
  for (char c : pattern) {
    if (c == '#')
      out += side;
    else
      out += c;
  }
  return out;
}

/// Builds the body of `n` (T-pose, metres) and checks every class and side.
void expect_naming_convention(const NameSet& n) {
  SCOPED_TRACE(n.pelvis + " / " + n.upper_arm);
  RawClipBuilder b;
  std::map<int, std::pair<SegmentClass, Side>> expected;
  const int pelvis = b.joint(n.pelvis, -1, V(0, 1, 0), {});
  expected[pelvis] = {SegmentClass::lower_trunk, Side::center};
  int top = pelvis;
  for (std::size_t i = 0; i < n.spine.size(); ++i) {
    top = b.joint(n.spine[i], top, V(0, 0.12, 0), {});
    expected[top] = {
        i + 1 == n.spine.size() ? SegmentClass::upper_trunk : SegmentClass::middle_trunk,
        Side::center};
  }
  int up = top;
  for (const std::string& nk : n.neck) {
    up = b.joint(nk, up, V(0, 0.08, 0), {});
    expected[up] = {SegmentClass::neck, Side::center};
  }
  const int head = b.joint(n.head, up, V(0, 0.08, 0), {});
  b.end_site(head, V(0, 0.2, 0));
  expected[head] = {SegmentClass::head, Side::center};
  for (int k = 0; k < 2; ++k) {
    const Side side = k == 0 ? Side::left : Side::right;
    const std::string t = k == 0 ? n.left : n.right;
    const double x = k == 0 ? 1.0 : -1.0;
    int arm_parent = top;
    if (!n.clavicle.empty()) {
      arm_parent = b.joint(named(n.clavicle, t), top, V(0.03 * x, 0.1, 0), {});
      expected[arm_parent] = {SegmentClass::clavicle, side};
    }
    const int ua = b.joint(named(n.upper_arm, t), arm_parent, V(0.15 * x, 0, 0), {});
    const int fa = b.joint(named(n.forearm, t), ua, V(0.28 * x, 0, 0), {});
    const int hd = b.joint(named(n.hand, t), fa, V(0.26 * x, 0, 0), {});
    const int fg = b.joint(named(n.finger, t), hd, V(0.09 * x, 0, 0), {});
    b.end_site(fg, V(0.04 * x, 0, 0));
    expected[ua] = {SegmentClass::upper_arm, side};
    expected[fa] = {SegmentClass::forearm, side};
    expected[hd] = {SegmentClass::hand, side};
    expected[fg] = {SegmentClass::none, Side::center};
    int leg_parent = pelvis;
    if (!n.hip_joint.empty()) {
      leg_parent = b.joint(named(n.hip_joint, t), pelvis, V(0, 0, 0), {});
      expected[leg_parent] = {SegmentClass::none, Side::center};
    }
    const int th = b.joint(named(n.thigh, t), leg_parent, V(0.09 * x, -0.07, 0), {});
    const int sh = b.joint(named(n.shank, t), th, V(0, -0.42, 0), {});
    const int ft = b.joint(named(n.foot, t), sh, V(0, -0.43, 0), {});
    const int to = b.joint(named(n.toe, t), ft, V(0, -0.05, 0.13), {});
    b.end_site(to, V(0, 0, 0.05));
    expected[th] = {SegmentClass::thigh, side};
    expected[sh] = {SegmentClass::shank, side};
    expected[ft] = {SegmentClass::foot, side};
    expected[to] = {SegmentClass::toes, side};
  }
  const Skeleton skel = skeleton_of(b.build());
  const auto classes = classify_joints(skel);
  for (const auto& [j, want] : expected) {
    const auto& got = classes[static_cast<std::size_t>(j)];
    EXPECT_EQ(got.first, want.first)
        << skel.names[static_cast<std::size_t>(j)] << " is " << segment_class_name(got.first);
    EXPECT_EQ(got.second, want.second) << skel.names[static_cast<std::size_t>(j)];
  }
  const Body body = build_body(skel, Character{});
  expect_well_formed(body, skel);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
}

TEST(BodyHandBuilt, NamingConventions) {
  // CMU original (ASF to BVH): LeftShoulder is the clavicle here.
  expect_naming_convention({"Left",
                            "Right",
                            "Hips",
                            {"LowerBack", "Spine", "Spine1"},
                            {"Neck", "Neck1"},
                            "Head",
                            "#Shoulder",
                            "#Arm",
                            "#ForeArm",
                            "#Hand",
                            "#HandIndex1",
                            "#HipJoint",
                            "#UpLeg",
                            "#Leg",
                            "#Foot",
                            "#ToeBase"});
  // CMU 3ds-max friendly: the joint at the shoulder owns the upper arm.
  expect_naming_convention({"Left",
                            "Right",
                            "Hips",
                            {"lowerback", "Chest", "Chest2"},
                            {"lowerneck", "Neck"},
                            "Head",
                            "#Collar",
                            "#Shoulder",
                            "#Elbow",
                            "#Wrist",
                            "#Fingers",
                            "",
                            "#Hip",
                            "#Knee",
                            "#Ankle",
                            "#Toe"});
  // Bandai Namco style suffixes.
  expect_naming_convention({"L",
                            "R",
                            "Hips",
                            {"Spine", "Chest"},
                            {"Neck"},
                            "Head",
                            "Shoulder_#",
                            "UpperArm_#",
                            "LowerArm_#",
                            "Hand_#",
                            "Index_#",
                            "",
                            "UpperLeg_#",
                            "LowerLeg_#",
                            "Foot_#",
                            "Toes_#"});
  // 3ds Max biped.
  expect_naming_convention({"L",
                            "R",
                            "Bip01 Pelvis",
                            {"Bip01 Spine", "Bip01 Spine1"},
                            {"Bip01 Neck"},
                            "Bip01 Head",
                            "Bip01 # Clavicle",
                            "Bip01 # UpperArm",
                            "Bip01 # Forearm",
                            "Bip01 # Hand",
                            "Bip01 # Finger0",
                            "",
                            "Bip01 # Thigh",
                            "Bip01 # Calf",
                            "Bip01 # Foot",
                            "Bip01 # Toe0"});
  // Blender (.L/.R) style, and a game-engine (l_/r_) style without clavicles.
  expect_naming_convention({"L",
                            "R",
                            "pelvis",
                            {"spine", "chest"},
                            {"neck"},
                            "head",
                            "shoulder.#",
                            "upper_arm.#",
                            "forearm.#",
                            "hand.#",
                            "finger.#",
                            "",
                            "thigh.#",
                            "shin.#",
                            "foot.#",
                            "toe.#"});
  expect_naming_convention({"l",
                            "r",
                            "pelvis",
                            {"spine_01", "spine_02", "spine_03"},
                            {"neck_01"},
                            "head",
                            "",
                            "#_upperarm",
                            "#_lowerarm",
                            "#_hand",
                            "#_thumb",
                            "",
                            "#_thigh",
                            "#_calf",
                            "#_foot",
                            "#_ball"});
}

TEST(BodyHandBuilt, RandomSkeletonsKeepTheTotalMass) {
  // Random trees (several roots, zero offsets, names from the alias table and
  // nonsense) never crash and always carry exactly the total mass.
  const std::vector<std::string> words = {"Hips",          "Spine",        "Chest",
                                          "Neck",          "Head",         "LeftShoulder",
                                          "RightShoulder", "LeftArm",      "RightArm",
                                          "LeftForeArm",   "RightForeArm", "LeftHand",
                                          "RightHand",     "LeftUpLeg",    "RightUpLeg",
                                          "LeftLeg",       "RightLeg",     "LeftFoot",
                                          "RightFoot",     "LeftToe",      "RightToe",
                                          "LHipJoint",     "lhand",        "LThumb",
                                          "joint_Root",    "Tail",         "Prop",
                                          "HeadTop_End",   "Hand_L",       "UpperArm_R",
                                          "l_calf",        "spine.001",    ""};
  std::mt19937 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    RawClipBuilder b;
    const int n = 1 + static_cast<int>(rng() % 40);
    for (int j = 0; j < n; ++j) {
      const int parent =
          j == 0 || rng() % 10 == 0 ? -1 : static_cast<int>(rng() % static_cast<unsigned>(j));
      const double len = rng() % 4 == 0 ? 0.0 : 0.01 * static_cast<double>(rng() % 50);
      const int id =
          b.joint(words[rng() % words.size()], parent, V(len, -0.5 * len, 0.25 * len), {});
      if (rng() % 3 == 0) b.end_site(id, V(0, 0.01 * static_cast<double>(rng() % 20), 0));
    }
    const Skeleton skel = skeleton_of(b.build());
    Character ch;
    ch.class_length_scale[SegmentClass::thigh] = 1.3;
    const Skeleton scaled = apply_length_scales(skel, ch);
    const Body body = build_body(scaled, ch);
    ASSERT_EQ(body.segments.size(), skel.joint_count());
    double bones = 0.0;
    for (const Segment& s : body.segments) bones += s.length_m;
    const bool recognised =
        std::any_of(body.segments.begin(), body.segments.end(),
                    [](const Segment& s) { return s.cls != SegmentClass::none; });
    if (recognised || bones > 0.0) {
      EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9) << "trial " << trial;
    } else {
      EXPECT_EQ(body.total_mass_kg, 0.0);
    }
    for (const Segment& s : body.segments) {
      EXPECT_TRUE(std::isfinite(s.mass_kg));
      EXPECT_TRUE(s.inertia_local_kgm2.allFinite());
    }
  }
}

TEST(BodyHandBuilt, AliasesResolveOnAnySkeleton) {
  const Skeleton skel = skeleton_of(humanoid(options(false, false, true)));
  const int arm = skel.find("LeftArm");
  for (const char* n : {"LeftArm", "LeftUpperArm", "UpperArm_L", "upperarm.l", "mixamorig:LeftArm",
                        "l_upperarm", "Bip01 L UpperArm", "lhumerus"})
    EXPECT_EQ(find_joint_by_alias(skel, n), arm) << n;
  EXPECT_EQ(find_joint_by_alias(skel, "RightShoulder"), skel.find("RightShoulder"));
  EXPECT_EQ(find_joint_by_alias(skel, "RightCollar"), skel.find("RightShoulder"));
  EXPECT_EQ(find_joint_by_alias(skel, "Pelvis"), skel.find("Hips"));
  EXPECT_EQ(find_joint_by_alias(skel, "RightKnee"), skel.find("RightLeg"));
  EXPECT_EQ(find_joint_by_alias(skel, "Chest"), skel.find("Spine2"));
  EXPECT_EQ(find_joint_by_alias(skel, "Spine1"), skel.find("Spine1"));  // exact, a trunk joint
  EXPECT_EQ(find_joint_by_alias(skel, "Tail2"), skel.find("Tail2"));    // exact, no body part
  EXPECT_EQ(find_joint_by_alias(skel, "Wing_L"), -1);
  EXPECT_EQ(find_joint_by_alias(skel, "LeftEye"), -1);
}

TEST(BodyHandBuilt, JointOverridesAndUnmatchedNames) {
  const Skeleton skel = skeleton_of(humanoid());
  Character ch;
  ch.joint_mass_kg["LeftUpperArm"] = 5.0;
  ch.joint_mass_kg["Wing_L"] = 1.0;
  ch.joint_length_scale["Antenna"] = 2.0;
  ch.class_mass_kg[SegmentClass::upper_arm] = 3.0;  // the joint setting wins on the left
  const Body body = build_body(skel, ch);
  expect_well_formed(body, skel);
  EXPECT_EQ(seg(body, skel, "LeftArm").mass_kg, 5.0);
  EXPECT_NEAR(seg(body, skel, "RightArm").mass_kg, 3.0, 1e-12);
  EXPECT_EQ(body.unmatched_joints, (std::vector<std::string>{"Antenna", "Wing_L"}));
}

TEST(BodyHandBuilt, MassScaleMultipliesTheTableMass) {
  const Skeleton skel = skeleton_of(humanoid());
  Character ch;
  ch.class_mass_scale[SegmentClass::thigh] = 1.5;
  const Body a = build_body(skel, Character{});
  const Body b = build_body(skel, ch);
  EXPECT_NEAR(seg(b, skel, "RightUpLeg").mass_kg, 1.5 * seg(a, skel, "RightUpLeg").mass_kg, 1e-12);
  EXPECT_NEAR(b.total_mass_kg - a.total_mass_kg, 0.5 * 2 * kThighPct / 100 * 70.0, 1e-9);
}

TEST(BodyHandBuilt, LengthScaleScalesTheOwnedBone) {
  const Skeleton skel = skeleton_of(humanoid(options(true, false, false)));
  Character ch;
  ch.class_length_scale[SegmentClass::forearm] = 1.5;
  ch.class_length_scale[SegmentClass::lower_trunk] = 1.2;
  ch.joint_length_scale["LeftForeArm"] = 2.0;  // joint wins over class
  const Skeleton scaled = apply_length_scales(skel, ch);
  ASSERT_EQ(scaled.translation_scales.size(), skel.joint_count());
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("LeftHand"))], 2.0);
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("RightHand"))], 1.5);
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("RightForeArm"))], 1.0);
  // LHipJoint sits at the pelvis origin, so it inherits the pelvis scale and
  // the hip width grows; the root is never scaled.
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("LeftUpLeg"))], 1.2);
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("Spine"))], 1.2);
  EXPECT_EQ(scaled.translation_scales[static_cast<std::size_t>(skel.find("Hips"))], 1.0);
  // End Sites of scaled segments.
  Character toes;
  toes.class_length_scale[SegmentClass::toes] = 3.0;
  const Skeleton long_toes = apply_length_scales(skel, toes);
  const auto t = static_cast<std::size_t>(skel.find("LeftToeBase"));
  EXPECT_LT((long_toes.end_sites_m[t] - 3.0 * skel.end_sites_m[t]).norm(), 1e-15);
  const Body body = build_body(scaled, ch);
  EXPECT_NEAR(seg(body, scaled, "LeftForeArm").length_m, 2.0 * 0.26, 1e-12);
  EXPECT_NEAR(seg(body, scaled, "RightForeArm").length_m, 1.5 * 0.26, 1e-12);
  EXPECT_NEAR(seg(body, scaled, "RightArm").length_m, 0.28, 1e-12);
  EXPECT_NEAR(seg(body, scaled, "RightHand").length_m, 0.09, 1e-12);
}

// ---------------------------------------------------------------------------
// Real skeletons.

const char* kBandaiFile = "bandai-namco-1/data/dataset-1_walk_normal_001.bvh";
const char* kCmuFile = "cmu/131_01.bvh";

struct RealClip {
  RawClip raw;
  Skeleton skel;
};

RealClip load(const char* rel, LengthUnit unit) {
  RealClip c;
  c.raw = read_bvh_file(test::data_dir() / rel);
  c.skel = build_skeleton(c.raw, unit_scale_m(unit));
  return c;
}

constexpr SegmentClass kCenter[] = {SegmentClass::head, SegmentClass::neck,
                                    SegmentClass::upper_trunk, SegmentClass::middle_trunk,
                                    SegmentClass::lower_trunk};
constexpr SegmentClass kSided[] = {
    SegmentClass::clavicle, SegmentClass::upper_arm, SegmentClass::forearm, SegmentClass::hand,
    SegmentClass::thigh,    SegmentClass::shank,     SegmentClass::foot,    SegmentClass::toes};

void expect_full_body(const Skeleton& skel, const Body& body) {
  expect_well_formed(body, skel);
  EXPECT_NEAR(body.total_mass_kg, 70.0, 1e-9);
  const auto m = class_masses(body);
  for (SegmentClass c : kCenter)
    EXPECT_TRUE(m.count({c, Side::center})) << "missing " << segment_class_name(c);
  for (SegmentClass c : kSided) {
    ASSERT_TRUE(m.count({c, Side::left})) << "missing left " << segment_class_name(c);
    ASSERT_TRUE(m.count({c, Side::right})) << "missing right " << segment_class_name(c);
    EXPECT_NEAR(m.at({c, Side::left}), m.at({c, Side::right}), 1e-12) << segment_class_name(c);
  }
  // Canonical names find a joint of their own class on this skeleton.
  for (const Segment& s : body.segments) {
    if (s.cls == SegmentClass::none) continue;
    const int j = find_joint_by_alias(skel, canonical_joint_name(s.cls, s.side));
    ASSERT_GE(j, 0) << canonical_joint_name(s.cls, s.side);
    const bool trunk_name =
        s.cls == SegmentClass::middle_trunk || s.cls == SegmentClass::upper_trunk;
    const SegmentClass got = body.segments[static_cast<std::size_t>(j)].cls;
    if (trunk_name) {
      EXPECT_TRUE(got == SegmentClass::middle_trunk || got == SegmentClass::upper_trunk);
    } else {
      EXPECT_EQ(got, s.cls) << canonical_joint_name(s.cls, s.side);
    }
  }
}

void expect_class(const Skeleton& skel, const Body& body, const std::string& name, SegmentClass c,
                  Side s) {
  const Segment& g = seg(body, skel, name);
  EXPECT_EQ(g.cls, c) << name << " is " << segment_class_name(g.cls);
  EXPECT_EQ(g.side, s) << name;
}

TEST(BodyReal, BandaiNamco) {
  MOCAP_REQUIRE_DATA();
  const RealClip c = load(kBandaiFile, LengthUnit::cm);
  const Body body = build_body(c.skel, Character{});
  expect_full_body(c.skel, body);
  using SC = SegmentClass;
  expect_class(c.skel, body, "joint_Root", SC::none, Side::center);
  EXPECT_EQ(seg(body, c.skel, "joint_Root").mass_kg, 0.0);
  expect_class(c.skel, body, "Hips", SC::lower_trunk, Side::center);
  expect_class(c.skel, body, "Spine", SC::middle_trunk, Side::center);
  expect_class(c.skel, body, "Chest", SC::upper_trunk, Side::center);
  expect_class(c.skel, body, "Neck", SC::neck, Side::center);
  expect_class(c.skel, body, "Head", SC::head, Side::center);
  expect_class(c.skel, body, "Shoulder_L", SC::clavicle, Side::left);
  expect_class(c.skel, body, "UpperArm_R", SC::upper_arm, Side::right);
  expect_class(c.skel, body, "LowerArm_L", SC::forearm, Side::left);
  expect_class(c.skel, body, "Hand_R", SC::hand, Side::right);
  expect_class(c.skel, body, "UpperLeg_L", SC::thigh, Side::left);
  expect_class(c.skel, body, "LowerLeg_R", SC::shank, Side::right);
  expect_class(c.skel, body, "Foot_L", SC::foot, Side::left);
  expect_class(c.skel, body, "Toes_R", SC::toes, Side::right);
  // Head, hands and toes end in zero End Sites: point masses at their joints.
  EXPECT_EQ(seg(body, c.skel, "Head").length_m, 0.0);
  EXPECT_GT(seg(body, c.skel, "Head").mass_kg, 0.0);
  // Thigh bone: UpperLeg_L -> LowerLeg_L, 39.08 cm.
  EXPECT_NEAR(seg(body, c.skel, "UpperLeg_L").length_m, 0.390811, 1e-6);
  EXPECT_NEAR(seg(body, c.skel, "UpperLeg_L").mass_kg, kThighPct / 100 * 70, 1e-9);
  EXPECT_EQ(find_joint_by_alias(c.skel, "LeftShoulder"), c.skel.find("Shoulder_L"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "RightUpperArm"), c.skel.find("UpperArm_R"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "mixamorig:LeftUpLeg"), c.skel.find("UpperLeg_L"));
}

TEST(BodyReal, Cmu3dsMaxNaming) {
  MOCAP_REQUIRE_DATA();
  const RealClip c = load(kCmuFile, LengthUnit::cmu);
  const Body body = build_body(c.skel, Character{});
  expect_full_body(c.skel, body);
  using SC = SegmentClass;
  expect_class(c.skel, body, "Hips", SC::lower_trunk, Side::center);
  expect_class(c.skel, body, "LHipJoint", SC::none, Side::center);
  EXPECT_EQ(seg(body, c.skel, "LHipJoint").mass_kg, 0.0);
  expect_class(c.skel, body, "LeftHip", SC::thigh, Side::left);
  expect_class(c.skel, body, "RightKnee", SC::shank, Side::right);
  expect_class(c.skel, body, "LeftAnkle", SC::foot, Side::left);
  expect_class(c.skel, body, "RightToe", SC::toes, Side::right);
  expect_class(c.skel, body, "lowerback", SC::middle_trunk, Side::center);
  expect_class(c.skel, body, "Chest", SC::middle_trunk, Side::center);
  expect_class(c.skel, body, "Chest2", SC::upper_trunk, Side::center);
  expect_class(c.skel, body, "lowerneck", SC::neck, Side::center);
  expect_class(c.skel, body, "Neck", SC::neck, Side::center);
  expect_class(c.skel, body, "Head", SC::head, Side::center);
  expect_class(c.skel, body, "LeftCollar", SC::clavicle, Side::left);
  expect_class(c.skel, body, "LeftShoulder", SC::upper_arm, Side::left);
  expect_class(c.skel, body, "RightElbow", SC::forearm, Side::right);
  expect_class(c.skel, body, "LeftWrist", SC::hand, Side::left);
  for (const char* n : {"lhand", "LFingers", "LThumb", "rhand", "RFingers", "RThumb"})
    EXPECT_EQ(seg(body, c.skel, n).mass_kg, 0.0) << n;
  // Thigh LeftHip -> LeftKnee: (2.49329, -6.85026, 0) CMU units.
  EXPECT_NEAR(seg(body, c.skel, "LeftHip").length_m, V(2.49329, -6.85026, 0).norm() * 0.056444,
              1e-9);
  // The wrist's children sit at its origin: its bone looks through them.
  EXPECT_GT(seg(body, c.skel, "LeftWrist").length_m, 0.02);
  // "LeftShoulder" means the clavicle everywhere; the upper arm has its own name.
  EXPECT_EQ(find_joint_by_alias(c.skel, "LeftShoulder"), c.skel.find("LeftCollar"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "LeftUpperArm"), c.skel.find("LeftShoulder"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "LeftArm"), c.skel.find("LeftShoulder"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "LeftUpLeg"), c.skel.find("LeftHip"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "Chest"), c.skel.find("Chest"));
  // Names that are no body part resolve exactly; "lhand" is one (the hand).
  EXPECT_EQ(find_joint_by_alias(c.skel, "LThumb"), c.skel.find("LThumb"));
  EXPECT_EQ(find_joint_by_alias(c.skel, "lhand"), c.skel.find("LeftWrist"));
}

TEST(BodyReal, HeavyUpperArmChangesOnlyTheUpperArms) {
  MOCAP_REQUIRE_DATA();
  const Character heavy =
      read_character_file(source_dir() / "docs/examples/character-heavy-arms.json");
  const Character def = read_character_file(source_dir() / "docs/examples/character-default.json");
  for (const auto& [file, unit] :
       {std::pair{kBandaiFile, LengthUnit::cm}, {kCmuFile, LengthUnit::cmu}}) {
    SCOPED_TRACE(file);
    const RealClip c = load(file, unit);
    const Body a = build_body(c.skel, def);
    const Body b = build_body(c.skel, heavy);
    expect_well_formed(b, c.skel);
    const Body plain = build_body(c.skel, Character{});
    for (std::size_t j = 0; j < a.segments.size(); ++j) {
      EXPECT_EQ(a.segments[j].mass_kg, plain.segments[j].mass_kg);
      if (a.segments[j].cls == SegmentClass::upper_arm) {
        EXPECT_NEAR(b.segments[j].mass_kg, heavy.class_mass_kg.at(SegmentClass::upper_arm), 1e-12);
        EXPECT_GT(b.segments[j].inertia_local_kgm2.trace(),
                  a.segments[j].inertia_local_kgm2.trace());
      } else {
        EXPECT_EQ(b.segments[j].mass_kg, a.segments[j].mass_kg) << c.skel.names[j];
        EXPECT_EQ(b.segments[j].inertia_local_kgm2, a.segments[j].inertia_local_kgm2);
      }
      EXPECT_EQ(b.segments[j].com_local_m, a.segments[j].com_local_m);
    }
  }
}

TEST(BodyReal, LengthScaleMovesBonesAndForwardKinematics) {
  MOCAP_REQUIRE_DATA();
  Character ch;
  ch.class_length_scale[SegmentClass::upper_arm] = 1.25;
  for (const auto& [file, unit] :
       {std::pair{kBandaiFile, LengthUnit::cm}, {kCmuFile, LengthUnit::cmu}}) {
    SCOPED_TRACE(file);
    const RealClip c = load(file, unit);
    const Skeleton scaled = apply_length_scales(c.skel, ch);
    const Body a = build_body(c.skel, ch);
    const Body b = build_body(scaled, ch);
    const int upper = find_joint_by_alias(c.skel, "LeftUpperArm");
    const int fore = find_joint_by_alias(c.skel, "LeftForeArm");
    const int hand = find_joint_by_alias(c.skel, "LeftHand");
    ASSERT_GE(upper, 0);
    ASSERT_GE(fore, 0);
    ASSERT_GE(hand, 0);
    for (std::size_t j = 0; j < a.segments.size(); ++j) {
      const double k = a.segments[j].cls == SegmentClass::upper_arm ? 1.25 : 1.0;
      EXPECT_NEAR(b.segments[j].length_m, k * a.segments[j].length_m, 1e-12) << c.skel.names[j];
    }
    // FK: the elbow moves out along the upper arm by 25 %, the forearm is unchanged.
    LocalPose local;
    WorldPose w0, w1;
    for (std::size_t f : {std::size_t{0}, c.raw.frame_count / 2}) {
      local_pose_from_row(c.skel, c.raw.frame(f), local);
      forward_kinematics(c.skel, local, w0);
      local_pose_from_row(scaled, c.raw.frame(f), local);
      forward_kinematics(scaled, local, w1);
      const auto u = static_cast<std::size_t>(upper), fa = static_cast<std::size_t>(fore),
                 h = static_cast<std::size_t>(hand);
      const V arm0 = w0.positions_m[fa] - w0.positions_m[u];
      const V arm1 = w1.positions_m[fa] - w1.positions_m[u];
      EXPECT_LT((arm1 - 1.25 * arm0).norm(), 1e-9);
      EXPECT_LT(
          ((w1.positions_m[h] - w1.positions_m[fa]) - (w0.positions_m[h] - w0.positions_m[fa]))
              .norm(),
          1e-9);
      EXPECT_LT((w1.positions_m[u] - w0.positions_m[u]).norm(), 1e-12);
    }
  }
}

TEST(BodyReal, FemaleTableDiffers) {
  MOCAP_REQUIRE_DATA();
  const RealClip c = load(kCmuFile, LengthUnit::cmu);
  Character female;
  female.sex = Sex::female;
  const Body m = build_body(c.skel, Character{});
  const Body f = build_body(c.skel, female);
  expect_full_body(c.skel, f);
  const auto thigh = static_cast<std::size_t>(c.skel.find("LeftHip"));
  // de Leva: thigh 14.16 % (male) vs 14.78 % of 99.99 % (female table sum).
  EXPECT_NEAR(m.segments[thigh].mass_kg, 0.1416 * 70, 1e-9);
  EXPECT_NEAR(f.segments[thigh].mass_kg, 14.78 / 99.99 * 70, 1e-9);
  // COM fraction differs too (40.95 % vs 36.12 % from the hip).
  EXPECT_NEAR(m.segments[thigh].com_local_m.norm() / m.segments[thigh].length_m, 0.4095, 1e-12);
  EXPECT_NEAR(f.segments[thigh].com_local_m.norm() / f.segments[thigh].length_m, 0.3612, 1e-12);
}

TEST(BodyReal, EveryBandaiNamcoSet1SkeletonIsComplete) {
  MOCAP_REQUIRE_DATA();
  // All set-1 clips share one hierarchy; check a spread of them anyway.
  std::set<std::uint64_t> ids;
  int checked = 0;
  for (const auto& e :
       std::filesystem::directory_iterator(test::data_dir() / "bandai-namco-1/data")) {
    if (e.path().extension() != ".bvh" || (checked++ % 25) != 0) continue;
    const Skeleton skel = build_skeleton(read_bvh_file(e.path()), 0.01);
    if (!ids.insert(skel.id()).second) continue;
    SCOPED_TRACE(e.path().string());
    expect_full_body(skel, build_body(skel, Character{}));
  }
  EXPECT_GE(ids.size(), 1u);
}

}  // namespace
}  // namespace mocap
