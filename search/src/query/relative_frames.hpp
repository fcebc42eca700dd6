#pragma once
// Internal to mocap_search: relative placements (docs/queries.md
// "Placement"). A pair's query frames are put into the body frame of the
// pair's first query frame once per query; a partial motion starting at F^s
// then places them with F^s's ground pose (frame_placement): heading and
// root x/z for "relative": true, root x/z alone for "position".
#include <cstddef>
#include <vector>

#include "bounds/skeleton_tables.hpp"
#include "mocap/common/body/ground_pose.hpp"
#include "mocap/search/query.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// A frame whose h does not depend on where it is placed: a partial frame
// giving no root position or heading (joint rotations, body-frame
// constraints; they are completed in F's own body frame).
inline bool placement_free(const ResolvedFrame& f) {
  return f.kind == FrameKind::partial && !f.given[0] && !f.given[1] && !f.given[2] &&
         !f.partial.spec.root_heading_rad;
}

// The given root x/z (f.root_m, f.given) and given heading of a frame that
// is not full, moved by g (ground_pose.hpp): written into `spec` and
// `root_scan` where not null (only the given components); returns f.root_m
// with its given x/z moved.
Eigen::Vector3d move_given_root(const GroundPose& g, const ResolvedFrame& f, PartialPoseSpec* spec,
                                HScanRootQuery* root_scan);

// Query frames qa (Q^h) and qb (Q^h+1) of one pair in body-frame coordinates
// for `placement` (position or relative), into a / b: each moved by
// pair_body_move (mocap/search/placement.hpp). Throws InputError ("query ID",
// "frames[i].root_position: ...") for a hand-written frame giving only one
// of root x and z under "relative": true (a turn would mix them).
void pair_body_frames(const Query& q, std::size_t h, const ResolvedFrame& qa,
                      const ResolvedFrame& qb, const SkeletonTables& tables, double t,
                      ResolvedFrame& a, ResolvedFrame& b);

// Heading of the root of every skeleton frame (radians, heading_rad), from
// the scan table's root-segment orientation; computed once per skeleton.
const std::vector<double>& frame_headings(const SkeletonData& skeleton);

// frame_placement(skeleton, placement, g).apply(p) from the cached cos and
// sin of the headings (frame_headings must have run), up to rounding.
Eigen::Vector3d place_point(const SkeletonData& skeleton, FramePlacement placement, std::size_t g,
                            const Eigen::Vector3d& p);

// Where a partial motion starting at skeleton frame g places body-frame
// query frames: F^g's root x/z, and its heading for "relative": true.
GroundPose frame_placement(const SkeletonData& skeleton, FramePlacement placement, std::size_t g);

}  // namespace mocap::search_detail
