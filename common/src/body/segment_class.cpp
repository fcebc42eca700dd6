// Segment classes and sides: their predicates and their names in JSON and docs.
#include "mocap/common/body/segment_class.hpp"

namespace mocap {

bool is_sided(SegmentClass c) {
  switch (c) {
    case SegmentClass::clavicle:
    case SegmentClass::upper_arm:
    case SegmentClass::forearm:
    case SegmentClass::hand:
    case SegmentClass::thigh:
    case SegmentClass::shank:
    case SegmentClass::foot:
    case SegmentClass::toes:
      return true;
    default:
      return false;
  }
}

bool is_trunk(SegmentClass c) {
  return c == SegmentClass::upper_trunk || c == SegmentClass::middle_trunk ||
         c == SegmentClass::lower_trunk;
}

const char* segment_class_name(SegmentClass c) {
  switch (c) {
    case SegmentClass::none:
      return "none";
    case SegmentClass::head:
      return "head";
    case SegmentClass::neck:
      return "neck";
    case SegmentClass::upper_trunk:
      return "upper_trunk";
    case SegmentClass::middle_trunk:
      return "middle_trunk";
    case SegmentClass::lower_trunk:
      return "lower_trunk";
    case SegmentClass::clavicle:
      return "clavicle";
    case SegmentClass::upper_arm:
      return "upper_arm";
    case SegmentClass::forearm:
      return "forearm";
    case SegmentClass::hand:
      return "hand";
    case SegmentClass::thigh:
      return "thigh";
    case SegmentClass::shank:
      return "shank";
    case SegmentClass::foot:
      return "foot";
    case SegmentClass::toes:
      return "toes";
  }
  return "none";
}

std::optional<SegmentClass> parse_segment_class(const std::string& s) {
  if (s == "none") return SegmentClass::none;
  for (SegmentClass c : kMassiveClasses)
    if (s == segment_class_name(c)) return c;
  return std::nullopt;
}

const char* side_name(Side s) {
  switch (s) {
    case Side::center:
      return "center";
    case Side::left:
      return "left";
    case Side::right:
      return "right";
  }
  return "center";
}

}  // namespace mocap
