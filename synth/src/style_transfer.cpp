// Style transfer as passes over a synthesised motion (style_transfer.hpp;
// docs/style.md "Style transfer"): the key weights, the style offsets the
// model predicts, the per-joint linear map of the rotation vectors, the
// grounded legs of the untransferred motion, the root's drop, the held feet.
#include "mocap/synth/style_transfer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "foot_planting.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

using synth_detail::LegChain;

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

std::size_t frames_of(double seconds, double frame_time_s) {
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(seconds / frame_time_s)));
}

// The rotation of a rotation vector (axis times angle, radians).
Eigen::Quaterniond from_rotation_vector(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1.0, 0.5 * r.x(), 0.5 * r.y(), 0.5 * r.z());
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle));
}

// The key weight w(t): 0 at every key frame, smoothstep(d / ease) at d
// frames from the nearest one, 1 from `ease` frames on.
std::vector<double> key_weights(std::size_t frames, const std::vector<std::size_t>& keys,
                                std::size_t ease) {
  std::vector<double> w(frames, 1.0);
  for (std::size_t t = 0; t < frames; ++t)
    for (std::size_t k : keys) {
      const std::size_t d = t > k ? t - k : k - t;
      w[t] = std::min(w[t], smoothstep(static_cast<double>(d) / static_cast<double>(ease)));
    }
  return w;
}

// One joint's linear map: its skeleton joint, whether it is the pelvis (its
// heading-free world rotation is mapped), the mean offset dm (radians) and
// the per-axis spread ratio k.
struct JointMap {
  int joint = -1;
  bool pelvis = false;
  /// False: left as it is (kWrapRad, kPredictionSpreadRad).
  bool moved = true;
  Eigen::Vector3d mean_offset = Eigen::Vector3d::Zero();
  Eigen::Vector3d sd_ratio = Eigen::Vector3d::Ones();
};

// A joint whose rotation turns further than this (radians) in a frame is
// left as it is: the features' rotation vector wraps at half a turn, so its
// mean and spread there say little (Bandai Namco's upper legs turn about pi
// from their parent).
constexpr double kWrapRad = 2.6;
// A joint whose mean rotation vector spreads more than this (radians, on an
// axis) over the content's clips is left as it is: its prediction rests on
// rotation vectors that wrapped.
constexpr double kPredictionSpreadRad = 0.8;
// An axis whose rotation vector spreads less than this over the motion
// (radians; a knee's off-hinge axes) keeps its spread: what it has is noise.
constexpr double kMinSpreadRad = 0.02;

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// The checks of transfer_style, before any work: the parameters, the style,
// the model's joints in the skeleton (their skeleton numbers returned).
std::vector<int> checked_joints(const SynthSkeleton& sk, const StyleModel& model,
                                const StyleTransferParams& p, std::size_t frames) {
  if (std::find(model.style.classes.begin(), model.style.classes.end(), p.style) ==
      model.style.classes.end())
    throw InputError("--style", 0,
                     "the style model has no style \"" + p.style +
                         "\"; its styles: " + joined(model.style.classes));
  if (!(std::isfinite(p.strength) && p.strength >= 0.0 && p.strength <= 4.0))
    throw InputError("--style-strength", 0, "must be a number from 0 to 4");
  if (!(p.min_sd_ratio > 0.0 && p.min_sd_ratio <= 1.0 && p.max_sd_ratio >= 1.0 &&
        std::isfinite(p.max_sd_ratio) && p.key_ease_s > 0.0 && p.plant_ease_s > 0.0 &&
        std::isfinite(p.plant_height_m)))
    throw InputError("--style", 0,
                     "bad transfer parameters: 0 < min_sd_ratio <= 1 <= max_sd_ratio, eases > 0");
  if (frames < 4)
    throw InputError(
        "--style-model", 0,
        "a motion of " + std::to_string(frames) + " frames: the style model reads at least 4");
  std::vector<int> out;
  for (const std::string& name : model.joints) {
    const auto it = std::find(sk.skeleton.names.begin(), sk.skeleton.names.end(), name);
    if (it == sk.skeleton.names.end())
      throw InputError("--style-model", 0,
                       "the model's joint \"" + name +
                           "\" is not in the output's skeleton: a model of another rig; learn "
                           "one from an index of this rig (mocap-index style-model)");
    out.push_back(static_cast<int>(it - sk.skeleton.names.begin()));
  }
  return out;
}

// The offsets the model predicts (strength x (predicted(C, S) -
// predicted(C, the motion's own style)) on each joint's mean and spread
// features, the motion's own style being its styles' class means weighted by
// their probabilities), as joint maps (kPredictionSpreadRad: not moved;
// kMinSpreadRad: spread kept); `report` gets the most probable style and
// the content.
std::vector<JointMap> style_offsets(const SynthSkeleton& sk, const StyleModel& model,
                                    const StyleTransferParams& p, const std::vector<int>& joints,
                                    const std::vector<double>& features, const std::string& content,
                                    StyleTransferReport& report) {
  const bool known = std::find(model.content.classes.begin(), model.content.classes.end(),
                               content) != model.content.classes.end();
  const StylePrediction from = recognise_style(model, features, known ? content : std::string());
  report.from_style = from.style;
  report.from_p = from.probability;
  report.content = from.content;
  report.content_recognised = from.content_recognised;
  const auto index_of = [](const std::vector<std::string>& v, const std::string& s) {
    return static_cast<Eigen::Index>(std::find(v.begin(), v.end(), s) - v.begin());
  };
  const Eigen::Index c = index_of(model.content.classes, from.content);
  const Eigen::Index to = index_of(model.style.classes, p.style);
  // The motion's style as the model sees it: its styles' means weighted by
  // their probabilities (a motion already recognised as the style is still
  // moved toward it by the probability it lacks).
  Eigen::RowVectorXd own = Eigen::RowVectorXd::Zero(model.style.means.cols());
  for (std::size_t k = 0; k < from.probabilities.size(); ++k)
    own += from.probabilities[k].second * model.style.means.row(static_cast<Eigen::Index>(k));
  const auto offset = [&](std::size_t f) {
    const auto i = static_cast<Eigen::Index>(f);
    return p.strength * (model.style.means(to, i) - own(i)) * model.style_scale(i) *
           model.content_sd(c, i);
  };
  std::vector<JointMap> maps;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    JointMap m;
    m.joint = joints[i];
    m.pelvis = joints[i] == sk.root_joint;
    for (int a = 0; a < 3; ++a) {
      const std::size_t f = i * kStyleJointFeatures;
      m.mean_offset(a) = offset(f + static_cast<std::size_t>(a));
      const double sd = features[f + 3 + static_cast<std::size_t>(a)];
      const double want = sd + offset(f + 3 + static_cast<std::size_t>(a));
      m.sd_ratio(a) =
          sd > kMinSpreadRad ? std::clamp(want / sd, p.min_sd_ratio, p.max_sd_ratio) : 1.0;
      m.moved =
          m.moved && model.content_sd(c, static_cast<Eigen::Index>(f) + a) <= kPredictionSpreadRad;
    }
    maps.push_back(m);
  }
  return maps;
}

// The rotation a joint map reads at frame t: the pelvis' world rotation
// without its heading, another joint's local rotation.
Eigen::Quaterniond read_rotation(const JointMap& m, const SynthFrame& f, const WorldPose& w) {
  if (!m.pelvis) return f.local_rotations[static_cast<std::size_t>(m.joint)];
  const Eigen::Quaterniond q = w.rotations[static_cast<std::size_t>(m.joint)];
  return (Eigen::AngleAxisd(-style_heading_rad(q), Eigen::Vector3d::UnitY()) * q).normalized();
}

// The linear map of each joint's rotation vector over the frames:
// r' = r + w(t) (dm + (k - 1)(r - m)), m the joint's mean over the motion
// (frames of weight 0 untouched; a joint turning past kWrapRad: not moved).
// The pelvis' mapped rotation gets its heading back and becomes local to its
// parent again; each mapped rotation is clamped to `range` where the
// untransferred one is within it (none: not clamped).
void map_rotations(const SynthSkeleton& sk, const RangeOfMotion* range, std::vector<JointMap>& maps,
                   const std::vector<double>& weight, const std::vector<WorldPose>& source_world,
                   std::vector<SynthFrame>& frames) {
  const std::size_t n = frames.size();
  std::vector<Eigen::Vector3d> r(n);
  for (JointMap& m : maps) {
    if (!m.moved) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    double widest = 0.0;
    for (std::size_t t = 0; t < n; ++t) {
      r[t] = style_rotation_vector(read_rotation(m, frames[t], source_world[t]));
      mean += r[t] / static_cast<double>(n);
      widest = std::max(widest, r[t].norm());
    }
    m.moved = widest <= kWrapRad;
    if (!m.moved) continue;
    const auto j = static_cast<std::size_t>(m.joint);
    const int parent = sk.skeleton.parents[j];
    for (std::size_t t = 0; t < n; ++t) {
      if (weight[t] <= 0.0) continue;
      const Eigen::Vector3d mapped =
          r[t] + weight[t] * (m.mean_offset +
                              (m.sd_ratio.array() - 1.0).matrix().cwiseProduct(r[t] - mean));
      Eigen::Quaterniond q = from_rotation_vector(mapped);
      if (m.pelvis) {
        const Eigen::Quaterniond world = source_world[t].rotations[j];
        q = Eigen::AngleAxisd(style_heading_rad(world), Eigen::Vector3d::UnitY()) * q;
        if (parent >= 0)
          q = source_world[t].rotations[static_cast<std::size_t>(parent)].conjugate() * q;
      }
      const bool clamp = range && within_range(sk, *range, m.joint, frames[t].local_rotations[j]);
      frames[t].local_rotations[j] =
          clamp ? clamp_to_range(sk, *range, m.joint, q.normalized()) : q.normalized();
    }
  }
}

// The report's account of the maps: the joints moved, their mean offset
// and spread change, the joints left as they were.
void summarise_maps(const SynthSkeleton& sk, const std::vector<JointMap>& maps,
                    StyleTransferReport& report) {
  std::size_t moved = 0;
  for (const JointMap& m : maps) {
    if (!m.moved) {
      report.kept_joints.push_back(sk.skeleton.names[static_cast<std::size_t>(m.joint)]);
      continue;
    }
    ++moved;
    report.mean_offset_rad += m.mean_offset.norm();
    report.mean_sd_change += (m.sd_ratio.array() - 1.0).abs().mean();
  }
  report.joints = moved;
  if (moved == 0) return;
  report.mean_offset_rad /= static_cast<double>(moved);
  report.mean_sd_change /= static_cast<double>(moved);
}

// Per leg and frame, how much its foot is held where the untransferred
// motion has it: 1 where that motion has the leg's lowest foot joint origin
// below plant_height_m above the ground (grounded), smoothstep(1 - d /
// (ease + 1)) at d frames from the nearest grounded frame.
std::vector<std::vector<double>> hold_weights(const SynthSkeleton& sk,
                                              const std::vector<LegChain>& legs,
                                              const std::vector<WorldPose>& source_world,
                                              double plant_height_m, std::size_t ease) {
  const double ground = sk.model.params.ground_height_m;
  const std::size_t n = source_world.size();
  std::vector<std::vector<double>> out;
  for (const LegChain& leg : legs) {
    std::vector<double> d(n, std::numeric_limits<double>::infinity());
    for (std::size_t t = 0; t < n; ++t) {
      double lowest = std::numeric_limits<double>::infinity();
      for (int f : leg.feet)
        lowest = std::min(lowest, source_world[t].positions_m[static_cast<std::size_t>(f)].y());
      if (lowest - ground < plant_height_m) d[t] = 0.0;
    }
    for (std::size_t t = 1; t < n; ++t) d[t] = std::min(d[t], d[t - 1] + 1.0);
    for (std::size_t t = n - 1; t-- > 0;) d[t] = std::min(d[t], d[t + 1] + 1.0);
    std::vector<double> hold(n);
    for (std::size_t t = 0; t < n; ++t)
      hold[t] = d[t] == 0.0 ? 1.0 : smoothstep(1.0 - d[t] / static_cast<double>(ease + 1));
    out.push_back(std::move(hold));
  }
  return out;
}

// How far (metres; < 0: up) the root must move down at frame `t` for each
// held leg, turned as the transfer left it, to reach where the
// untransferred motion has its ankle with the hip-ankle distance the
// transfer gave it (so that the held leg keeps the style's knee bend), times
// the hold; the largest over the held legs (0: none held).
double needed_drop(const std::vector<LegChain>& legs, const std::vector<std::vector<double>>& hold,
                   std::size_t t, const WorldPose& now, const WorldPose& source) {
  double drop = -std::numeric_limits<double>::infinity();
  for (std::size_t l = 0; l < legs.size(); ++l) {
    if (hold[l][t] <= 0.0) continue;
    const auto hip = static_cast<std::size_t>(legs[l].hip);
    const auto ankle = static_cast<std::size_t>(legs[l].ankle);
    const double reach = (now.positions_m[ankle] - now.positions_m[hip]).norm();
    const Eigen::Vector3d d = source.positions_m[ankle] - now.positions_m[hip];
    const double horizontal = std::hypot(d.x(), d.z());
    const double vertical = -d.y();  // the hip above the ankle
    const double fits =
        horizontal < reach ? std::sqrt(reach * reach - horizontal * horizontal) : 0.0;
    drop = std::max(drop, hold[l][t] * (vertical - fits));
  }
  return std::isfinite(drop) ? drop : 0.0;
}

// The root's drop per frame: needed_drop, its mean over +-ease frames
// (smooth), times the key weight (key frames do not move).
std::vector<double> root_drops(const SynthSkeleton& sk, const std::vector<LegChain>& legs,
                               const std::vector<std::vector<double>>& hold,
                               const std::vector<double>& weight,
                               const std::vector<WorldPose>& source_world,
                               const std::vector<SynthFrame>& frames, std::size_t ease) {
  const std::size_t n = frames.size();
  std::vector<double> need(n, 0.0), drop(n, 0.0);
  WorldPose w;
  for (std::size_t t = 0; t < n; ++t) {
    if (weight[t] <= 0.0) continue;
    synth_world_pose(sk, frames[t], w);
    need[t] = needed_drop(legs, hold, t, w, source_world[t]);
  }
  for (std::size_t t = 0; t < n; ++t) {
    const std::size_t a = t > ease ? t - ease : 0, b = std::min(n - 1, t + ease);
    double sum = 0.0;
    for (std::size_t u = a; u <= b; ++u) sum += need[u];
    drop[t] = weight[t] * sum / static_cast<double>(b - a + 1);
  }
  return drop;
}

// Each leg's knee hinge: the unit mean of its knee's rotation vectors over
// the untransferred motion (zero where the knee does not turn).
std::vector<Eigen::Vector3d> knee_hinges(const std::vector<LegChain>& legs,
                                         const std::vector<SynthFrame>& source) {
  std::vector<Eigen::Vector3d> out;
  for (const LegChain& leg : legs) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const SynthFrame& f : source)
      sum += style_rotation_vector(f.local_rotations[static_cast<std::size_t>(leg.knee)]);
    out.push_back(sum.norm() > 1e-9 ? Eigen::Vector3d(sum.normalized()) : Eigen::Vector3d::Zero());
  }
  return out;
}

// Two-bone inverse kinematics as synth_detail::plant_leg, the knee turned
// about its `hinge` (in its own frame) instead of the thigh-shin plane's
// normal, which is ill-defined for a leg near straight: three times, the
// turn of the interior angle's change, in the direction that brings the
// hip-ankle distance nearer the wanted one; then the hip turns the
// hip-ankle line onto the target and the ankle takes the target's rotation.
// False, `f` unchanged, for a degenerate leg (a bone under 1 micrometre).
bool plant_leg_on_hinge(const SynthSkeleton& sk, const LegChain& leg, const Eigen::Vector3d& hinge,
                        const Eigen::Vector3d& target, const Eigen::Quaterniond& target_rotation,
                        SynthFrame& f, WorldPose& w) {
  const auto hip = static_cast<std::size_t>(leg.hip), knee = static_cast<std::size_t>(leg.knee),
             ankle = static_cast<std::size_t>(leg.ankle);
  synth_world_pose(sk, f, w);
  const double lab = (w.positions_m[knee] - w.positions_m[hip]).norm();
  const double lcb = (w.positions_m[ankle] - w.positions_m[knee]).norm();
  if (lab < 1e-6 || lcb < 1e-6 || hinge.isZero()) return false;
  // Reachable: at most 0.1 mm short of a straight leg, or the leg's own
  // length now where it is straighter than that.
  const double longest =
      std::max(lab + lcb - 1e-4, (w.positions_m[ankle] - w.positions_m[hip]).norm());
  const double lat =
      std::clamp((target - w.positions_m[hip]).norm(), std::abs(lab - lcb) + 1e-4, longest);
  const double angle1 =
      std::acos(std::clamp((lab * lab + lcb * lcb - lat * lat) / (2.0 * lab * lcb), -1.0, 1.0));
  for (int step = 0; step < 3; ++step) {
    const Eigen::Vector3d a = w.positions_m[hip], b = w.positions_m[knee], c = w.positions_m[ankle];
    const double angle0 =
        std::acos(std::clamp((a - b).normalized().dot((c - b).normalized()), -1.0, 1.0));
    const Eigen::Quaterniond knee0 = f.local_rotations[knee];
    double best = std::numeric_limits<double>::infinity();
    Eigen::Quaterniond chosen = knee0;
    for (const double sign : {1.0, -1.0}) {
      f.local_rotations[knee] =
          (knee0 * Eigen::AngleAxisd(sign * (angle1 - angle0), hinge)).normalized();
      synth_world_pose(sk, f, w);
      const double miss = std::abs((w.positions_m[ankle] - w.positions_m[hip]).norm() - lat);
      if (miss < best) {
        best = miss;
        chosen = f.local_rotations[knee];
      }
    }
    f.local_rotations[knee] = chosen;
    synth_world_pose(sk, f, w);
  }
  aim_leg(sk, leg, target, target_rotation, f, w);
  return true;
}

// The held feet: each leg with a hold h > 0 at a frame of weight > 0 gets
// its hip, knee and ankle rotations slerped by h toward the two-bone
// solution that puts its ankle where the untransferred motion has it, turned
// as that motion's ankle by the transfer's change of the ankle's local
// rotation, its knee turned about the knee's hinge (knee_hinges,
// plant_leg_on_hinge; a knee that does not turn: toward that motion's
// leg); the toes keep the transfer's rotation. Returns the (leg, frame)
// pairs fully held.
std::size_t hold_feet(const SynthSkeleton& sk, const std::vector<LegChain>& legs,
                      const std::vector<std::vector<double>>& hold,
                      const std::vector<double>& weight, const std::vector<SynthFrame>& source,
                      const std::vector<WorldPose>& source_world, std::vector<SynthFrame>& frames) {
  std::size_t held = 0;
  WorldPose w;
  const std::vector<Eigen::Vector3d> hinges = knee_hinges(legs, source);
  for (std::size_t t = 0; t < frames.size(); ++t) {
    if (weight[t] <= 0.0) continue;
    for (std::size_t l = 0; l < legs.size(); ++l) {
      const double h = hold[l][t];
      if (h <= 0.0) continue;
      const LegChain& leg = legs[l];
      const auto ankle = static_cast<std::size_t>(leg.ankle);
      const Eigen::Quaterniond turn =
          source[t].local_rotations[ankle].conjugate() * frames[t].local_rotations[ankle];
      SynthFrame planted = frames[t];
      const bool solved = plant_leg_on_hinge(sk, leg, hinges[l], source_world[t].positions_m[ankle],
                                             source_world[t].rotations[ankle] * turn, planted, w);
      for (int j : {leg.hip, leg.knee, leg.ankle}) {
        const auto k = static_cast<std::size_t>(j);
        const Eigen::Quaterniond& goal =
            solved ? planted.local_rotations[k] : source[t].local_rotations[k];
        frames[t].local_rotations[k] = frames[t].local_rotations[k].slerp(h, goal).normalized();
      }
      held += h >= 1.0 ? 1 : 0;
    }
  }
  return held;
}

}  // namespace

StyleMotion synth_style_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                               double frame_time_s) {
  StyleMotion out;
  out.joint_names = sk.skeleton.names;
  out.parents = sk.skeleton.parents;
  out.pelvis = sk.root_joint;
  out.frame_time_s = frame_time_s;
  out.frame_count = frames.size();
  WorldPose w;
  const auto p = static_cast<std::size_t>(sk.root_joint);
  for (const SynthFrame& f : frames) {
    synth_world_pose(sk, f, w);
    out.local_rotations.insert(out.local_rotations.end(), f.local_rotations.begin(),
                               f.local_rotations.end());
    out.pelvis_rotations.push_back(w.rotations[p]);
    out.pelvis_positions.push_back(w.positions_m[p]);
  }
  return out;
}

StyleTransferReport transfer_style(const SynthSkeleton& sk, const RangeOfMotion* range,
                                   const StyleModel& model, const StyleTransferParams& params,
                                   const std::vector<std::size_t>& key_frames,
                                   const std::string& content, std::vector<SynthFrame>& frames,
                                   double frame_time_s) {
  const std::vector<int> joints = checked_joints(sk, model, params, frames.size());
  StyleTransferReport report;
  report.params = params;
  std::vector<double> features;
  try {
    features = style_features(synth_style_motion(sk, frames, frame_time_s), model.joints);
  } catch (const InputError& e) {
    throw InputError("--style-model", 0, "the model cannot read the motion: " + e.detail());
  }
  std::vector<JointMap> maps = style_offsets(sk, model, params, joints, features, content, report);
  const std::vector<double> weight =
      key_weights(frames.size(), key_frames, frames_of(params.key_ease_s, frame_time_s));
  report.key_frames = static_cast<std::size_t>(
      std::count_if(weight.begin(), weight.end(), [](double w) { return w <= 0.0; }));
  const std::vector<SynthFrame> source = frames;
  std::vector<WorldPose> source_world(frames.size());
  for (std::size_t t = 0; t < frames.size(); ++t) synth_world_pose(sk, frames[t], source_world[t]);
  map_rotations(sk, range, maps, weight, source_world, frames);
  summarise_maps(sk, maps, report);
  const std::vector<LegChain> legs = synth_detail::leg_chains(sk);
  const std::size_t ease = frames_of(params.plant_ease_s, frame_time_s);
  const auto hold = hold_weights(sk, legs, source_world, params.plant_height_m, ease);
  const std::vector<double> drop = root_drops(sk, legs, hold, weight, source_world, frames, ease);
  for (std::size_t t = 0; t < frames.size(); ++t) {
    frames[t].root_position_m.y() -= drop[t];
    report.max_root_drop_m = std::max(report.max_root_drop_m, std::abs(drop[t]));
  }
  report.held_foot_frames = hold_feet(sk, legs, hold, weight, source, source_world, frames);
  return report;
}

}  // namespace mocap
