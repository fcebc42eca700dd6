#pragma once
// Joint classes: which body part (segment class and side) each joint of a
// skeleton is, and which joint a body-part name means.
//
// Classes are recognised from joint names by aliases (CMU original and
// 3ds-max-friendly, Bandai Namco, Mixamo-style, common variants, left and
// right) with the limb chain used to disambiguate (e.g. CMU's 3ds-max
// "LeftShoulder" below "LeftCollar" is an upper arm): docs/body-model.md.
// Names and topology only, no lengths. Never throws: a joint nothing
// recognises is SegmentClass::none.
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/body/segment_class.hpp"
#include "mocap/common/body/skeleton.hpp"

namespace mocap {

/// Segment class and side of every joint of `skel` (by aliases + chain rules),
/// indexed by joint. Sided classes get left or right, the others center.
/// A classified joint whose bone has zero length keeps its class (build_body
/// makes it a point mass at the joint origin).
std::vector<std::pair<SegmentClass, Side>> classify_joints(const Skeleton& skel);

/// Canonical joint name of a body part: "Hips" (lower_trunk), "Spine"
/// (middle_trunk), "Chest" (upper_trunk), "Neck", "Head", "LeftShoulder"
/// (clavicle), "LeftUpperArm", "LeftForeArm", "LeftHand", "LeftUpLeg" (thigh),
/// "LeftLeg" (shank), "LeftFoot", "LeftToe", and "Right..." likewise. Empty for
/// none, for a sided class with Side::center; the side is ignored for the
/// centre classes.
std::string canonical_joint_name(SegmentClass c, Side s);

/// Joint of `skel` that `name` means, -1 if none. The name is read as a body
/// part through the alias table (docs/body-model.md: "LeftArm", "LeftUpperArm",
/// "UpperArm_L", "mixamorig:LeftArm" all mean the left upper arm), so it means
/// the same part on every skeleton:
///  1. a joint named exactly `name` whose class matches that part (any trunk
///     class for a trunk name such as "Spine" or "Chest") is returned;
///  2. else the first joint (lowest index) classified as that part and side;
///  3. else the joint named exactly `name` (names that are no body part, e.g.
///     "LThumb", "joint_Root", and parts this skeleton lacks), or -1.
/// "LeftShoulder" means the clavicle (CMU original, Mixamo, Bandai Namco); on
/// CMU's 3ds-max files, where the joint named LeftShoulder is the upper arm,
/// it resolves to LeftCollar; ask for "LeftUpperArm" to get the upper arm.
int find_joint_by_alias(const Skeleton& skel, const std::string& name);

}  // namespace mocap
