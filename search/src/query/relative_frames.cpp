// Relative placements: body-frame query frames and the frames' ground poses
// (relative_frames.hpp).
#include "query/relative_frames.hpp"

#include <fmt/format.h>

#include <cmath>

#include "mocap/common/util/error.hpp"

namespace mocap::search_detail {

Eigen::Vector3d move_given_root(const GroundPose& g, const ResolvedFrame& f, PartialPoseSpec* spec,
                                HScanRootQuery* root_scan) {
  const Eigen::Vector3d p = g.apply(f.root_m);
  Eigen::Vector3d moved = f.root_m;
  for (std::size_t a : {0u, 2u}) {
    if (!f.given[a]) continue;
    const double v = p[static_cast<Eigen::Index>(a)];
    moved[static_cast<Eigen::Index>(a)] = v;
    if (spec != nullptr) spec->root_position_m[a] = v;
    if (root_scan != nullptr) root_scan->position[a] = static_cast<float>(v);
  }
  if (spec != nullptr && f.partial.spec.root_heading_rad)
    spec->root_heading_rad = *f.partial.spec.root_heading_rad + g.heading_rad;
  return moved;
}

namespace {

// Moves a frame by `g` (own coordinates -> body): a full frame's state and
// scan query, or the given root components and heading of any other.
void move_frame(ResolvedFrame& f, const GroundPose& g, const SkeletonTables& tables, double t) {
  if (f.kind == FrameKind::full) {
    place_state(g, f.state);
    f.scan = make_h_scan_query(tables.model, f.state.view(), t, f.compared);
    f.root_m = f.state.joint_positions_m[static_cast<std::size_t>(tables.model.root())];
    return;
  }
  f.root_m = move_given_root(g, f, &f.partial.spec, &f.root_scan);
}

}  // namespace

void pair_body_frames(const Query& q, std::size_t h, const ResolvedFrame& qa,
                      const ResolvedFrame& qb, const SkeletonTables& tables, double t,
                      ResolvedFrame& a, ResolvedFrame& b) {
  const bool turn = q.placement == FramePlacement::relative;
  std::size_t i = h;
  for (const ResolvedFrame* f : {&qa, &qb}) {
    if (turn && !f->root.from_bvh && f->given[0] != f->given[2])
      throw InputError("query " + q.id, 0,
                       fmt::format("frames[{}].root_position: \"relative\": true needs root x and "
                                   "z together (or neither): a turn mixes them; for one axis use "
                                   "\"relative\": \"position\" or false",
                                   i));
    ++i;
  }
  a = qa;
  b = qb;
  for (ResolvedFrame* f : {&a, &b}) {
    const GroundPose g = pair_body_move(q.placement, qa.root, f->root);
    if (g.heading_rad != 0.0 || g.position_m != Eigen::Vector2d::Zero())
      move_frame(*f, g, tables, t);
  }
}

const std::vector<double>& frame_headings(const SkeletonData& skeleton) {
  SkeletonCaches& caches = skeleton.caches;
  std::call_once(caches.headings_once, [&] {
    const SkeletonTables& tables = skeleton.tables;
    const std::size_t n = tables.frame_count;
    caches.headings.assign(n, 0.0);
    const int root = tables.model.root();
    if (root < 0) return;
    const auto r = static_cast<std::size_t>(root);
    const auto seg = static_cast<std::size_t>(tables.segment_of_joint[r]);
    // The table holds q = R P (the segment's principal frame): R = q P^-1.
    const Eigen::Quaterniond back = tables.model.principal_frames[r].conjugate();
    tables.for_each_tile_piece(
        0, n, [&](std::size_t row, std::size_t lane, std::size_t count, std::size_t offset) {
          const std::size_t stride = tables.tile_stride(row);
          const float* base = tables.tile_data(row) + seg * HScanTable::kFields * stride + lane;
          const float* w = base + HScanField::orient_w * stride;
          const float* x = base + HScanField::orient_x * stride;
          const float* y = base + HScanField::orient_y * stride;
          const float* z = base + HScanField::orient_z * stride;
          for (std::size_t i = 0; i < count; ++i)
            caches.headings[offset + i] =
                heading_rad(Eigen::Quaterniond(w[i], x[i], y[i], z[i]) * back);
        });
    caches.heading_cos_sin.resize(2 * n);
    for (std::size_t f = 0; f < n; ++f) {
      caches.heading_cos_sin[2 * f] = std::cos(caches.headings[f]);
      caches.heading_cos_sin[2 * f + 1] = std::sin(caches.headings[f]);
    }
  });
  return caches.headings;
}

Eigen::Vector3d place_point(const SkeletonData& skeleton, FramePlacement placement, std::size_t g,
                            const Eigen::Vector3d& p) {
  const SkeletonTables& tables = skeleton.tables;
  const double x = tables.root_position(0, g), z = tables.root_position(2, g);
  if (placement != FramePlacement::relative) return {p.x() + x, p.y(), p.z() + z};
  const double* cs = skeleton.caches.heading_cos_sin.data() + 2 * g;
  // R_y(theta) (x, z) = (c x + s z, -s x + c z) (ground_pose.hpp).
  return {cs[0] * p.x() + cs[1] * p.z() + x, p.y(), -cs[1] * p.x() + cs[0] * p.z() + z};
}

GroundPose frame_placement(const SkeletonData& skeleton, FramePlacement placement, std::size_t g) {
  const SkeletonTables& tables = skeleton.tables;
  GroundPose start;
  start.position_m = Eigen::Vector2d(tables.root_position(0, g), tables.root_position(2, g));
  if (placement == FramePlacement::relative) start.heading_rad = frame_headings(skeleton)[g];
  return partial_motion_placement(placement, start);
}

}  // namespace mocap::search_detail
