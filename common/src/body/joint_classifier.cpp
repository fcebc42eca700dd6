// The joint classifier: limbs found from their middle joints, the pelvis where
// the legs meet, the shoulder branch where the arms meet, the trunk between
// them, neck and head above; then alias resolution on the classified joints.
#include "body/joint_classifier.hpp"

#include <algorithm>
#include <initializer_list>

#include "body/joint_names.hpp"
#include "mocap/common/body/joint_classes.hpp"

namespace mocap {

namespace detail {

namespace {

struct Classifier {
  const SkeletonTree& tree;
  std::vector<NameInfo> info;
  JointClasses out;

  explicit Classifier(const SkeletonTree& t) : tree(t) {
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
      if (at(j).kind == k && at(j).side == s &&
          (below < 0 || (j != below && tree.is_ancestor(below, j))))
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
      if (arm[k].middle < 0 && arm[k].girdle < 0)
        arm[k].girdle = first_of(Kind::clavicle, sides[k]);
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
      for (int j = branch;
           j >= 0 && at(j).side == Side::center && (j == branch || at(j).kind == Kind::trunk);
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

}  // namespace

JointClasses classify(const SkeletonTree& tree) {
  Classifier c(tree);
  c.run();
  return std::move(c.out);
}

int resolve_alias(const Skeleton& skel, const JointClasses& classes, const std::string& name) {
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

}  // namespace detail

std::vector<std::pair<SegmentClass, Side>> classify_joints(const Skeleton& skel) {
  return detail::classify(detail::SkeletonTree(skel));
}

int find_joint_by_alias(const Skeleton& skel, const std::string& name) {
  return detail::resolve_alias(skel, classify_joints(skel), name);
}

}  // namespace mocap
