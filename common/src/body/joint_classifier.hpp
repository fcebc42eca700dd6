#pragma once
// The joint classifier (internal to the body model): names plus the tree give
// every joint its segment class and side, and a body-part name its joint.
#include <string>
#include <utility>
#include <vector>

#include "body/skeleton_tree.hpp"
#include "mocap/common/body/segment_class.hpp"
#include "mocap/common/body/skeleton.hpp"

namespace mocap::detail {

/// Class and side per joint, indexed by joint.
using JointClasses = std::vector<std::pair<SegmentClass, Side>>;

/// classify_joints (joint_classes.hpp) on a tree already built.
JointClasses classify(const SkeletonTree& tree);

/// find_joint_by_alias (joint_classes.hpp) with the classes already computed
/// (`classes` = classify of `skel`'s tree).
int resolve_alias(const Skeleton& skel, const JointClasses& classes, const std::string& name);

}  // namespace mocap::detail
