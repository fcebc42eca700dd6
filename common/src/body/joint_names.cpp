// Joint-name aliases: the alias table and the tokenizer that reads a joint
// name as a body part, and the canonical name of each body part.
#include "body/joint_names.hpp"

#include <cctype>
#include <cstddef>
#include <initializer_list>
#include <vector>

#include "mocap/common/body/joint_classes.hpp"

namespace mocap {

namespace detail {

namespace {

bool is_lower(char c) {
  return c >= 'a' && c <= 'z';
}
bool is_upper(char c) {
  return c >= 'A' && c <= 'Z';
}
bool is_digit(char c) {
  return c >= '0' && c <= '9';
}
bool is_alnum(char c) {
  return is_lower(c) || is_upper(c) || is_digit(c);
}

std::vector<std::string> name_tokens(const std::string& raw) {
  std::string s = raw;
  const std::size_t ns = s.find_last_of(":|");
  if (ns != std::string::npos) s = s.substr(ns + 1);
  std::vector<std::string> out;
  std::string cur;
  auto flush = [&] {
    if (!cur.empty()) out.push_back(cur);
    cur.clear();
  };
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (!is_alnum(c)) {
      flush();
      continue;
    }
    if (is_upper(c) && !cur.empty()) {
      const char prev = s[i - 1];
      const bool next_lower = i + 1 < s.size() && is_lower(s[i + 1]);
      if (is_lower(prev) || is_digit(prev) || (is_upper(prev) && next_lower)) flush();
    }
    cur.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  flush();
  return out;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool contains(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

bool in(const std::string& s, std::initializer_list<const char*> words) {
  for (const char* w : words)
    if (s == w) return true;
  return false;
}

/// Kind of a side-less base word (lower case, no digits at the end).
Kind base_kind(const std::string& b, Side side, SegmentClass& trunk_hint) {
  if (b.empty()) return Kind::unknown;
  if (ends_with(b, "end") || ends_with(b, "nub") || ends_with(b, "site") || ends_with(b, "tip"))
    return Kind::end_marker;
  if (in(b, {"root", "jointroot", "rootjoint", "reference", "armature", "world", "scene", "origin",
             "master", "trajectory", "skeleton"}))
    return Kind::dummy;
  if (in(b, {"hips", "pelvis"}) || (b == "hip" && side == Side::center)) return Kind::pelvis;
  if (b == "hipjoint") return Kind::hip_joint;
  if (in(b, {"spine", "lowerback", "abdomen", "waist", "torso", "back", "lowerspine", "spinelower",
             "midspine", "spinemid", "spinemiddle", "middlespine", "belly"})) {
    trunk_hint = SegmentClass::middle_trunk;
    return Kind::trunk;
  }
  if (in(b, {"chest", "upperchest", "chestupper", "thorax", "upperback", "upperspine", "spineupper",
             "ribcage"})) {
    trunk_hint = SegmentClass::upper_trunk;
    return Kind::trunk;
  }
  if (in(b, {"neck", "lowerneck", "upperneck", "necklower", "neckupper"})) return Kind::neck;
  if (b == "head") return Kind::head;
  if (in(b, {"collar", "clavicle", "collarbone", "scapula", "shoulderblade"}))
    return Kind::clavicle;
  if (b == "shoulder") return Kind::shoulder;
  // Fingers before hands and arms ("handindex", "handthumb", "fingerbase").
  for (const char* f :
       {"finger", "thumb", "index", "middle", "ring", "pinky", "pinkie", "little", "carpal"})
    if (contains(b, f)) return Kind::finger;
  if (in(b, {"arm", "upperarm", "armupper", "humerus", "uparm"})) return Kind::upper_arm;
  if (in(b, {"forearm", "lowerarm", "armlower", "elbow", "radius", "ulna"})) return Kind::forearm;
  if (in(b, {"hand", "wrist", "palm"})) return Kind::hand;
  if (in(b, {"upleg", "upperleg", "legupper", "thigh", "femur", "hip"})) return Kind::thigh;
  if (in(b, {"leg", "lowerleg", "leglower", "calf", "shin", "knee", "tibia", "shank"}))
    return Kind::shank;
  if (in(b, {"foot", "ankle"})) return Kind::foot;
  if (in(b, {"toe", "toes", "toebase", "ball", "forefoot"})) return Kind::toes;
  return Kind::unknown;
}

/// Words that CMU's ASF-style names glue to a one-letter side ("lhand", "rfemur").
bool glued_limb_word(const std::string& b) {
  return in(b, {"hand",     "femur",   "tibia",    "foot",    "toes",  "toe",      "humerus",
                "radius",   "wrist",   "clavicle", "fingers", "thumb", "hipjoint", "collar",
                "shoulder", "elbow",   "knee",     "ankle",   "hip",   "upleg",    "leg",
                "arm",      "forearm", "thigh",    "calf",    "shin"});
}

std::string strip_digits(std::string s) {
  while (!s.empty() && is_digit(s.back())) s.pop_back();
  return s;
}

}  // namespace

NameInfo parse_name(const std::string& raw) {
  NameInfo info;
  std::vector<std::string> toks = name_tokens(raw);
  // Exporter prefixes that carry no meaning.
  std::erase_if(toks, [](const std::string& t) {
    return t == "mixamorig" || t == "def" || t == "org" || t == "mch" ||
           (t.rfind("bip", 0) == 0 && strip_digits(t) == "bip");
  });
  for (std::size_t i = 0; i < toks.size(); ++i) {
    const std::string& t = toks[i];
    Side s = Side::center;
    if (t == "left" || t == "l") s = Side::left;
    if (t == "right" || t == "r") s = Side::right;
    if (s != Side::center && toks.size() > 1 && info.side == Side::center) {
      info.side = s;
      toks.erase(toks.begin() + static_cast<std::ptrdiff_t>(i));
      break;
    }
  }
  std::string base;
  for (const std::string& t : toks) base += t;
  base = strip_digits(base);
  if (info.side == Side::center && base.size() > 1 && (base[0] == 'l' || base[0] == 'r')) {
    SegmentClass hint = SegmentClass::middle_trunk;
    if (base_kind(base, Side::center, hint) == Kind::unknown && glued_limb_word(base.substr(1))) {
      info.side = base[0] == 'l' ? Side::left : Side::right;
      base = base.substr(1);
    }
  }
  info.kind = base_kind(base, info.side, info.trunk_hint);
  return info;
}

/// The body part a name means (for queries and character files).
std::pair<SegmentClass, Side> name_part(const NameInfo& n) {
  switch (n.kind) {
    case Kind::pelvis:
      return {SegmentClass::lower_trunk, Side::center};
    case Kind::trunk:
      return {n.trunk_hint, Side::center};
    case Kind::neck:
      return {SegmentClass::neck, Side::center};
    case Kind::head:
      return {SegmentClass::head, Side::center};
    case Kind::clavicle:
    case Kind::shoulder:
      return {SegmentClass::clavicle, n.side};
    case Kind::upper_arm:
      return {SegmentClass::upper_arm, n.side};
    case Kind::forearm:
      return {SegmentClass::forearm, n.side};
    case Kind::hand:
      return {SegmentClass::hand, n.side};
    case Kind::thigh:
      return {SegmentClass::thigh, n.side};
    case Kind::shank:
      return {SegmentClass::shank, n.side};
    case Kind::foot:
      return {SegmentClass::foot, n.side};
    case Kind::toes:
      return {SegmentClass::toes, n.side};
    default:
      return {SegmentClass::none, Side::center};
  }
}

}  // namespace detail

std::string canonical_joint_name(SegmentClass c, Side s) {
  const char* base = nullptr;
  switch (c) {
    case SegmentClass::none:
      return {};
    case SegmentClass::head:
      return "Head";
    case SegmentClass::neck:
      return "Neck";
    case SegmentClass::upper_trunk:
      return "Chest";
    case SegmentClass::middle_trunk:
      return "Spine";
    case SegmentClass::lower_trunk:
      return "Hips";
    case SegmentClass::clavicle:
      base = "Shoulder";
      break;
    case SegmentClass::upper_arm:
      base = "UpperArm";
      break;
    case SegmentClass::forearm:
      base = "ForeArm";
      break;
    case SegmentClass::hand:
      base = "Hand";
      break;
    case SegmentClass::thigh:
      base = "UpLeg";
      break;
    case SegmentClass::shank:
      base = "Leg";
      break;
    case SegmentClass::foot:
      base = "Foot";
      break;
    case SegmentClass::toes:
      base = "Toe";
      break;
  }
  if (s == Side::center) return {};
  return std::string(s == Side::left ? "Left" : "Right") + base;
}

}  // namespace mocap
