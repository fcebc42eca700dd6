#pragma once
// The skeleton as a tree with its bones (internal to the body model): children
// lists, ancestry, and each joint's bone tip, for the classifier and the body
// builder. Metres, joint frames at rest.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mocap/common/body/skeleton.hpp"

namespace mocap::detail {

/// Bones shorter than this are "zero-length" (metres).
constexpr double kZeroLength_m = 1e-6;

/// A view of `skel` (which must outlive it) with every joint's children.
/// Joint indices are ints, -1 meaning none (no parent, not found).
struct SkeletonTree {
  const Skeleton& skel;
  std::vector<std::vector<int>> children;
  explicit SkeletonTree(const Skeleton& s) : skel(s), children(s.joint_count()) {
    for (std::size_t j = 0; j < s.joint_count(); ++j)
      if (s.parents[j] >= 0)
        children[static_cast<std::size_t>(s.parents[j])].push_back(static_cast<int>(j));
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

}  // namespace mocap::detail
