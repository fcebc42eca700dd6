#include "mocap/body.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "mocap/error.hpp"

namespace mocap {

namespace {

/// Bones shorter than this are "zero-length" (metres).
constexpr double kZeroLength_m = 1e-6;

constexpr std::array<SegmentClass, 13> kMassiveClasses = {
    SegmentClass::head,      SegmentClass::neck,    SegmentClass::upper_trunk,
    SegmentClass::middle_trunk, SegmentClass::lower_trunk, SegmentClass::clavicle,
    SegmentClass::upper_arm, SegmentClass::forearm, SegmentClass::hand,
    SegmentClass::thigh,     SegmentClass::shank,   SegmentClass::foot,
    SegmentClass::toes};

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

// ---------------------------------------------------------------------------
// Anthropometric table: de Leva (1996), Table 4, adjusted Zatsiorsky-Seluyanov
// values (docs/body-model.md reproduces them). Percentages of total mass and
// of segment length. `com` is measured from de Leva's origin point, which is
// the proximal joint for the limbs and the CRANIAL end for the head (vertex)
// and the trunk parts (suprasternale, xiphoid, omphalion); `com_from_top`
// marks the latter, whose bones in a capture skeleton point upwards.
struct DeLevaRow {
  double mass_pct;
  double com_pct;
  bool com_from_top;
  double r_sag_pct;    // about the antero-posterior (sagittal) axis
  double r_trans_pct;  // about the medio-lateral (transverse) axis
  double r_long_pct;   // about the long axis
};

struct DeLevaTable {
  DeLevaRow head, upper_trunk, middle_trunk, lower_trunk, upper_arm, forearm, hand, thigh,
      shank, foot;
};

constexpr DeLevaTable kDeLevaMale{
    {6.94, 59.76, true, 36.2, 37.6, 31.2},   // head (vertex - mid-gonion)
    {15.96, 29.99, true, 71.6, 45.4, 65.9},  // upper trunk (suprasternale - xiphoid)
    {16.33, 45.02, true, 48.2, 38.3, 46.8},  // middle trunk (xiphoid - omphalion)
    {11.17, 61.15, true, 61.5, 55.1, 58.7},  // lower trunk (omphalion - mid-hip)
    {2.71, 57.72, false, 28.5, 26.9, 15.8},  // upper arm
    {1.62, 45.74, false, 27.6, 26.5, 12.1},  // forearm
    {0.61, 79.00, false, 62.8, 51.3, 40.1},  // hand (wrist - 3rd metacarpale)
    {14.16, 40.95, false, 32.9, 32.9, 14.9}, // thigh
    {4.33, 44.59, false, 25.5, 24.9, 10.3},  // shank
    {1.37, 44.15, false, 25.7, 24.5, 12.4},  // foot (heel - toe tip)
};

constexpr DeLevaTable kDeLevaFemale{
    {6.68, 58.94, true, 33.0, 35.9, 31.8},
    {15.45, 20.77, true, 74.6, 50.2, 71.8},
    {14.65, 45.12, true, 43.3, 35.4, 41.5},
    {12.47, 49.20, true, 43.3, 40.2, 44.4},
    {2.55, 57.54, false, 27.8, 26.0, 14.8},
    {1.38, 45.59, false, 26.1, 25.7, 9.4},
    {0.56, 74.74, false, 53.1, 45.4, 33.5},
    {14.78, 36.12, false, 36.9, 36.4, 16.2},
    {4.81, 44.16, false, 27.1, 26.7, 9.3},
    {1.29, 40.14, false, 29.9, 27.9, 13.9},
};

// Shares of de Leva segments given to joints de Leva does not have (our
// modelling choice, docs/body-model.md): the neck takes a sixth of de Leva's
// head (which includes the neck), each clavicle a tenth of the upper trunk, each
// toes joint 15% of its foot. A share the skeleton cannot carry goes back.
constexpr double kNeckShareOfHead = 1.0 / 6.0;
constexpr double kClavicleShareOfUpperTrunk = 0.10;
constexpr double kToesShareOfFoot = 0.15;

// Radii of a uniform thin rod (fractions of length): transverse sqrt(1/12).
constexpr double kRodTransverse = 0.28867513459481287;

/// Per-class parameters in our joint convention: mass as a fraction of the
/// total mass (table normalised to sum to 1), COM as a fraction of the bone
/// from the joint origin, radii as fractions of the bone length.
struct ClassParams {
  double mass_fraction = 0.0;
  double com_fraction = 0.5;
  double r_sag = kRodTransverse;
  double r_trans = kRodTransverse;
  double r_long = 0.0;
};

ClassParams from_row(const DeLevaRow& r, double mass_fraction) {
  ClassParams p;
  p.mass_fraction = mass_fraction;
  p.com_fraction = r.com_from_top ? 1.0 - r.com_pct / 100.0 : r.com_pct / 100.0;
  p.r_sag = r.r_sag_pct / 100.0;
  p.r_trans = r.r_trans_pct / 100.0;
  p.r_long = r.r_long_pct / 100.0;
  return p;
}

/// Parameters of one class (per side for sided classes), sex-specific.
ClassParams class_params(SegmentClass c, Sex sex) {
  const DeLevaTable& t = sex == Sex::male ? kDeLevaMale : kDeLevaFemale;
  const double sum = t.head.mass_pct + t.upper_trunk.mass_pct + t.middle_trunk.mass_pct +
                     t.lower_trunk.mass_pct +
                     2.0 * (t.upper_arm.mass_pct + t.forearm.mass_pct + t.hand.mass_pct +
                            t.thigh.mass_pct + t.shank.mass_pct + t.foot.mass_pct);
  auto frac = [sum](double pct) { return pct / sum; };
  switch (c) {
    case SegmentClass::head:
      return from_row(t.head, frac(t.head.mass_pct) * (1.0 - kNeckShareOfHead));
    case SegmentClass::neck: {
      ClassParams p = from_row(t.head, frac(t.head.mass_pct) * kNeckShareOfHead);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::upper_trunk:
      return from_row(t.upper_trunk,
                      frac(t.upper_trunk.mass_pct) * (1.0 - 2.0 * kClavicleShareOfUpperTrunk));
    case SegmentClass::middle_trunk:
      return from_row(t.middle_trunk, frac(t.middle_trunk.mass_pct));
    case SegmentClass::lower_trunk:
      return from_row(t.lower_trunk, frac(t.lower_trunk.mass_pct));
    case SegmentClass::clavicle: {
      ClassParams p =
          from_row(t.upper_arm, frac(t.upper_trunk.mass_pct) * kClavicleShareOfUpperTrunk);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::upper_arm:
      return from_row(t.upper_arm, frac(t.upper_arm.mass_pct));
    case SegmentClass::forearm:
      return from_row(t.forearm, frac(t.forearm.mass_pct));
    case SegmentClass::hand:
      return from_row(t.hand, frac(t.hand.mass_pct));
    case SegmentClass::thigh:
      return from_row(t.thigh, frac(t.thigh.mass_pct));
    case SegmentClass::shank:
      return from_row(t.shank, frac(t.shank.mass_pct));
    case SegmentClass::foot:
      return from_row(t.foot, frac(t.foot.mass_pct) * (1.0 - kToesShareOfFoot));
    case SegmentClass::toes: {
      ClassParams p = from_row(t.foot, frac(t.foot.mass_pct) * kToesShareOfFoot);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::none:
      break;
  }
  return ClassParams{};  // uniform rod, no mass
}

/// Where a class's mass goes when the skeleton has no joint of that class
/// (same side for sided relatives), in order of preference.
std::vector<SegmentClass> relatives(SegmentClass c) {
  using S = SegmentClass;
  switch (c) {
    case S::head: return {S::neck, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::neck: return {S::head, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::upper_trunk: return {S::middle_trunk, S::lower_trunk, S::neck, S::head};
    case S::middle_trunk: return {S::upper_trunk, S::lower_trunk};
    case S::lower_trunk: return {S::middle_trunk, S::upper_trunk};
    case S::clavicle: return {S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::upper_arm: return {S::clavicle, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::forearm: return {S::upper_arm, S::clavicle, S::upper_trunk, S::middle_trunk};
    case S::hand: return {S::forearm, S::upper_arm, S::clavicle, S::upper_trunk};
    case S::thigh: return {S::lower_trunk, S::middle_trunk, S::upper_trunk};
    case S::shank: return {S::thigh, S::lower_trunk, S::middle_trunk};
    case S::foot: return {S::shank, S::thigh, S::lower_trunk};
    case S::toes: return {S::foot, S::shank, S::thigh, S::lower_trunk};
    case S::none: break;
  }
  return {};
}

// ---------------------------------------------------------------------------
// Joint names. A name is split into lower-case tokens (namespace "a:b" and
// "a|b" prefixes dropped, separators and camelCase boundaries split), a side
// token (left/l/right/r) is taken out, and the rest, joined and without
// trailing digits, is looked up in the alias table.

enum class Kind {
  unknown,
  dummy,      // joint_Root, Reference, ...
  end_marker, // HeadTop_End, LeftToe_End, ...
  pelvis,
  trunk,      // spine / chest parts; `trunk_hint` says which one a query means
  neck,
  head,
  clavicle,
  shoulder,   // clavicle or upper arm: decided by the chain
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
  Side side = Side::center;
  SegmentClass trunk_hint = SegmentClass::middle_trunk;
};

bool is_lower(char c) { return c >= 'a' && c <= 'z'; }
bool is_upper(char c) { return c >= 'A' && c <= 'Z'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_alnum(char c) { return is_lower(c) || is_upper(c) || is_digit(c); }

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
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool contains(const std::string& s, const char* part) { return s.find(part) != std::string::npos; }

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
  if (in(b, {"root", "jointroot", "rootjoint", "reference", "armature", "world", "scene",
             "origin", "master", "trajectory", "skeleton"}))
    return Kind::dummy;
  if (in(b, {"hips", "pelvis"}) || (b == "hip" && side == Side::center)) return Kind::pelvis;
  if (b == "hipjoint") return Kind::hip_joint;
  if (in(b, {"spine", "lowerback", "abdomen", "waist", "torso", "back", "lowerspine",
             "spinelower", "midspine", "spinemid", "spinemiddle", "middlespine", "belly"})) {
    trunk_hint = SegmentClass::middle_trunk;
    return Kind::trunk;
  }
  if (in(b, {"chest", "upperchest", "chestupper", "thorax", "upperback", "upperspine",
             "spineupper", "ribcage"})) {
    trunk_hint = SegmentClass::upper_trunk;
    return Kind::trunk;
  }
  if (in(b, {"neck", "lowerneck", "upperneck", "necklower", "neckupper"})) return Kind::neck;
  if (b == "head") return Kind::head;
  if (in(b, {"collar", "clavicle", "collarbone", "scapula", "shoulderblade"}))
    return Kind::clavicle;
  if (b == "shoulder") return Kind::shoulder;
  // Fingers before hands and arms ("handindex", "handthumb", "fingerbase").
  for (const char* f : {"finger", "thumb", "index", "middle", "ring", "pinky", "pinkie",
                        "little", "carpal"})
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
  return in(b, {"hand", "femur", "tibia", "foot", "toes", "toe", "humerus", "radius", "wrist",
                "clavicle", "fingers", "thumb", "hipjoint", "collar", "shoulder", "elbow",
                "knee", "ankle", "hip", "upleg", "leg", "arm", "forearm", "thigh", "calf",
                "shin"});
}

std::string strip_digits(std::string s) {
  while (!s.empty() && is_digit(s.back())) s.pop_back();
  return s;
}

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
    case Kind::pelvis: return {SegmentClass::lower_trunk, Side::center};
    case Kind::trunk: return {n.trunk_hint, Side::center};
    case Kind::neck: return {SegmentClass::neck, Side::center};
    case Kind::head: return {SegmentClass::head, Side::center};
    case Kind::clavicle:
    case Kind::shoulder: return {SegmentClass::clavicle, n.side};
    case Kind::upper_arm: return {SegmentClass::upper_arm, n.side};
    case Kind::forearm: return {SegmentClass::forearm, n.side};
    case Kind::hand: return {SegmentClass::hand, n.side};
    case Kind::thigh: return {SegmentClass::thigh, n.side};
    case Kind::shank: return {SegmentClass::shank, n.side};
    case Kind::foot: return {SegmentClass::foot, n.side};
    case Kind::toes: return {SegmentClass::toes, n.side};
    default: return {SegmentClass::none, Side::center};
  }
}

// ---------------------------------------------------------------------------
// Skeleton geometry.

struct Tree {
  const Skeleton& skel;
  std::vector<std::vector<int>> children;
  explicit Tree(const Skeleton& s) : skel(s), children(s.joint_count()) {
    for (std::size_t j = 0; j < s.joint_count(); ++j)
      if (s.parents[j] >= 0) children[static_cast<std::size_t>(s.parents[j])].push_back(static_cast<int>(j));
  }
  int parent(int j) const { return skel.parents[static_cast<std::size_t>(j)]; }
  const std::vector<int>& kids(int j) const { return children[static_cast<std::size_t>(j)]; }
  bool is_ancestor(int a, int j) const {  // a is j or above j
    for (; j >= 0; j = parent(j))
      if (j == a) return true;
    return false;
  }
  int lca(int a, int b) const {
    for (; a >= 0; a = parent(a))
      if (is_ancestor(a, b)) return a;
    return -1;
  }
  /// Translation from the parent (OFFSET times the character's scale).
  Eigen::Vector3d offset(int c) const {
    const auto i = static_cast<std::size_t>(c);
    const double s = skel.translation_scales.empty() ? 1.0 : skel.translation_scales[i];
    return skel.offsets_m[i] * s;
  }
  /// Bone tip of joint j in its frame: the End Site when j has no child, else
  /// the mean over children of their offsets, where a child at j's origin
  /// (zero offset, CMU's LHipJoint / lowerback / LeftCollar) is looked
  /// through: its own tip stands for it (rest frames are aligned, so its tip
  /// is also expressed in j's frame at rest).
  Eigen::Vector3d tip(int j) const {
    const auto& ks = kids(j);
    if (ks.empty()) {
      const auto i = static_cast<std::size_t>(j);
      return skel.has_end_site[i] ? skel.end_sites_m[i] : Eigen::Vector3d::Zero();
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int c : ks) {
      const Eigen::Vector3d o = offset(c);
      sum += o.norm() > kZeroLength_m ? o : tip(c);
    }
    return sum / static_cast<double>(ks.size());
  }
};

// ---------------------------------------------------------------------------
// Classification.

struct Classifier {
  const Tree& tree;
  std::vector<NameInfo> info;
  std::vector<std::pair<SegmentClass, Side>> out;

  explicit Classifier(const Tree& t) : tree(t) {
    const std::size_t n = t.skel.joint_count();
    info.reserve(n);
    for (const std::string& name : t.skel.names) info.push_back(parse_name(name));
    out.assign(n, {SegmentClass::none, Side::center});
  }
  int count() const { return static_cast<int>(info.size()); }
  const NameInfo& at(int j) const { return info[static_cast<std::size_t>(j)]; }
  void set(int j, SegmentClass c, Side s) { out[static_cast<std::size_t>(j)] = {c, s}; }

  int first_of(Kind k, Side s, int below = -1) const {
    for (int j = 0; j < count(); ++j)
      if (at(j).kind == k && at(j).side == s && (below < 0 || (j != below && tree.is_ancestor(below, j))))
        return j;
    return -1;
  }
  int first_center_ancestor(int j) const {
    for (j = tree.parent(j); j >= 0; j = tree.parent(j))
      if (at(j).side == Side::center) return j;
    return -1;
  }

  struct Limb {
    int girdle = -1, upper = -1, middle = -1, distal = -1, tip = -1;
    int top() const { return girdle >= 0 ? girdle : upper; }
  };

  /// A limb of side `s` from its middle joint (forearm / shank, found by name,
  /// or the parent of the distal joint): the parent of the middle joint is the
  /// upper segment whatever its name (CMU 3ds-max "LeftShoulder" above
  /// "LeftElbow" is the upper arm), a further joint of the same side above it
  /// is the girdle (clavicle; CMU's LHipJoint for legs), the distal joint is
  /// the first descendant of the middle joint named as one (or its only
  /// child), the tip the first child of the distal joint named as one.
  Limb find_limb(Side s, Kind middle_kind, Kind distal_kind, Kind tip_kind,
                 std::initializer_list<Kind> upper_kinds) const {
    Limb l;
    l.middle = first_of(middle_kind, s);
    if (l.middle < 0) {
      const int d = first_of(distal_kind, s);
      if (d >= 0 && tree.parent(d) >= 0 && at(tree.parent(d)).side == s) l.middle = tree.parent(d);
    }
    if (l.middle >= 0) {
      const int p = tree.parent(l.middle);
      if (p >= 0 && at(p).side == s) l.upper = p;
      if (l.upper >= 0) {
        const int g = tree.parent(l.upper);
        if (g >= 0 && at(g).side == s) l.girdle = g;
      }
      l.distal = first_of(distal_kind, s, l.middle);
      if (l.distal < 0 && tree.kids(l.middle).size() == 1) l.distal = tree.kids(l.middle)[0];
    } else {
      // No chain to read: the names alone.
      for (Kind k : upper_kinds)
        if (l.upper < 0) l.upper = first_of(k, s);
      l.distal = first_of(distal_kind, s);
    }
    if (l.distal >= 0 && tip_kind != Kind::unknown)
      for (int c : tree.kids(l.distal))
        if (l.tip < 0 && at(c).kind == tip_kind) l.tip = c;
    return l;
  }

  /// Joints on the tree path from `from` (exclusive) to `to` (inclusive),
  /// in order from `from`.
  std::vector<int> path(int from, int to) const {
    const int a = tree.lca(from, to);
    if (a < 0) return {};  // different trees
    std::vector<int> up, down;
    for (int j = tree.parent(from); a >= 0 && from != a && j >= 0; j = tree.parent(j)) {
      up.push_back(j);
      if (j == a) break;
    }
    for (int j = to; j >= 0 && j != a; j = tree.parent(j)) down.push_back(j);
    std::reverse(down.begin(), down.end());
    up.insert(up.end(), down.begin(), down.end());
    return up;
  }

  void run() {
    Limb arm[2], leg[2];
    const Side sides[2] = {Side::left, Side::right};
    for (int k = 0; k < 2; ++k) {
      arm[k] = find_limb(sides[k], Kind::forearm, Kind::hand, Kind::unknown,
                         {Kind::upper_arm, Kind::shoulder});
      leg[k] = find_limb(sides[k], Kind::shank, Kind::foot, Kind::toes, {Kind::thigh});
      // An arm found by names alone: a "shoulder" above an upper arm is the clavicle.
      if (arm[k].middle < 0 && arm[k].upper >= 0 && at(arm[k].upper).kind == Kind::shoulder)
        for (int c : tree.kids(arm[k].upper))
          if (at(c).kind == Kind::upper_arm) {
            arm[k].girdle = arm[k].upper;
            arm[k].upper = c;
          }
      if (arm[k].middle < 0 && arm[k].girdle < 0) arm[k].girdle = first_of(Kind::clavicle, sides[k]);
    }

    // Pelvis: where the legs meet.
    int pelvis = -1;
    const int thigh_l = leg[0].top(), thigh_r = leg[1].top();
    if (thigh_l >= 0 && thigh_r >= 0)
      pelvis = tree.lca(thigh_l, thigh_r);
    else if (thigh_l >= 0 || thigh_r >= 0)
      pelvis = first_center_ancestor(thigh_l >= 0 ? thigh_l : thigh_r);
    if (pelvis < 0) pelvis = first_of(Kind::pelvis, Side::center);

    // Shoulder branch: where the arms meet (else the neck's or head's parent).
    int branch = -1;
    const int arm_l = arm[0].top(), arm_r = arm[1].top();
    if (arm_l >= 0 && arm_r >= 0)
      branch = tree.lca(arm_l, arm_r);
    else if (arm_l >= 0 || arm_r >= 0)
      branch = first_center_ancestor(arm_l >= 0 ? arm_l : arm_r);
    if (branch < 0) {
      int n = first_of(Kind::neck, Side::center, pelvis);
      if (n < 0) n = first_of(Kind::head, Side::center, pelvis);
      if (n >= 0) branch = tree.parent(n);
    }

    // Trunk: the pelvis is the lower trunk; the joints from above it up to the
    // shoulder branch are the middle trunk, the branch itself the upper trunk.
    std::vector<int> spine;
    if (pelvis >= 0 && branch >= 0) {
      spine = path(pelvis, branch);
    } else if (pelvis >= 0) {
      for (int j = pelvis;;) {
        int next = -1;
        for (int c : tree.kids(j))
          if (next < 0 && at(c).kind == Kind::trunk) next = c;
        if (next < 0) break;
        spine.push_back(next);
        j = next;
      }
    } else if (branch >= 0) {
      for (int j = branch; j >= 0 && at(j).side == Side::center &&
                           (j == branch || at(j).kind == Kind::trunk);
           j = tree.parent(j))
        spine.push_back(j);
      std::reverse(spine.begin(), spine.end());
    }
    for (std::size_t i = 0; i < spine.size(); ++i)
      set(spine[i], i + 1 == spine.size() ? SegmentClass::upper_trunk : SegmentClass::middle_trunk,
          Side::center);
    if (pelvis >= 0) set(pelvis, SegmentClass::lower_trunk, Side::center);

    // Neck and head: the joints from the branch up to the first head.
    const int start = branch >= 0 ? branch : pelvis;
    const int head = first_of(Kind::head, Side::center, start);
    if (head >= 0) {
      set(head, SegmentClass::head, Side::center);
      if (start >= 0) {
        for (int j = tree.parent(head); j >= 0 && j != start; j = tree.parent(j))
          set(j, SegmentClass::neck, Side::center);
      } else {
        for (int j = tree.parent(head); j >= 0 && at(j).kind == Kind::neck; j = tree.parent(j))
          set(j, SegmentClass::neck, Side::center);
      }
    } else {
      for (int j = first_of(Kind::neck, Side::center, start); j >= 0;) {
        set(j, SegmentClass::neck, Side::center);
        int next = -1;
        for (int c : tree.kids(j))
          if (next < 0 && at(c).kind == Kind::neck) next = c;
        j = next;
      }
    }

    // Limbs last: they win over a trunk or neck reading of the same joint.
    for (int k = 0; k < 2; ++k) {
      const Side s = sides[k];
      if (arm[k].girdle >= 0) set(arm[k].girdle, SegmentClass::clavicle, s);
      if (arm[k].upper >= 0) set(arm[k].upper, SegmentClass::upper_arm, s);
      if (arm[k].middle >= 0) set(arm[k].middle, SegmentClass::forearm, s);
      if (arm[k].distal >= 0) set(arm[k].distal, SegmentClass::hand, s);
      if (leg[k].girdle >= 0) set(leg[k].girdle, SegmentClass::none, Side::center);
      if (leg[k].upper >= 0) set(leg[k].upper, SegmentClass::thigh, s);
      if (leg[k].middle >= 0) set(leg[k].middle, SegmentClass::shank, s);
      if (leg[k].distal >= 0) set(leg[k].distal, SegmentClass::foot, s);
      if (leg[k].tip >= 0) set(leg[k].tip, SegmentClass::toes, s);
    }
  }
};

std::vector<std::pair<SegmentClass, Side>> classify(const Tree& tree) {
  Classifier c(tree);
  c.run();
  return std::move(c.out);
}

int resolve_alias(const Skeleton& skel, const std::vector<std::pair<SegmentClass, Side>>& classes,
                  const std::string& name) {
  const NameInfo ni = parse_name(name);
  const auto [cls, side] = name_part(ni);
  const int exact = skel.find(name);
  const bool part = cls != SegmentClass::none && (!is_sided(cls) || side != Side::center);
  if (!part) return exact;
  if (exact >= 0) {
    const auto& have = classes[static_cast<std::size_t>(exact)];
    if ((have.first == cls && have.second == side) ||
        (ni.kind == Kind::trunk && is_trunk(have.first)))
      return exact;
  }
  for (std::size_t j = 0; j < classes.size(); ++j)
    if (classes[j].first == cls && classes[j].second == side) return static_cast<int>(j);
  return exact;
}

/// Inertia about the COM of a segment of mass m and bone `tip` (joint frame):
/// principal axes u (along the bone, radius r_long), t (medio-lateral guess,
/// r_trans) and a = u x t (antero-posterior, r_sag); I = R diag(m (r L)^2) R^T.
/// t is the joint frame's X axis made orthogonal to u, or its Z axis when the
/// bone lies within 45 degrees of X (the anatomical orientation is unknown).
Eigen::Matrix3d segment_inertia(double m, const Eigen::Vector3d& tip, const ClassParams& p) {
  const double len = tip.norm();
  if (len <= kZeroLength_m || m <= 0.0) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d u = tip / len;
  const Eigen::Vector3d ref =
      std::abs(u.x()) > std::sqrt(0.5) ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d t = (ref - ref.dot(u) * u).normalized();
  const Eigen::Vector3d a = u.cross(t);
  Eigen::Matrix3d r;
  r.col(0) = u;
  r.col(1) = t;
  r.col(2) = a;
  const Eigen::Vector3d d(m * std::pow(p.r_long * len, 2), m * std::pow(p.r_trans * len, 2),
                          m * std::pow(p.r_sag * len, 2));
  Eigen::Matrix3d inertia = r * d.asDiagonal() * r.transpose();
  return 0.5 * (inertia + inertia.transpose());
}

// ---------------------------------------------------------------------------
// Character JSON.

using nlohmann::json;

std::string dotted(const std::vector<std::string>& path) {
  std::string s;
  for (const std::string& p : path) {
    if (!s.empty()) s += '.';
    s += p;
  }
  return s;
}

std::string all_class_names() {
  std::string s;
  for (SegmentClass c : kMassiveClasses) {
    if (!s.empty()) s += ", ";
    s += segment_class_name(c);
  }
  return s;
}

struct JsonReader {
  const std::string& source;

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(source, 0, (field.empty() ? std::string() : field + ": ") + what);
  }
  const json& object(const json& v, const std::string& field) const {
    if (!v.is_object()) fail(field, "expected an object, got " + std::string(v.type_name()));
    return v;
  }
  double positive(const json& v, const std::string& field, const char* unit) const {
    if (!v.is_number())
      fail(field, std::string("expected a positive number (") + unit + "), got " + v.type_name());
    const double x = v.get<double>();
    if (!std::isfinite(x) || !(x > 0.0))
      fail(field, std::string("expected a positive finite number (") + unit + "), got " + v.dump());
    return x;
  }
  void unknown_key(const std::string& field, const std::string& expected) const {
    fail(field, "unknown key; expected " + expected);
  }
};

}  // namespace

// ---------------------------------------------------------------------------
// Public API.

const char* segment_class_name(SegmentClass c) {
  switch (c) {
    case SegmentClass::none: return "none";
    case SegmentClass::head: return "head";
    case SegmentClass::neck: return "neck";
    case SegmentClass::upper_trunk: return "upper_trunk";
    case SegmentClass::middle_trunk: return "middle_trunk";
    case SegmentClass::lower_trunk: return "lower_trunk";
    case SegmentClass::clavicle: return "clavicle";
    case SegmentClass::upper_arm: return "upper_arm";
    case SegmentClass::forearm: return "forearm";
    case SegmentClass::hand: return "hand";
    case SegmentClass::thigh: return "thigh";
    case SegmentClass::shank: return "shank";
    case SegmentClass::foot: return "foot";
    case SegmentClass::toes: return "toes";
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
    case Side::center: return "center";
    case Side::left: return "left";
    case Side::right: return "right";
  }
  return "center";
}

std::string canonical_joint_name(SegmentClass c, Side s) {
  const char* base = nullptr;
  switch (c) {
    case SegmentClass::none: return {};
    case SegmentClass::head: return "Head";
    case SegmentClass::neck: return "Neck";
    case SegmentClass::upper_trunk: return "Chest";
    case SegmentClass::middle_trunk: return "Spine";
    case SegmentClass::lower_trunk: return "Hips";
    case SegmentClass::clavicle: base = "Shoulder"; break;
    case SegmentClass::upper_arm: base = "UpperArm"; break;
    case SegmentClass::forearm: base = "ForeArm"; break;
    case SegmentClass::hand: base = "Hand"; break;
    case SegmentClass::thigh: base = "UpLeg"; break;
    case SegmentClass::shank: base = "Leg"; break;
    case SegmentClass::foot: base = "Foot"; break;
    case SegmentClass::toes: base = "Toe"; break;
  }
  if (s == Side::center) return {};
  return std::string(s == Side::left ? "Left" : "Right") + base;
}

std::vector<std::pair<SegmentClass, Side>> classify_joints(const Skeleton& skel) {
  return classify(Tree(skel));
}

int find_joint_by_alias(const Skeleton& skel, const std::string& name) {
  return resolve_alias(skel, classify_joints(skel), name);
}

Character parse_character_json(const std::string& text, const std::string& source) {
  const JsonReader r{source};
  // The callback tracks the key path so that a number overflow ("1e999") can
  // still be reported against its field.
  std::vector<std::string> path;
  json doc;
  try {
    doc = json::parse(text, [&path](int depth, json::parse_event_t ev, json& parsed) {
      if (ev == json::parse_event_t::key && depth > 0) {
        path.resize(static_cast<std::size_t>(depth));
        path.back() = parsed.get<std::string>();
      }
      return true;
    });
  } catch (const json::parse_error& e) {
    r.fail("", "invalid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const json::exception& e) {
    r.fail(dotted(path), std::string("invalid number: ") + e.what());
  }
  r.object(doc, "<document>");
  Character ch;
  for (const auto& [key, value] : doc.items()) {
    if (key == "version") {
      if (!value.is_number_integer() || value.get<long long>() != 1)
        r.fail(key, "unsupported version " + value.dump() + " (this program reads version 1)");
    } else if (key == "name") {
      if (!value.is_string() || value.get<std::string>().empty())
        r.fail(key, "expected a non-empty string, got " + value.dump());
      ch.name = value.get<std::string>();
    } else if (key == "total_mass_kg") {
      ch.total_mass_kg = r.positive(value, key, "kg");
    } else if (key == "sex") {
      const std::string s = value.is_string() ? value.get<std::string>() : std::string();
      if (s == "male")
        ch.sex = Sex::male;
      else if (s == "female")
        ch.sex = Sex::female;
      else
        r.fail(key, "expected \"male\" or \"female\", got " + value.dump());
    } else if (key == "segments") {
      r.object(value, key);
      for (const auto& [cname, entry] : value.items()) {
        const std::string field = "segments." + cname;
        const std::optional<SegmentClass> cls = parse_segment_class(cname);
        if (!cls || *cls == SegmentClass::none)
          r.fail(field, "unknown segment class; expected one of " + all_class_names());
        r.object(entry, field);
        if (entry.contains("mass_kg") && entry.contains("mass_scale"))
          r.fail(field, "give mass_kg or mass_scale, not both");
        for (const auto& [k, v] : entry.items()) {
          const std::string f = field + "." + k;
          if (k == "mass_kg")
            ch.class_mass_kg[*cls] = r.positive(v, f, "kg");
          else if (k == "mass_scale")
            ch.class_mass_scale[*cls] = r.positive(v, f, "factor");
          else if (k == "length_scale")
            ch.class_length_scale[*cls] = r.positive(v, f, "factor");
          else
            r.unknown_key(f, "mass_kg, mass_scale or length_scale");
        }
      }
    } else if (key == "joints") {
      r.object(value, key);
      for (const auto& [jname, entry] : value.items()) {
        const std::string field = "joints." + jname;
        if (jname.empty()) r.fail("joints", "empty joint name");
        r.object(entry, field);
        for (const auto& [k, v] : entry.items()) {
          const std::string f = field + "." + k;
          if (k == "mass_kg")
            ch.joint_mass_kg[jname] = r.positive(v, f, "kg");
          else if (k == "length_scale")
            ch.joint_length_scale[jname] = r.positive(v, f, "factor");
          else
            r.unknown_key(f, "mass_kg or length_scale");
        }
      }
    } else {
      r.unknown_key(key, "version, name, total_mass_kg, sex, segments or joints");
    }
  }
  return ch;
}

Character read_character_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot open character file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path.string(), 0, "cannot read character file");
  return parse_character_json(text.str(), path.string());
}

Skeleton apply_length_scales(const Skeleton& skel, const Character& ch) {
  Skeleton out = skel;
  const std::size_t n = skel.joint_count();
  if (ch.class_length_scale.empty() && ch.joint_length_scale.empty()) return out;
  const Tree tree(skel);
  const auto classes = classify(tree);
  std::vector<double> joint_scale(n, 0.0);  // 0 = not set
  for (const auto& [name, s] : ch.joint_length_scale) {
    const int j = resolve_alias(skel, classes, name);
    if (j >= 0) joint_scale[static_cast<std::size_t>(j)] = s;
  }
  // Scale of each joint's own bone; parents come first.
  std::vector<double> scale(n, 1.0);
  for (std::size_t j = 0; j < n; ++j) {
    const SegmentClass c = classes[j].first;
    const int p = skel.parents[j];
    if (joint_scale[j] > 0.0) {
      scale[j] = joint_scale[j];
    } else if (c != SegmentClass::none) {
      const auto it = ch.class_length_scale.find(c);
      if (it != ch.class_length_scale.end()) scale[j] = it->second;
    } else if (p >= 0 && tree.offset(static_cast<int>(j)).norm() <= kZeroLength_m) {
      scale[j] = scale[static_cast<std::size_t>(p)];  // part of the parent's segment
    }
  }
  if (out.translation_scales.size() != n) out.translation_scales.assign(n, 1.0);
  for (std::size_t j = 0; j < n; ++j) {
    out.end_sites_m[j] *= scale[j];
    for (int c : tree.kids(static_cast<int>(j)))
      out.translation_scales[static_cast<std::size_t>(c)] *= scale[j];
  }
  return out;
}

Body build_body(const Skeleton& skel, const Character& ch) {
  const std::size_t n = skel.joint_count();
  const Tree tree(skel);
  const auto classes = classify(tree);
  Body body;
  body.segments.resize(n);
  std::vector<ClassParams> params(n);
  for (std::size_t j = 0; j < n; ++j) {
    Segment& seg = body.segments[j];
    seg.joint = static_cast<int>(j);
    seg.cls = classes[j].first;
    seg.side = classes[j].second;
    seg.tip_local_m = tree.tip(static_cast<int>(j));
    seg.length_m = seg.tip_local_m.norm();
    if (seg.length_m <= kZeroLength_m) {
      seg.tip_local_m.setZero();
      seg.length_m = 0.0;
    }
    params[j] = class_params(seg.cls, ch.sex);
  }

  // Mass carried by each (class, side) present on the skeleton: its table
  // share of the total mass plus the shares of absent relatives.
  using Key = std::pair<SegmentClass, Side>;
  std::map<Key, std::vector<std::size_t>> groups;
  for (std::size_t j = 0; j < n; ++j)
    if (classes[j].first != SegmentClass::none) groups[classes[j]].push_back(j);
  std::map<Key, double> carried;
  for (const auto& [key, joints] : groups) carried[key] = 0.0;
  double orphan = 0.0;  // mass with no present relative
  for (SegmentClass c : kMassiveClasses) {
    const double m = class_params(c, ch.sex).mass_fraction * ch.total_mass_kg;
    for (Side s : is_sided(c) ? std::vector<Side>{Side::left, Side::right}
                              : std::vector<Side>{Side::center}) {
      Key target{c, s};
      if (!groups.count(target)) {
        target.first = SegmentClass::none;
        for (SegmentClass rel : relatives(c)) {
          const Key k{rel, is_sided(rel) ? s : Side::center};
          if (groups.count(k)) {
            target = k;
            break;
          }
        }
      }
      if (target.first == SegmentClass::none)
        orphan += m;
      else
        carried[target] += m;
    }
  }
  double carried_sum = 0.0;
  for (const auto& [key, m] : carried) carried_sum += m;
  if (carried_sum > 0.0)
    for (auto& [key, m] : carried) m += orphan * m / carried_sum;

  // Character overrides per class, then the share of each joint by bone length.
  for (auto& [key, m] : carried) {
    if (const auto it = ch.class_mass_kg.find(key.first); it != ch.class_mass_kg.end())
      m = it->second;
    else if (const auto is = ch.class_mass_scale.find(key.first); is != ch.class_mass_scale.end())
      m *= is->second;
    const std::vector<std::size_t>& joints = groups[key];
    double total_len = 0.0;
    for (std::size_t j : joints) total_len += body.segments[j].length_m;
    for (std::size_t j : joints)
      body.segments[j].mass_kg =
          total_len > 0.0 ? m * body.segments[j].length_m / total_len
                          : m / static_cast<double>(joints.size());
  }

  // No recognised joint at all: every bone gets a length-proportional share.
  if (groups.empty()) {
    double total_len = 0.0;
    for (const Segment& seg : body.segments) total_len += seg.length_m;
    if (total_len > 0.0)
      for (Segment& seg : body.segments)
        seg.mass_kg = ch.total_mass_kg * seg.length_m / total_len;
  }

  // Per-joint mass overrides win over everything.
  std::set<std::string> unmatched;
  for (const auto& [name, m] : ch.joint_mass_kg) {
    const int j = resolve_alias(skel, classes, name);
    if (j < 0)
      unmatched.insert(name);
    else
      body.segments[static_cast<std::size_t>(j)].mass_kg = m;
  }
  for (const auto& [name, s] : ch.joint_length_scale)
    if (resolve_alias(skel, classes, name) < 0) unmatched.insert(name);
  body.unmatched_joints.assign(unmatched.begin(), unmatched.end());

  for (std::size_t j = 0; j < n; ++j) {
    Segment& seg = body.segments[j];
    seg.com_local_m = params[j].com_fraction * seg.tip_local_m;
    seg.inertia_local_kgm2 = segment_inertia(seg.mass_kg, seg.tip_local_m, params[j]);
    body.total_mass_kg += seg.mass_kg;
  }
  return body;
}

}  // namespace mocap
