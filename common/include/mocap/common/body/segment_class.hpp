#pragma once
// Segment classes: the body parts the body model knows (docs/body-model.md).
//
// Every joint of a skeleton gets one class and one side (classify_joints,
// joint_classes.hpp); the class picks its row of the anthropometric table
// (build_body, body.hpp), and character files (character.hpp) set masses and
// lengths per class. The sided classes (clavicle .. toes) come as a left and a
// right joint; the others are centred.
#include <array>
#include <optional>
#include <string>

namespace mocap {

enum class SegmentClass {
  none,  // no mass (dummy roots such as joint_Root, fingers, unrecognised)
  head,  // head (de Leva: head + neck when there is no neck joint)
  neck,
  upper_trunk,   // thorax / chest
  middle_trunk,  // abdomen / spine
  lower_trunk,   // pelvis (the root, canonical Hips)
  clavicle,      // shoulder girdle (collar)
  upper_arm,
  forearm,
  hand,
  thigh,
  shank,
  foot,
  toes,
};
enum class Side { center, left, right };

/// Every class but none, in declaration order (the classes that carry mass).
inline constexpr std::array<SegmentClass, 13> kMassiveClasses = {
    SegmentClass::head,         SegmentClass::neck,        SegmentClass::upper_trunk,
    SegmentClass::middle_trunk, SegmentClass::lower_trunk, SegmentClass::clavicle,
    SegmentClass::upper_arm,    SegmentClass::forearm,     SegmentClass::hand,
    SegmentClass::thigh,        SegmentClass::shank,       SegmentClass::foot,
    SegmentClass::toes};

/// True for the classes with a left and a right (clavicle, upper_arm, forearm,
/// hand, thigh, shank, foot, toes); false for none, head, neck and the trunk.
bool is_sided(SegmentClass c);
/// True for upper_trunk, middle_trunk and lower_trunk.
bool is_trunk(SegmentClass c);

/// "head", "upper_arm", ... (the names used in JSON and docs); "none" for none.
const char* segment_class_name(SegmentClass c);
/// Inverse of segment_class_name ("none" included); nullopt for any other text
/// (case-sensitive).
std::optional<SegmentClass> parse_segment_class(const std::string& s);
/// "center", "left", "right".
const char* side_name(Side s);

}  // namespace mocap
