#pragma once
// Joint-name aliases (internal to the body model): what a joint name says.
//
// A name is split into lower-case tokens (namespace "a:b" and "a|b" prefixes
// dropped, separators and camelCase boundaries split, exporter prefixes such as
// "mixamorig" or "Bip01" dropped), a side token (left/l/right/r, or an "l"/"r"
// glued to a limb word as in CMU's "lhand") is taken out, and the rest, joined
// and without trailing digits, is looked up in the alias table (CMU original
// and 3ds-max-friendly, Bandai Namco, Mixamo-style, common variants). A name
// alone is only a hint: the classifier (joint_classifier.hpp) decides with the
// tree.
#include <string>
#include <utility>

#include "mocap/common/body/segment_class.hpp"

namespace mocap::detail {

/// What a name says a joint is, before the tree is looked at.
enum class Kind {
  unknown,
  dummy,       // joint_Root, Reference, ...
  end_marker,  // HeadTop_End, LeftToe_End, ...
  pelvis,
  trunk,  // spine / chest parts; `trunk_hint` says which one a query means
  neck,
  head,
  clavicle,
  shoulder,  // clavicle or upper arm: decided by the chain
  upper_arm,
  forearm,
  hand,
  finger,
  hip_joint,  // CMU LHipJoint: the hip-width bone, part of the pelvis
  thigh,
  shank,
  foot,
  toes,
};

struct NameInfo {
  Kind kind = Kind::unknown;
  /// center when the name has no side token.
  Side side = Side::center;
  /// For Kind::trunk: upper_trunk for chest words, else middle_trunk.
  SegmentClass trunk_hint = SegmentClass::middle_trunk;
};

/// Reads a joint name (any case, any exporter's spelling). Never throws: a
/// name it does not know is Kind::unknown.
NameInfo parse_name(const std::string& raw);

/// The body part a name means (for queries and character files): its class
/// and side; {none, center} for names that are no body part (dummy, end
/// marker, finger, hip joint, unknown). A trunk name gives its trunk_hint.
std::pair<SegmentClass, Side> name_part(const NameInfo& n);

}  // namespace mocap::detail
