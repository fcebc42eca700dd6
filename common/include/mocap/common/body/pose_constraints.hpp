#pragma once
// Body-frame constraints on a pose (docs/queries.md "Body-frame
// constraints"): a segment's direction, anatomical angles (trunk and hip
// flexion, elbow and knee flexion, shoulder elevation) and end-effector
// positions, all stated in the pose's body frame (ground_pose.hpp: origin
// under the root, +y up, +z forward, +x to the character's left), so that
// one constraint means one pose on every rig whatever its joints' local
// axes.
//
// A partial query frame with constraints is completed with a database frame
// F like any partial frame (energy.hpp complete_partial_query), its given
// local rotations found per F by solve_pose_constraints: F's pose changed
// as little as possible until every constraint holds (within its
// tolerance), each constraint moving only its own joints:
//  - direction: the segment of `joint` (from its origin to `end`'s) is
//    swung (shortest arc) to the target direction;
//  - sagittal flexion (trunk, hip): the segment `joint` -> `end` is turned
//    about the body's left-right axis until its forward lean from vertical
//    (trunk: from straight up; hip: from straight down) is the target;
//  - hinge flexion (elbow, knee): the segment `joint` -> `end` is turned in
//    the plane it makes with its parent segment (`middle` -> `joint`) until
//    the angle between them is the target (0 = straight);
//  - elevation (shoulder): the segment `joint` -> `end` is turned in its
//    vertical plane until its angle from straight down is the target;
//  - effector: the joint origin `end` is moved to the target position by
//    the two-bone chain `joint` (shoulder / hip) -> `middle` (elbow / knee)
//    -> `end`: the middle joint bends to the distance, then the chain aims.
// Each constraint drives its joints by a rigid turn of their subtrees, so
// joints further down keep their local rotations (a hand keeps its wrist
// angle while the arm moves). Constraints are applied parents first; a
// target out of reach (an effector past the chain's length) is approached
// as closely as the chain allows.
//
// Units: metres, radians; world Y up.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace mocap {

enum class PoseConstraintKind : std::uint8_t {
  local_rotation,  // a given local rotation (the query's "euler_deg" / "quat")
  direction,
  sagittal_flexion,  // trunk flexion (from up), hip flexion (from down)
  hinge_flexion,     // elbow, knee
  elevation,         // shoulder
  effector,
};

struct PoseConstraint {
  PoseConstraintKind kind = PoseConstraintKind::direction;
  /// The name residuals are reported under (as the query wrote it).
  std::string name;
  /// The first joint driven (its local rotation is replaced): direction,
  /// flexion, elevation: the segment's joint; hinge: the lower segment's
  /// joint (forearm, shank); effector: the chain's first joint (upper arm,
  /// thigh); local_rotation: the joint.
  int joint = -1;
  /// hinge: the upper segment's joint (upper arm, thigh); effector: the
  /// chain's middle joint (forearm, shank), also driven; -1 otherwise.
  int middle = -1;
  /// The joint whose origin ends the measured segment (direction, flexion,
  /// hinge, elevation: the segment's child on the chain; trunk flexion: the
  /// neck), or the effector joint; -1 for local_rotation.
  int end = -1;
  /// direction: unit vector, body frame; effector: position, body frame, m;
  /// hinge / elevation with a straight or vertical segment: the body-frame
  /// direction the segment bends towards (elbow: forward, knee: backward,
  /// shoulder: outward).
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d bend_hint = Eigen::Vector3d::UnitZ();
  /// Angle kinds: the target, radians. Hip flexion is measured from
  /// straight down (`from_down`), trunk flexion from straight up.
  double angle_rad = 0.0;
  bool from_down = false;
  /// local_rotation: the rotation.
  Eigen::Quaterniond local = Eigen::Quaterniond::Identity();
  /// Met within this: metres (effector) or radians (the others); >= 0.
  double tolerance = 0.0;
  /// Multiplier of the energy terms of the segments this constraint drives
  /// (docs/queries.md "Weights"); > 0.
  double weight = 1.0;
};

/// The joints the constraints drive (each once), in index order (parents
/// first). std::invalid_argument if two constraints drive one joint or a
/// constraint's joints are out of range.
std::vector<int> driven_joints(const std::vector<PoseConstraint>& constraints,
                               std::size_t joint_count);

/// Per-thread working arrays of solve_pose_constraints.
struct PoseConstraintScratch {
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  std::vector<std::uint8_t> moved;
  /// After solve_pose_constraints: per joint, 1 when the solution turned it
  /// (a constraint not met within its tolerance, or a given local rotation,
  /// moved it or an ancestor); 0 where the pose is F's.
  std::vector<std::uint8_t> turned;
  /// The driven joints with their constraints (null: an effector's middle
  /// joint), in index order: kept to spare an allocation per frame.
  std::vector<std::pair<int, const PoseConstraint*>> driven;
};

/// Solves the constraints on a pose: world joint origins `pos` and world
/// rotations `rot` of every joint (`parents` per joint, parents before
/// children, -1 for a root). The body frame is that of joint `root` (the
/// pelvis). Writes the local rotation of each driven joint
/// (driven_joints order) into `locals`. Constraints must be sorted by
/// `joint` (sort_constraints). Never throws; degenerate geometry (a zero
/// length segment) leaves that constraint's joints as they are.
void solve_pose_constraints(const std::vector<int>& parents, int root,
                            const std::vector<PoseConstraint>& constraints,
                            const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot,
                            PoseConstraintScratch& scratch, Eigen::Quaterniond* locals);

/// Orders constraints parents first (by `joint`, then `middle`).
void sort_constraints(std::vector<PoseConstraint>& constraints);

/// How far a pose is from meeting a constraint, measured on the pose as it
/// is: effector: distance of the effector from the target, metres;
/// direction: angle between the segment and the target, degrees; angle
/// kinds: |angle - target|, degrees; local_rotation: the rotation's angle
/// from the given one, degrees. The tolerance is not subtracted.
double constraint_residual(const std::vector<int>& parents, int root, const PoseConstraint& c,
                           const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot);

}  // namespace mocap
