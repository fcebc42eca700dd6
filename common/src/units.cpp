#include "mocap/units.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "mocap/kinematics.hpp"
#include "mocap/skeleton.hpp"

namespace mocap {

namespace {
constexpr LengthUnit kAllUnits[] = {LengthUnit::m, LengthUnit::cm, LengthUnit::mm, LengthUnit::inch,
                                    LengthUnit::cmu};
constexpr double kReferenceHeightM = 1.7;
}  // namespace

double unit_scale_m(LengthUnit u) {
  switch (u) {
    case LengthUnit::m: return 1.0;
    case LengthUnit::cm: return 0.01;
    case LengthUnit::mm: return 0.001;
    case LengthUnit::inch: return 0.0254;
    case LengthUnit::cmu: return 0.056444;
  }
  return 1.0;
}

const char* unit_name(LengthUnit u) {
  switch (u) {
    case LengthUnit::m: return "m";
    case LengthUnit::cm: return "cm";
    case LengthUnit::mm: return "mm";
    case LengthUnit::inch: return "inch";
    case LengthUnit::cmu: return "cmu";
  }
  return "m";
}

std::optional<LengthUnit> parse_unit(std::string_view s) {
  std::string lower(s);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (LengthUnit u : kAllUnits)
    if (lower == unit_name(u)) return u;
  return std::nullopt;
}

double standing_height_file_units(const RawClip& clip, int samples) {
  if (clip.frame_count == 0 || clip.joints.empty() || samples <= 0) return 0.0;
  const Skeleton skel = build_skeleton(clip, 1.0);
  const std::size_t count = std::min<std::size_t>(clip.frame_count, static_cast<std::size_t>(samples));
  std::vector<double> heights;
  heights.reserve(count);
  LocalPose local;
  WorldPose world;
  std::vector<Eigen::Vector3d> ends;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t f = count == 1 ? 0 : i * (clip.frame_count - 1) / (count - 1);
    local_pose_from_row(skel, clip.frame(f), local);
    forward_kinematics(skel, local, world);
    end_site_positions(skel, world, ends);
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t j = 0; j < skel.joint_count(); ++j) {
      for (const Eigen::Vector3d* p : {&world.positions_m[j], &ends[j]}) {
        lo = std::min(lo, (*p)[1]);
        hi = std::max(hi, (*p)[1]);
      }
    }
    if (std::isfinite(hi - lo)) heights.push_back(hi - lo);
  }
  if (heights.empty()) return 0.0;
  std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2),
                   heights.end());
  return heights[heights.size() / 2];
}

LengthUnit detect_unit(const RawClip& clip) {
  const double h = standing_height_file_units(clip);
  if (!(h > 0.0) || !std::isfinite(h)) return LengthUnit::m;
  LengthUnit best = LengthUnit::m;
  double best_err = INFINITY;
  for (LengthUnit u : kAllUnits) {
    const double err = std::abs(std::log(h * unit_scale_m(u) / kReferenceHeightM));
    if (err < best_err) {
      best_err = err;
      best = u;
    }
  }
  return best;
}

}  // namespace mocap
