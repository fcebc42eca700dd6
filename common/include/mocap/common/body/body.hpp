#pragma once
// Body model: a character's segments (masses, centres of mass, inertias) on a
// skeleton.
//
// Each joint owns at most one segment: the bone from the joint to its child,
// to the mean of its children, or to its End Site (docs/body-model.md). The
// joint's class and side come from classify_joints (joint_classes.hpp).
// Masses, COM positions and radii of gyration come from de Leva (1996), male
// or female table, scaled by the total mass; a class spread over several
// joints (CMU's lowerback/Chest/Chest2) is shared by bone length; a class the
// skeleton lacks gives its mass to its nearest present relative (documented
// table). Unrecognised bones and zero-length joints (bones under 1e-6 m) get
// no mass. Never throws for a strange skeleton; only a bad character file
// (character.hpp) is an error.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "mocap/common/body/character.hpp"
#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/body/segment_class.hpp"
#include "mocap/common/body/skeleton.hpp"

namespace mocap {

/// A joint's segment (all in the joint's local frame, metres, kilograms).
/// A zero-length bone has a zero tip and length: a point mass at the joint
/// origin with zero inertia.
struct Segment {
  /// Index of the joint that owns it.
  int joint = -1;
  SegmentClass cls = SegmentClass::none;
  Side side = Side::center;
  double mass_kg = 0.0;
  /// Bone end in the joint frame (child / mean of children / End Site), metres.
  Eigen::Vector3d tip_local_m = Eigen::Vector3d::Zero();
  /// Centre of mass in the joint frame, metres.
  Eigen::Vector3d com_local_m = Eigen::Vector3d::Zero();
  /// Inertia tensor about the COM, joint frame, kg m^2 (symmetric, PSD).
  Eigen::Matrix3d inertia_local_kgm2 = Eigen::Matrix3d::Zero();
  /// |tip_local_m|, metres; 0 below 1e-6 m.
  double length_m = 0.0;
};

/// Body of a character on a skeleton: one Segment per joint (mass 0 for none,
/// except on a skeleton with no recognised joint at all, where every bone gets a
/// length-proportional share as a uniform rod: docs/body-model.md).
struct Body {
  double total_mass_kg = 0.0;     // sum of segment masses
  std::vector<Segment> segments;  // indexed by joint
  /// Names in the character's per-joint settings (joint_mass_kg,
  /// joint_length_scale) that find_joint_by_alias() cannot resolve on this
  /// skeleton; they are ignored. Sorted, unique.
  std::vector<std::string> unmatched_joints;
};

/// Applies the character's length scales to a copy of the skeleton: a joint
/// with scale s multiplies its children's translation_scales (so OFFSETs and
/// position channels alike) and its End Site by s. The scale of a joint is its
/// joint setting, else its class setting, else (a class-none joint at its
/// parent's origin, such as CMU's LHipJoint) its parent's, else 1. Names that
/// do not resolve are ignored here and reported by build_body.
Skeleton apply_length_scales(const Skeleton& skel, const Character& ch);

/// Builds the body on `skel` (already length-scaled if wanted). Character
/// settings apply in this order: class masses (mass_kg, else mass_scale on the
/// table mass), then per-joint masses, which win. Never throws.
Body build_body(const Skeleton& skel, const Character& ch);

}  // namespace mocap
