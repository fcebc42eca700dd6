#pragma once
// Retargeting a pose from one rig onto another (docs/queries.md "Across
// rigs").
//
// A local rotation means nothing outside its rig: rigs differ in their rest
// poses (identity rotations along the BVH OFFSETs), so a standing Bandai
// Namco Spine has the local rotation (-120°, 86°, 123°) ZXY and a standing
// CMU one nearly identity. A pose is carried across rigs by what it looks
// like instead: every segment class both rigs have (segment_class.hpp,
// joint_classes.hpp) points the same way in the world, and so in the body
// frame, whose heading and ground position are kept.
//
// Definitions (each rig on its own, at rest: every local rotation identity,
// the OFFSETs times the skeleton's translation scales):
//  - A class's *representative* is its first joint (lowest index) of that
//    class and side.
//  - Its *aim* is the first class of its chain, after it, that both rigs
//    have with the representative of the aim at a rest distance of at least
//    1 cm below its own in both rigs: lower trunk -> middle trunk -> upper
//    trunk -> neck -> head; clavicle -> upper arm -> forearm -> hand; thigh
//    -> shank -> foot -> toes (same side). Head, hands and toes aim nowhere.
//  - Its *rest axis* a is the unit rest vector from the representative to
//    its aim's, in the representative's frame. The *direction* of the class
//    in a pose is R a, R the representative's world rotation: the direction
//    from the joint to its counterpart child (CMU's pelvis, whose spine
//    child lies at its own origin, aims at the chest through it).
//  - Trunk classes also have a *side axis* b: the rest vector from the right
//    to the left thigh (lower trunk; else shank) or clavicle (middle and
//    upper trunk; else upper arm), made orthogonal to a. R b fixes the twist
//    of the pelvis and chest.
// A class with an aim in both rigs is *directed*.
//
// Posing the target: every target joint gets the world rotation
// R_t = R_s(source joint) * M, with M a constant of the pair of rigs:
//  - directed trunk class: M = F_s F_t^T, F = [a, b, a x b] (columns): the
//    target's rest axes onto the source's, so R_t a_t = R_s a_s and
//    R_t b_t = R_s b_s exactly;
//  - other directed class: M = S M_p, M_p the M of the nearest target
//    ancestor that follows a source joint (identity if none) and S the least
//    rotation taking M_p a_t to a_s: the direction exactly, the twist about
//    it carried from the parent;
//  - a joint that follows a source joint but is not a directed
//    representative (a class both rigs have that aims nowhere: head, hands,
//    toes; a second joint of a class with the same name and class in both;
//    a class-none joint with the same name in both, such as fingers): M =
//    M_p, so its rotation relative to its parent is the source's, seen
//    through the parent's M;
//  - a joint with no counterpart keeps a neutral pose: identity local
//    rotation (its parent's orientation, the rig's rest shape).
// With the target rig's *typical pose* (typical_local_rotations: the mean
// local rotation of each joint over an index's frames of that skeleton),
// two choices use it instead, because rigs also disagree on how a bone's
// frame is turned about the bone (Bandai Namco's left thigh points up at
// rest, its right one down): every joint that is not a directed
// representative takes its typical local rotation (the neutral pose), and a
// directed class without a side axis (limbs, neck) keeps its direction but
// is turned about it to the twist nearest its typical local rotation.
// Joint translations are the target's own (OFFSET times translation scale),
// except the pelvis: its ground position (x, z) is the source pelvis's, and
// its height is set so that the lowest foot point (ankle or toe joint) lies at
// the source's lowest foot point height times the leg-length ratio (target
// over source: thigh + shank rest lengths, mean of the sides; 1 without
// legs). Scaling the pelvis height itself would leave the feet a few
// centimetres above or below the ground on rigs whose pelvis-to-hip geometry
// differs, and every segment would pay m g dy for it.
//
// Compared segments: a cross-rig comparison sums h over the target segments
// whose pose the shared classes decide: the joints of every directed class,
// and point masses (no child, no End Site: Bandai Namco's head, hands and
// toes) hanging from a compared joint, whose state is just their origin.
// The others' segments are not compared.
//
// Units: metres, unit quaternions (world from joint), Y up. Never throws for a
// pose; make_retarget_map throws InputError when a rig has no pelvis.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/body/segment_class.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/index.hpp"

namespace mocap {

/// True when local rotations mean the same pose on both skeletons, so that a
/// frame of one is posed on the other by copying them (no retargeting): the
/// same joint names and parents, and every joint below the pelvis (the lower
/// trunk of classify_joints; every non-root joint without one) with its
/// OFFSET pointing the same way within 5 degrees (or zero in both). Lengths
/// may differ (two actors of one rig); the offsets of the pelvis and of the
/// joints above it are placements, not rest shape, and are not compared.
bool same_rig(const Skeleton& a, const Skeleton& b);

/// What carries poses from a source rig onto a target rig (the header's
/// definitions); built once per pair of skeletons.
struct RetargetMap {
  std::size_t source_joint_count = 0, target_joint_count = 0;
  /// Per target joint: the source joint whose world rotation it follows, -1
  /// for a neutral joint.
  std::vector<int> source_joint;
  /// Per target joint: M of R_t = R_s(source_joint) * M (identity where
  /// source_joint is -1).
  std::vector<Eigen::Quaterniond> correction;
  /// Per target joint: 1 for the representative of a directed class, with
  /// its unit rest axes: target_axis in its own frame, source_axis in its
  /// source joint's frame (zero vectors elsewhere).
  std::vector<std::uint8_t> directed;
  std::vector<Eigen::Vector3d> target_axis, source_axis;
  /// Per target joint: 1 where its segment is compared across the rigs.
  std::vector<std::uint8_t> compared;
  /// The compared classes, in segment_class.hpp's order (left before right).
  std::vector<std::pair<SegmentClass, Side>> compared_classes;
  /// The pelvis (lower trunk representative) of each rig.
  int source_pelvis = -1, target_pelvis = -1;
  /// Target over source leg length (thigh + shank, mean of the sides), 1
  /// when either rig lacks legs.
  double leg_length_ratio = 1.0;
  /// Foot points (foot and toes representatives) both rigs have: (source,
  /// target) joints.
  std::vector<std::pair<int, int>> foot_points;
  /// Per target joint: 1 for a directed class with a side axis (trunk).
  std::vector<std::uint8_t> has_side_axis;
  /// The target's typical local rotations (one per joint), or empty.
  std::vector<Eigen::Quaterniond> typical_local;
};

/// The map from `source` onto `target` (each as read, its translation
/// scales applied), with the target's typical pose when given (one local
/// rotation per target joint; empty: none). Throws InputError("<retarget>",
/// 0, ...) when either skeleton has no recognised pelvis (no lower trunk);
/// std::invalid_argument for a typical pose of another size.
RetargetMap make_retarget_map(const Skeleton& source, const Skeleton& target,
                              std::vector<Eigen::Quaterniond> typical_local = {});

/// A typical pose: per joint, the average of its local rotations over frames
/// (the unit quaternion q maximising sum_f (q . q_f)^2, the top eigenvector
/// of sum_f q_f q_f^T: insensitive to the sign of each q_f; w >= 0).
/// `locals`: frame-major [f * joints + j]; identity for a joint without
/// frames.
std::vector<Eigen::Quaterniond> typical_local_rotations(std::span<const Eigen::Quaterniond> locals,
                                                        std::size_t joints);
/// The same over every frame of index skeleton `skeleton` (its
/// local_rotations, streamed: nothing kept). Throws what reading the index
/// throws.
std::vector<Eigen::Quaterniond> typical_local_rotations(const Index& index, std::uint32_t skeleton);

/// Poses `target` like the source pose `source_world` (world pose of the
/// source skeleton, forward_kinematics): `local` gets the target's local
/// pose (translations and rotations, resized), `world` its forward
/// kinematics. `map` = make_retarget_map(source, target).
void retarget_pose(const RetargetMap& map, const Skeleton& target, const WorldPose& source_world,
                   LocalPose& local, WorldPose& world);

/// retarget_pose of frame `frame` of `source` (its local poses, as
/// clip_locals_from_raw gives them; the source skeleton is source.skeleton).
void retarget_clip_frame(const RetargetMap& map, const ClipMotion& source, std::size_t frame,
                         const Skeleton& target, LocalPose& local, WorldPose& world);

/// "lower_trunk", "left thigh", ...: the names compared classes are reported
/// by (segment_class_name, prefixed with the side for sided classes).
std::string class_key_name(SegmentClass c, Side s);

}  // namespace mocap
