#pragma once
// Character body model: segment classes, anthropometric masses and inertias.
//
// Each joint owns at most one segment: the bone from the joint to its child,
// to the mean of its children, or to its End Site (docs/body-model.md).
// Segment classes are recognised from joint names by aliases (CMU original
// and 3ds-max-friendly, Bandai Namco, Mixamo-style, common variants, left and
// right) with the limb chain used to disambiguate (e.g. CMU's 3ds-max
// "LeftShoulder" below "LeftCollar" is an upper arm). Masses, COM positions
// and radii of gyration come from de Leva (1996), male or female table,
// scaled by the total mass; a class spread over several joints (CMU's
// lowerback/Chest/Chest2) is shared by bone length; a class the skeleton
// lacks gives its mass to its nearest present relative (documented table).
// Unrecognised bones and zero-length joints get no mass. Never throws for a
// strange skeleton; only a bad character file is an error.
#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "mocap/skeleton.hpp"

namespace mocap {

enum class SegmentClass {
  none,          // no mass (dummy roots such as joint_Root, fingers, unrecognised)
  head,          // head (de Leva: head + neck when there is no neck joint)
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

/// "head", "upper_arm", ... (the names used in JSON and docs).
const char* segment_class_name(SegmentClass c);
std::optional<SegmentClass> parse_segment_class(const std::string& s);
const char* side_name(Side s);

enum class Sex { male, female };

/// A target character (what the query's body is). JSON schema: docs/character.md.
struct Character {
  std::string name = "default";
  double total_mass_kg = 70.0;
  Sex sex = Sex::male;
  /// Absolute mass override per class (kg, both sides each get this value).
  std::map<SegmentClass, double> class_mass_kg;
  /// Multiplier on the table mass per class (applied after total-mass scaling).
  std::map<SegmentClass, double> class_mass_scale;
  /// Absolute mass override per joint name (kg); wins over class settings.
  std::map<std::string, double> joint_mass_kg;
  /// Length scale per class / per joint name: scales the bones the segment
  /// owns (its children's offsets and its End Site). Joint wins over class.
  std::map<SegmentClass, double> class_length_scale;
  std::map<std::string, double> joint_length_scale;
};

/// Parses and validates a character JSON text; errors name `source` and the field.
Character parse_character_json(const std::string& text, const std::string& source);
Character read_character_file(const std::filesystem::path& path);

/// A joint's segment (all in the joint's local frame, metres, kilograms).
struct Segment {
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

/// Segment class and side of every joint of `skel` (by aliases + chain rules).
/// Names and topology only: a classified joint whose bone has zero length keeps
/// its class (build_body makes it a point mass at the joint origin).
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

/// Applies the character's length scales to a copy of the skeleton: a joint
/// with scale s multiplies its children's translation_scales (so OFFSETs and
/// position channels alike) and its End Site by s. The scale of a joint is its
/// joint setting, else its class setting, else (a class-none joint at its
/// parent's origin, such as CMU's LHipJoint) its parent's, else 1. Names that
/// do not resolve are ignored here and reported by build_body.
Skeleton apply_length_scales(const Skeleton& skel, const Character& ch);

/// Builds the body on `skel` (already length-scaled if wanted).
Body build_body(const Skeleton& skel, const Character& ch);

}  // namespace mocap
