#pragma once
// Where query frames and partial motions go (docs/queries.md "Placement"):
// the one rule the search scores by and synthesis assembles by.
//
// Every query frame has its own ground pose P(f) (ground_pose.hpp) in its own
// coordinates: a BVH frame's root ground pose in its file, a hand-written
// frame's given root x/z and heading. In a pair (Q^h, Q^h+1) both frames are
// moved into the pair's body frame by pair_body_move; a partial motion
// starting at F^s (ground pose S in its clip) maps that body frame into its
// clip by partial_motion_placement(S). The search compares the moved query
// frames with the clip's frames there; synthesis maps the clip's frames into
// the output by the inverse.
//
//  - world ("relative": false): every move is the identity;
//  - position: moves by root x/z only (headings stay world);
//  - relative (default): moves by root x/z and heading.
//
// Units: metres, radians; heading 0 faces +z, +x is the character's left.
#include <optional>

#include "mocap/common/body/ground_pose.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/query_pose.hpp"

namespace mocap {

/// What placements read from one query frame.
struct FrameRoot {
  /// A BVH frame, and its root's ground pose in its file (whatever "only"
  /// keeps).
  bool from_bvh = false;
  GroundPose file_pose;
  /// Hand-written: the given root x, z (metres) and heading (radians).
  std::optional<double> x_m, z_m, heading_rad;

  /// True when the frame says where it is or which way it faces: a BVH
  /// frame, or a hand-written one giving root x, z or heading.
  bool anchored() const {
    return from_bvh || x_m.has_value() || z_m.has_value() || heading_rad.has_value();
  }
  /// P(f): the file pose of a BVH frame; the given x/z (0 where not given)
  /// and heading (0 when not given) of a hand-written one.
  GroundPose ground_pose() const;
};

/// The FrameRoot of a resolved query frame.
FrameRoot frame_root(const ResolvedQueryPose& pose);

/// The move (own coordinates -> the pair's body frame) of frame `f` of a pair
/// whose first frame is `first` (f may be `first`):
///  - world: identity;
///  - `first` anchored, and f from a BVH file exactly when `first` is:
///    P(first)^-1 (its heading part dropped under position). A BVH pair is
///    measured from its first frame; a hand-written frame's root x/z and
///    heading from the pair's first hand-written frame;
///  - f from a BVH file, `first` not: P(f)^-1 (the frame at the body frame's
///    origin: files and hand-written values share no coordinates);
///  - otherwise identity (hand-written values already are body-frame ones).
GroundPose pair_body_move(FramePlacement placement, const FrameRoot& first, const FrameRoot& f);

/// Body frame -> clip coordinates for a partial motion whose first frame
/// F^s has the ground pose `start` in its clip: `start` (relative), its x/z
/// alone (position), identity (world).
GroundPose partial_motion_placement(FramePlacement placement, const GroundPose& start);

}  // namespace mocap
