#pragma once
// Checks of a parsed query against what it is run on (docs/queries.md
// "Validation"): the label values of its filter against those the index or
// collection holds, and the names of a BVH (or AMC) frame's `only` against
// the file's own skeleton.
//
// Order of the checks. parse_query (query.hpp) checks the JSON: fields,
// types, ranges, files named, all but the value of a hand-written joint
// (QueryFrameSpec::joint_value_error). A query that parses is then checked
// where it runs (SearchEngine::run, mocap-synth):
//  1. the filter's label values (check_filter_labels), before any frame;
//  2. per query frame, in order: a hand-written frame's `joints` names
//     (rotations and directions) against each index skeleton (an unknown
//     name lists that skeleton's joints), then, where parsing deferred one,
//     its `effectors` names and the deferred joint-value error (so that an
//     unknown joint written without its "order" is reported as unknown, not
//     as missing its order); a file frame's file (readable, frame in range,
//     mapping onto the index skeleton), then each `only` name against the
//     file's skeleton (resolve_only_joint); then the body-frame constraints
//     (angles, directions, effectors: query_pose.hpp).
// The first failed check is the query's error: InputError("query ID", 0,
// "<field path>: what"), except a deferred joint-value error, which keeps the
// query file and line it was parsed from.
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/query.hpp"

namespace mocap {

/// Label key ("content", "style", ...) -> the non-empty values clips carry
/// for it, sorted (byte order). A key no clip has a value for is absent.
using LabelValues = std::map<std::string, std::set<std::string>>;

/// Adds the label values of `index`'s clips to `values` (a collection's are
/// the union of its shards').
void add_label_values(LabelValues& values, const Index& index);
/// The label values of one index.
LabelValues label_values(const Index& index);

/// Throws InputError("query ID", 0, "filter.KEY: unknown value \"V\"; WHERE
/// has: a, b, c") for the first value of the filter's `content` and `style`
/// lists (in that order, each in its written order) that no clip carries,
/// or "...; WHERE has no KEY labels" when none carries one for that key.
/// `where`: "the index" or "the collection", as the message should say.
/// Globs (`clips`, `exclude`) are not checked: a pattern matching no file is
/// a valid, empty filter.
void check_filter_labels(const Query& q, const LabelValues& values,
                         const std::string& where = "the index");

/// The `only` fields that are not joints, in the order the messages list them.
inline constexpr const char* kOnlyRootFields[] = {"root_position", "root_position_xz",
                                                  "root_heading"};

/// The index skeleton joint that entry `k` of frame `i`'s `only` (a joint
/// name; the root fields are the caller's) keeps the rotation of. The name
/// must name a joint of the file's skeleton (the BVH's, or an AMC take's
/// ASF, which the messages name), by name or alias (find_joint_by_alias);
/// the index joint is the one it means on the index skeleton the same way,
/// else the one whose file joint it is (`file_joints`: index joint -> file
/// joint or -1, as resolve_query_pose poses the frame on the index skeleton).
/// Throws InputError("query ID", 0, "frames[i].only[k]: ...") when the
/// file's skeleton has no such joint (listing the root fields and the file's
/// joints) or the index skeleton has no counterpart for it (listing the
/// index skeleton's joints).
int resolve_only_joint(const Query& q, std::size_t i, std::size_t k, const Skeleton& file_skeleton,
                       const Skeleton& index_skeleton, const std::vector<int>& file_joints);

/// "did you mean \"NAME\"? " for an unknown joint name within 2 edits (any
/// case) of a joint of `skeleton` or of a canonical body-part name
/// (canonical_joint_name: "LeftUpperArm", "Hips", ...); "" when none is.
std::string joint_did_you_mean(const Skeleton& skeleton, const std::string& name);

/// Warnings for joint names that the query reads as another body part than
/// the one they name on a rig that carries them (docs/queries.md "Across
/// rigs"). A name means a body part on every rig (find_joint_by_alias):
/// "LeftShoulder" is the clavicle, though the joint named LeftShoulder in
/// CMU's 3ds-max files is the upper arm. Checked: frame i's hand-written
/// `joints` and `effectors` names on `skeleton` (called `rig` in the
/// message), and a file frame's `only` names on its file's skeleton
/// (`file_skeleton`, called `file`; null for a hand-written frame). One
/// warning per name whose exact-named joint is not the joint it is read
/// as: "frames[i].joints.NAME: read as the left clavicle (joint "LeftCollar"
/// of RIG), but RIG's joint "LeftShoulder" is its left upper arm; ...
/// write "LeftUpperArm" for that joint". Unknown names are the resolution's
/// errors, not warnings. Never throws.
std::vector<std::string> joint_name_warnings(const Query& q, std::size_t i,
                                             const Skeleton& skeleton, const std::string& rig,
                                             const Skeleton* file_skeleton,
                                             const std::string& file);

}  // namespace mocap
