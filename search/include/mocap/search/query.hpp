#pragma once
// Search queries: the JSON query language (docs/queries.md), parsed and
// validated, independent of any skeleton or index.
//
// A query is a sequence of query frames Q^1..Q^H (H >= 2), each possibly
// partial: root position (per axis, null = not given), root heading, some
// joints' rotations (Euler degrees in a stated order, or a quaternion), or
// "frame k of this BVH file" (all DOFs, or only some with "only"). Joint
// names are resolved later against the index's skeleton through the aliases
// of joint_classes.hpp (find_joint_by_alias).
//
// Errors: InputError(source, line, "<field path>: what was expected"), where
// `source` is the query file and `line` its line in a batch (0 for a single
// query file), e.g. "queries.jsonl:3: frames[1].joints.RightArm.order:
// expected 3 distinct letters of X, Y, Z, got \"ZZY\"". An invalid joint
// value is the one error parse_query does not throw: it is kept in
// QueryFrameSpec::joint_value_error and reported when the query is resolved,
// after the joint names (query_validation.hpp gives the order of the checks).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/util/error.hpp"

namespace mocap {

/// One joint's entry in "joints": a given local rotation (relative to its
/// parent, as in BVH: "euler_deg" + "order", or "quat"), or the direction
/// its segment points in the body frame ("direction"; docs/queries.md
/// "Body-frame constraints").
struct JointRotationSpec {
  std::string name;  // as written; resolved by alias later
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit; unless `direction`
  /// Unit vector in the body frame (+x left, +y up, +z forward).
  std::optional<Eigen::Vector3d> direction;
  /// direction: met within this angle, degrees (>= 0; default 0).
  double tolerance_deg = 0.0;
  /// "weight" (> 0): multiplier of the energy terms of the segments this
  /// entry moves (docs/queries.md "Weights").
  std::optional<double> weight;
};

/// An anatomical angle ("angles": {"trunk_flexion": 40, ...}), degrees:
/// trunk_flexion, left_/right_hip_flexion (forward lean from vertical,
/// -180..180), left_/right_elbow_flexion, left_/right_knee_flexion (0 =
/// straight, 0..180), left_/right_shoulder_elevation (upper arm from
/// hanging down, 0..180).
struct AngleSpec {
  std::string name;
  double deg = 0.0;
  double tolerance_deg = 0.0;  // >= 0
  std::optional<double> weight;
};

/// An end-effector target ("effectors": {"RightHand": {"position_m": [x, y,
/// z]}}): the joint's origin at a body-frame position, reached by its
/// two-bone chain (docs/queries.md "Body-frame constraints").
struct EffectorSpec {
  std::string name;  // a joint with a parent and grandparent below the root
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  double tolerance_m = 0.0;  // >= 0
  std::optional<double> weight;
};

/// The most context frames a query frame may give on either side.
inline constexpr std::size_t kMaxContextFrames = 120;

/// One query frame, as written.
struct QueryFrameSpec {
  /// Root (pelvis) position per axis, metres, world (or relative, see Query::relative).
  std::array<std::optional<double>, 3> root_position_m;
  /// Root heading: rotation about +Y, degrees.
  std::optional<double> root_heading_deg;
  std::vector<JointRotationSpec> joints;
  /// "frame k of this BVH file": path (resolved against the query file's
  /// folder when relative) and 0-based frame.
  std::optional<std::filesystem::path> bvh;
  std::size_t bvh_frame = 0;
  /// "amc" frames: `bvh` is the AMC take and this its ASF skeleton
  /// ("asf"), read at `amc_fps` frames per second ("amc_fps", default 120,
  /// CMU's rate; AMC files carry none). Unset for BVH frames.
  std::optional<std::filesystem::path> asf;
  double amc_fps = 120.0;
  /// With `bvh`: the DOFs taken from the file ("root_position",
  /// "root_position_xz", "root_heading", or joint names); empty = all.
  std::vector<std::string> only;
  /// "time_s": when the motion passes this key pose, seconds from the first
  /// key pose (docs/queries.md "Timed key poses"). Given on every frame of
  /// a query or on none; the first at 0; strictly increasing.
  std::optional<double> time_s;
  /// "angles" and "effectors": body-frame constraints (hand-written frames,
  /// and BVH frames with "only").
  std::vector<AngleSpec> angles;
  std::vector<EffectorSpec> effectors;
  /// "weight" (> 0, default 1): multiplier of this frame's h terms in the
  /// scores (docs/queries.md "Weights").
  double weight = 1.0;
  /// "context": {"before": K, "after": K, "weight": W} (whole BVH or AMC
  /// frames only; docs/queries.md "Context frames"): how many of the file's
  /// frames before this key pose (read where it starts a pair) and after it
  /// (where it ends one) the ranking compares with a partial motion's own
  /// (0..kMaxContextFrames; 0 = none), and the multiplier (> 0, default 1)
  /// of that context energy.
  std::size_t context_before = 0, context_after = 0;
  double context_weight = 1.0;
  /// The first invalid joint value of `joints` (e.g. euler_deg without its
  /// order), as parsing reported it (query file and line); that joint is
  /// kept by name only (identity rotation, no direction). Resolution reports it once every joint
  /// name of the frame is known on the skeleton, so that a misspelt joint is
  /// reported as unknown first (query_validation.hpp "Order of the checks").
  std::optional<InputError> joint_value_error;

  /// True when nothing at all is given (an error for a query frame).
  bool empty() const;
  /// True when the frame has a constraint completed per database frame (a
  /// direction, an angle, an effector) or a per-joint weight.
  bool constrained() const;
};

/// Clip filters; every given list must match (AND between lists, OR inside one).
struct QueryFilter {
  std::vector<std::string> content;  // label names, exact
  std::vector<std::string> style;    // label names, exact
  std::vector<std::string> clips;    // shell globs on the clip's file name (not its folder)
  std::vector<std::string> exclude;  // shell globs on the clip's file name
  bool empty() const {
    return content.empty() && style.empty() && clips.empty() && exclude.empty();
  }
  /// True when a clip with this file name and labels passes.
  bool accepts(const std::string& file_name, const std::string& content_label,
               const std::string& style_label) const;
};

/// How query frames are placed on a partial motion F^s..F^e (docs/queries.md
/// "Placement"; JSON "relative").
enum class FramePlacement : std::uint8_t {
  /// "relative": false. Root positions and headings are world values.
  world,
  /// "relative": "position". The first query frame's root ground position
  /// (x, z) is put on F^s's; later frames keep their ground offsets from the
  /// first; headings stay absolute (world).
  position,
  /// "relative": true (the default). The first query frame's root ground
  /// position and heading are put on F^s's; later frames keep their ground
  /// displacement and heading change from the first, turned into F^s's
  /// heading (velocities turn with them). Hand-written root_position x/z are
  /// offsets in the first query frame's body frame (+z forward, +x to the
  /// character's left), root_heading a heading change from the first frame.
  relative,
};
/// "world", "position", "relative".
const char* placement_name(FramePlacement p);

/// How results that miss a named constraint rank (docs/queries.md
/// "Residuals and verdicts"; JSON "met"). Queries without named constraints
/// rank by score whatever it says.
enum class MetPolicy : std::uint8_t {
  /// "any": by score alone (ties: the misfit, then the clip).
  any,
  /// "first" (the default): results that meet every named constraint before
  /// the rest, each group by score.
  first,
  /// "only": results that miss a constraint are left out (fewer than top
  /// may remain).
  only,
};
/// "any", "first", "only".
const char* met_policy_name(MetPolicy p);

/// A query's "style" (docs/style.md "Asking for a style"): the style its
/// results should have, by label or like a file's frames; every result's
/// score gains weight x the clip's style distance (nats), which needs a
/// style model (mocap-search --style-model, Python style_model=).
struct QueryStyle {
  std::string label;                              // a style of the model, or
  std::optional<std::filesystem::path> like_bvh;  // frames like_first..like_last of a BVH file
  std::size_t like_first = 0, like_last = 0;
  bool like_whole = true;  // no "frames": the whole file
  double weight = 1.0;     // J per nat, > 0
};

struct Query {
  std::string id;  // default "<line N>" / file stem
  std::vector<QueryFrameSpec> frames;
  FramePlacement placement = FramePlacement::relative;
  /// Any relative placement (position or position and heading).
  bool relative() const { return placement != FramePlacement::world; }
  /// The frames carry time_s (a timed query: docs/queries.md "Timed key poses").
  bool timed() const { return !frames.empty() && frames.front().time_s.has_value(); }
  /// Length limits of a partial motion, seconds (e - s >= round(min / frame
  /// time), >= 1 frame; e - s <= round(max / frame time)); unset: the search
  /// options' (SearchOptions::min_length_s, max_length_s).
  std::optional<double> min_length_s, max_length_s;
  std::optional<std::filesystem::path> character;
  double transition_time_s = 0.5;  // > 0
  std::size_t top = 10;            // the paper's r, >= 1
  double path_weight = 0.0;        // lambda >= 0
  MetPolicy met = MetPolicy::first;
  QueryFilter filter;
  std::optional<QueryStyle> style;
  /// "synth_style": the style mocap-synth turns the output toward (style
  /// transfer, docs/style.md "Style transfer"; a style of the model given
  /// with --style-model); the search ignores it.
  std::optional<std::string> synth_style;
};

/// Parses one query object. `base_dir` resolves relative "bvh" and
/// "character" paths; `default_id` is used when "id" is absent.
Query parse_query(const nlohmann::json& j, const std::string& source, std::size_t line,
                  const std::filesystem::path& base_dir, const std::string& default_id);

/// Parses text holding one JSON query; JSON syntax errors become InputError too.
Query parse_query_text(const std::string& text, const std::string& source, std::size_t line,
                       const std::filesystem::path& base_dir, const std::string& default_id);

/// Euler order "ZXY" -> axes {2, 0, 1}; nullopt unless 3 distinct letters of XYZ (any case).
std::optional<std::array<std::uint8_t, 3>> parse_euler_order(const std::string& order);

}  // namespace mocap
