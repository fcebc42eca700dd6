#include "mocap/common/io/units.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"

namespace mocap {

namespace {
constexpr LengthUnit kAllUnits[] = {LengthUnit::m,    LengthUnit::cm,  LengthUnit::mm,
                                    LengthUnit::inch, LengthUnit::cmu, LengthUnit::dm};
constexpr UpAxis kAllUpAxes[] = {UpAxis::y, UpAxis::z};
// Z extent over Y extent above which a clip is taken to stand along Z.
constexpr double kZUpRatio = 1.5;
constexpr double kReferenceHeightM = 1.7;
constexpr double kInf = std::numeric_limits<double>::infinity();

double median(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Frames sampled evenly over the clip, first and last included.
std::vector<std::size_t> sample_frames(const RawClip& clip, int samples) {
  std::vector<std::size_t> out;
  if (clip.frame_count == 0 || samples <= 0) return out;
  const std::size_t count =
      std::min<std::size_t>(clip.frame_count, static_cast<std::size_t>(samples));
  for (std::size_t i = 0; i < count; ++i)
    out.push_back(count == 1 ? 0 : i * (clip.frame_count - 1) / (count - 1));
  return out;
}

// Lowest and highest point of a posed frame: (joint, is End Site) pairs.
struct Extremes {
  std::size_t lo_joint = 0, hi_joint = 0;
  bool lo_end = false, hi_end = false;
  double lo = kInf, hi = -kInf;
};

// The body's root: the first joint below a root that branches (Bandai Namco's
// static joint_Root -> Hips chain ends at Hips). Heights are measured within
// its subtree, so the root translation (where the character is) never counts.
std::vector<std::uint8_t> body_subtree(const Skeleton& skel) {
  const std::size_t n = skel.joint_count();
  std::vector<int> child_count(n, 0);
  for (std::size_t j = 0; j < n; ++j)
    if (skel.parents[j] >= 0) ++child_count[static_cast<std::size_t>(skel.parents[j])];
  std::vector<std::uint8_t> in(n, 0);
  for (std::size_t r = 0; r < n; ++r) {
    if (skel.parents[r] >= 0) continue;
    std::size_t body = r;  // walk down single-child chains
    while (child_count[body] == 1) {
      std::size_t c = body + 1;
      while (skel.parents[c] != static_cast<int>(body)) ++c;
      body = c;
    }
    in[body] = 1;
  }
  for (std::size_t j = 0; j < n; ++j)
    if (skel.parents[j] >= 0 && in[static_cast<std::size_t>(skel.parents[j])]) in[j] = 1;
  return in;
}

// Extremes along `axis` (1 = Y, 2 = Z).
Extremes extremes(const Skeleton& skel, const WorldPose& world,
                  const std::vector<Eigen::Vector3d>& ends, const std::vector<std::uint8_t>& body,
                  int axis = 1) {
  Extremes e;
  for (std::size_t j = 0; j < skel.joint_count(); ++j) {
    if (!body[j]) continue;
    for (int k = 0; k < 2; ++k) {
      const double y = k == 0 ? world.positions_m[j][axis] : ends[j][axis];
      if (k == 1 && !skel.has_end_site[j]) continue;
      if (y < e.lo) e = {j, e.hi_joint, k == 1, e.hi_end, y, e.hi};
      if (y > e.hi) e = {e.lo_joint, j, e.lo_end, k == 1, e.lo, y};
    }
  }
  return e;
}
}  // namespace

double unit_scale_m(LengthUnit u) {
  switch (u) {
    case LengthUnit::m:
      return 1.0;
    case LengthUnit::cm:
      return 0.01;
    case LengthUnit::mm:
      return 0.001;
    case LengthUnit::inch:
      return 0.0254;
    case LengthUnit::cmu:
      return 0.056444;
    case LengthUnit::dm:
      return 0.1;
  }
  return 1.0;
}

const char* unit_name(LengthUnit u) {
  switch (u) {
    case LengthUnit::m:
      return "m";
    case LengthUnit::cm:
      return "cm";
    case LengthUnit::mm:
      return "mm";
    case LengthUnit::inch:
      return "inch";
    case LengthUnit::cmu:
      return "cmu";
    case LengthUnit::dm:
      return "dm";
  }
  return "m";
}

const char* up_axis_name(UpAxis a) {
  return a == UpAxis::z ? "z" : "y";
}

std::optional<LengthUnit> parse_unit(std::string_view s) {
  std::string lower(s);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (LengthUnit u : kAllUnits)
    if (lower == unit_name(u)) return u;
  return std::nullopt;
}

std::optional<UpAxis> parse_up_axis(std::string_view s) {
  for (UpAxis a : kAllUpAxes)
    if (s.size() == 1 && std::tolower(static_cast<unsigned char>(s[0])) == up_axis_name(a)[0])
      return a;
  return std::nullopt;
}

namespace {
// Median over sampled frames of `measure(skel, local, extremes)`; frames whose
// extremes are not finite or whose measure is negative (no height) are skipped.
template <class Measure>
double median_over_samples(const RawClip& clip, int samples, Measure measure, int axis = 1) {
  if (clip.joints.empty()) return 0.0;
  const Skeleton skel = build_skeleton(clip, 1.0);
  const std::vector<std::uint8_t> body = body_subtree(skel);
  std::vector<double> heights;
  LocalPose local;
  WorldPose world;
  std::vector<Eigen::Vector3d> ends;
  for (std::size_t f : sample_frames(clip, samples)) {
    local_pose_from_row(skel, clip.frame(f), local);
    forward_kinematics(skel, local, world);
    end_site_positions(skel, world, ends);
    const Extremes e = extremes(skel, world, ends, body, axis);
    if (!std::isfinite(e.hi - e.lo)) continue;
    const double h = measure(skel, local, e);
    if (h >= 0.0) heights.push_back(h);
  }
  return median(heights);
}
}  // namespace

double standing_height_file_units(const RawClip& clip, int samples) {
  return median_over_samples(
      clip, samples,
      [](const Skeleton&, const LocalPose&, const Extremes& e) { return e.hi - e.lo; });
}

UpAxis detect_up_axis(const RawClip& clip, int samples) {
  const auto extent = [](const Skeleton&, const LocalPose&, const Extremes& e) {
    return e.hi - e.lo;
  };
  const double y = median_over_samples(clip, samples, extent, 1);
  const double z = median_over_samples(clip, samples, extent, 2);
  return z > kZUpRatio * y ? UpAxis::z : UpAxis::y;
}

double skeleton_height_file_units(const RawClip& clip, int samples) {
  return median_over_samples(
      clip, samples, [](const Skeleton& skel, const LocalPose& local, const Extremes& e) {
        // Bone lengths from each end up to the lowest common ancestor.
        double length = (e.lo_end ? skel.end_sites_m[e.lo_joint].norm() : 0.0) +
                        (e.hi_end ? skel.end_sites_m[e.hi_joint].norm() : 0.0);
        int a = static_cast<int>(e.lo_joint), b = static_cast<int>(e.hi_joint);
        while (a != b && a >= 0 && b >= 0) {
          // parents[j] < j: the larger index is never an ancestor of the smaller.
          int& deeper = a > b ? a : b;
          length += local.translations_m[static_cast<std::size_t>(deeper)].norm();
          deeper = skel.parents[static_cast<std::size_t>(deeper)];
        }
        return a == b ? length : -1.0;  // different trees (several ROOTs): not a body height
      });
}

LengthUnit detect_unit(const RawClip& clip) {
  const double h = skeleton_height_file_units(clip);
  if (!(h > 0.0) || !std::isfinite(h)) return LengthUnit::m;
  LengthUnit best = LengthUnit::m;
  double best_err = kInf;
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
