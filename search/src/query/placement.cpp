// The placement rule shared by search and synthesis (mocap/search/placement.hpp).
#include "mocap/search/placement.hpp"

namespace mocap {

GroundPose FrameRoot::ground_pose() const {
  if (from_bvh) return file_pose;
  GroundPose g;
  g.heading_rad = heading_rad.value_or(0.0);
  g.position_m = Eigen::Vector2d(x_m.value_or(0.0), z_m.value_or(0.0));
  return g;
}

FrameRoot frame_root(const ResolvedQueryPose& pose) {
  FrameRoot r;
  r.from_bvh = pose.from_bvh;
  r.file_pose = pose.file_pose;
  if (!pose.from_bvh) {
    r.x_m = pose.given.root_position_m[0];
    r.z_m = pose.given.root_position_m[2];
    r.heading_rad = pose.given.root_heading_rad;
  }
  return r;
}

namespace {

GroundPose inverse_for(FramePlacement placement, GroundPose g) {
  if (placement != FramePlacement::relative) g.heading_rad = 0.0;
  return g.inverse();
}

}  // namespace

GroundPose pair_body_move(FramePlacement placement, const FrameRoot& first, const FrameRoot& f) {
  if (placement == FramePlacement::world) return {};
  if (first.anchored() && f.from_bvh == first.from_bvh)
    return inverse_for(placement, first.ground_pose());
  if (f.from_bvh) return inverse_for(placement, f.ground_pose());
  return {};
}

GroundPose partial_motion_placement(FramePlacement placement, const GroundPose& start) {
  GroundPose g;
  if (placement == FramePlacement::world) return g;
  g.position_m = start.position_m;
  if (placement == FramePlacement::relative) g.heading_rad = start.heading_rad;
  return g;
}

}  // namespace mocap
