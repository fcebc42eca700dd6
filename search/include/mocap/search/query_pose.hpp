#pragma once
// Query frames resolved on one index skeleton (docs/queries.md): the one
// resolver that the search engine and synthesis both read query frames
// through. A frame gives some degrees of freedom (root position components,
// root heading, joints' local rotations) or is a frame of a BVH file (all of
// them, with the file's velocities, or the DOFs listed in "only").
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mocap/common/body/ground_pose.hpp"
#include "mocap/common/body/pose_constraints.hpp"
#include "mocap/common/body/segment_class.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/search/query.hpp"

namespace mocap {

/// A BVH file read for queries (file skeleton, local pose per frame): all
/// its frames, or a window of them (QueryBvhCache::get_frames).
struct QueryBvhFile {
  /// Frames [first_frame, first_frame + motion.frame_count) of the file:
  /// local poses only (clip_locals_from_raw; the world arrays are empty, as
  /// the frames are posed on the index's skeletons).
  ClipMotion motion;
  /// The file's size and modification time when it was read.
  FileStat stat;
  std::size_t first_frame = 0;
  /// Frames in the file.
  std::size_t file_frame_count = 0;
};

/// Parsed BVH files shared by the queries of a batch (bounded, thread-safe;
/// an entry is re-read when the file's size or modification time changes).
class QueryBvhCache {
 public:
  /// `unit_option`: "auto" (or empty) detects the file's length unit, else a
  /// unit name (units.hpp parse_unit). Throws InputError naming the file.
  std::shared_ptr<const QueryBvhFile> get(const std::filesystem::path& path,
                                          const std::string& unit_option);

  /// An ASF/AMC take (asf_amc.hpp): the AMC `amc` with the skeleton `asf`,
  /// at `frame_time_s` seconds a frame, Y up as the indexer makes it, in
  /// metres by the ASF's length unit. Cached like get() (re-read when either
  /// file's size or modification time changes). Throws InputError naming
  /// the file and line.
  std::shared_ptr<const QueryBvhFile> get_amc(const std::filesystem::path& amc,
                                              const std::filesystem::path& asf,
                                              double frame_time_s);

  /// Lets get_frames read only a window of the files `index` holds.
  void use_index(const Index& index);

  /// Frames [frame - radius, frame + radius] (clamped to the file) of the
  /// file, with exactly get()'s values for them. When the file is a clip of
  /// the index given to use_index (same lexically normal absolute path, same
  /// size, its bytes hash to the clip's content XXH64) and `unit_option` is
  /// the index's, the indexer has parsed these very bytes and detected their
  /// unit: only the window's frame lines are parsed (parse_bvh_window), the
  /// hierarchy only when no earlier file began with the same hierarchy bytes,
  /// and the clip's unit is used. Otherwise it is get()
  /// (every frame). A frame past the file's end gives an empty window
  /// (file_frame_count says how many frames there are). The verified bytes
  /// of the last few such files are kept, so another frame of the same
  /// unchanged file (same size and modification time) is not read and hashed
  /// again.
  std::shared_ptr<const QueryBvhFile> get_frames(const std::filesystem::path& path,
                                                 const std::string& unit_option, std::size_t frame,
                                                 std::size_t radius);

 private:
  struct KnownFile {
    std::uint64_t size = 0, hash = 0;
    double unit_scale_m = 1.0;
  };
  std::shared_ptr<const QueryBvhFile> store(const std::string& key,
                                            std::shared_ptr<QueryBvhFile> entry);
  // The bytes of an indexed file whose hash matched the index's, kept for
  // the file's other frames (a query's frames often come from one file); an
  // entry serves while the file's size and modification time are unchanged.
  struct VerifiedText {
    FileStat stat;
    std::shared_ptr<const FileBytes> text;
  };
  // The hierarchy a verified text begins with, looked up among the last few
  // distinct ones (a library's files of one skeleton share it).
  std::shared_ptr<const BvhHierarchy> hierarchy_of(std::string_view text);
  std::mutex mutex_;
  std::unordered_map<std::string, std::shared_ptr<const QueryBvhFile>> entries_;
  std::unordered_map<std::string, VerifiedText> verified_;  // by path as given (bounded)
  std::unordered_map<std::string, KnownFile> known_;        // by path; set before concurrent use
  std::vector<std::shared_ptr<const BvhHierarchy>> hierarchies_;  // bounded
  std::string known_unit_option_;
};

/// Query frame i of a query on one index skeleton.
struct ResolvedQueryPose {
  /// The frame is a frame of a BVH file (QueryFrameSpec::bvh).
  bool from_bvh = false;
  /// A whole BVH frame (no "only"): `state` holds its world state.
  bool full = false;
  /// from_bvh: the ground pose (ground_pose.hpp) of the frame's root in its
  /// file, whatever "only" keeps: where relative placements measure the
  /// pair's other frames from.
  GroundPose file_pose;
  /// The degrees of freedom the frame gives, on the index skeleton: root
  /// (pelvis) world position components (metres), root heading (radians,
  /// heading_rad()), local rotations by joint index (each joint once; a joint
  /// named twice through aliases: the last wins). For a whole BVH frame: the
  /// root position (x, y, z) and the local rotation of every joint the file
  /// has a counterpart for (no heading: the root's rotation is given).
  PartialPoseSpec given;
  /// from_bvh: the frame's local rotation of every skeleton joint (identity
  /// where the file has no counterpart) and the file joint of each skeleton
  /// joint (-1: none; the same rig: by name; another rig:
  /// RetargetMap::source_joint).
  std::vector<Eigen::Quaterniond> local_rotations;
  std::vector<int> file_joints;
  /// full: world state (joint origins, rotations, COMs) with the file's own
  /// finite-difference rates at the frame (dynamics.hpp), index skeleton and
  /// `model`'s body.
  BodyState state;
  /// The frame's joint entries, angles and effectors as body-frame
  /// constraints (pose_constraints.hpp), parents first: what residuals are
  /// measured against (a given local rotation of a BVH frame's "only" is
  /// there unnamed, and has no residual). Empty for frames without any.
  std::vector<PoseConstraint> constraints;
  /// The frame is completed per database frame (QueryFrameSpec::constrained):
  /// `given.joint_rotations` lists every joint the constraints drive, in
  /// driven_joints order, and solve_given fills their rotations.
  bool solve = false;
  /// solve: per joint, the multiplier of its energy terms (the weight of the
  /// constraint driving it or its nearest driven ancestor; 1 elsewhere);
  /// empty when every weight is 1.
  std::vector<double> joint_weights;
  /// solve: per joint, 1 when it is driven only by body-frame constraints
  /// (not under a given local rotation, root position or heading): such a
  /// joint keeps the database frame's rates when the solution leaves it
  /// where it is (its constraints met within tolerance), and is static (a
  /// given value) when the solution moves it (solve_given).
  std::vector<std::uint8_t> keep_rates;
  /// The frame's "weight": multiplier of its h.
  double weight = 1.0;
  /// from_bvh with "context" (QueryFrameSpec::context_before / _after): the
  /// file's segment COM velocities around the key pose, m/s, in the key
  /// pose's body frame (turned by minus its root heading), on the index
  /// skeleton with `model`'s body: K rows of model.segments.size() vectors
  /// each. Before: row j the backward difference at file frame a - j (reading
  /// frames a - K .. a, none after the key pose); after: row j the forward
  /// difference at frame b + j (reading b .. b + K). Empty: none given.
  std::vector<Eigen::Vector3d> context_before_mps, context_after_mps;
  /// The file's frame time (s): the spacing of the context rows.
  double context_frame_time_s = 0.0;
  /// from_bvh: the file's skeleton is another rig than the index skeleton
  /// (retarget.hpp same_rig): the frames were retargeted onto it
  /// (make_retarget_map, retarget_pose; docs/queries.md "Across rigs"), so
  /// `local_rotations`, `state` and the given DOFs are the retargeted pose's
  /// and `file_joints` is RetargetMap::source_joint.
  bool cross_rig = false;
  /// cross_rig: per index-skeleton joint, 1 where its segment is compared
  /// with database frames (RetargetMap::compared), and the compared classes;
  /// empty otherwise (every segment is compared).
  std::vector<std::uint8_t> compared_joints;
  std::vector<std::pair<SegmentClass, Side>> compared_classes;
};

/// A constrained frame's DOFs when completed with a pose of the index
/// skeleton (world joint origins `pos`, rotations `rot`): `spec` (a copy of
/// the frame's `given`) gets each driven joint's rotation from
/// solve_pose_constraints. With `keep_rates`, it receives per joint whether
/// the joint keeps the pose's rates (PartialQuery::keep_rates): eligible
/// (ResolvedQueryPose::keep_rates) and not turned by the solution. Does
/// nothing for a frame with solve == false.
void solve_given(const ResolvedQueryPose& pose, const DynamicsModel& model,
                 const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot,
                 PoseConstraintScratch& scratch, std::vector<Eigen::Quaterniond>& locals,
                 PartialPoseSpec& spec, std::vector<std::uint8_t>* keep_rates = nullptr);

/// The typical pose of an index skeleton (retarget.hpp
/// typical_local_rotations: one local rotation per joint), asked for only
/// when a query frame's file is another rig; null or an empty function:
/// none (the retargeting's neutral pose is then the rest pose).
using TypicalPoseFn = std::function<const std::vector<Eigen::Quaterniond>*()>;

/// Resolves query frame `i` of `q` on skeleton `sk` (character `model`).
/// Throws InputError ("query ID: frames[i]...: ...") for unknown joints
/// (hand-written: listing `sk`'s joints; in `only`: listing the root fields
/// and the file's joints, resolve_only_joint), unreadable files, frames out
/// of range and files of another rig than `sk`'s that cannot be retargeted
/// onto it (no joint recognised as the pelvis); then a hand-written frame's
/// deferred joint-value error (QueryFrameSpec::joint_value_error), once its
/// joint names are known (order: query_validation.hpp). `file`, when given,
/// is the frame's BVH file fetched by an earlier call for the same query
/// frame on another skeleton (used when set, set when fetched here), so the
/// file is looked up once per query frame.
/// `typical_pose`: `sk`'s typical pose, for a file of another rig.
ResolvedQueryPose resolve_query_pose(const Query& q, std::size_t i, const IndexSkeleton& sk,
                                     const DynamicsModel& model, QueryBvhCache& cache,
                                     const std::string& unit_option = "auto",
                                     std::shared_ptr<const QueryBvhFile>* file = nullptr,
                                     const TypicalPoseFn& typical_pose = {});

}  // namespace mocap
