// The measures of a transition (measure_transition, motion_step_energies,
// end_steps_peak_angular_speed) and their per-step pieces (measures.hpp).
#include "measures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/dynamics/work_energy.hpp"
#include "mocap/synth/path_cache.hpp"
#include "transition_math.hpp"

namespace mocap {
namespace synth_detail {

Eigen::Vector3d contact_point(const SynthSkeleton& sk, const WorldPose& w, int j) {
  const auto ju = static_cast<std::size_t>(j);
  Eigen::Vector3d p = w.positions_m[ju];
  if (sk.model.tip_contacts[ju]) {
    const Eigen::Vector3d tip = p + w.rotations[ju] * sk.model.tips_local_m[ju];
    if (tip.y() < p.y()) p = tip;
  }
  return p;
}

StepSliding step_foot_sliding_split(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                                    double dt) {
  const EnergyParams& ep = sk.model.params;
  StepSliding out;
  for (int j : sk.foot_joints) {
    const Eigen::Vector3d pa = contact_point(sk, a, j), pb = contact_point(sk, b, j);
    const bool low = pa.y() - ep.ground_height_m <= ep.contact_height_m &&
                     pb.y() - ep.ground_height_m <= ep.contact_height_m;
    if (!low) continue;
    const double d = std::hypot(pb.x() - pa.x(), pb.z() - pa.z());
    out.total_m += d;
    if (d <= ep.contact_speed_mps * dt) out.slow_m += d;
  }
  return out;
}

double step_foot_sliding(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                         double dt) {
  return step_foot_sliding_split(sk, a, b, dt).total_m;
}

StepSkating step_skating(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b,
                         double dt) {
  const double ground = sk.model.params.ground_height_m;
  StepSkating out;
  out.airborne = !sk.foot_joints.empty();
  for (int j : sk.foot_joints) {
    const auto ju = static_cast<std::size_t>(j);
    const Eigen::Vector3d& pa = a.positions_m[ju];
    const Eigen::Vector3d& pb = b.positions_m[ju];
    if (pa.y() - ground < kSkatingHeightM || pb.y() - ground < kSkatingHeightM)
      out.airborne = false;
    const double v = low_foot_speed(pa, pb, dt, ground);
    if (v <= kSkatingSpeedMps) continue;
    ++out.joints;
    out.speed_sum += v;
  }
  return out;
}

void SkatingTally::add(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b, double dt) {
  const StepSkating s = step_skating(sk, a, b, dt);
  ++steps;
  skating_steps += s.joints > 0 ? 1 : 0;
  airborne_steps += s.airborne ? 1 : 0;
  joints += s.joints;
  speed_sum += s.speed_sum;
  const StepSliding sliding = step_foot_sliding_split(sk, a, b, dt);
  sliding_m += sliding.total_m;
  slow_sliding_m += sliding.slow_m;
}

std::size_t skating_steps(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  const SynthSkeleton& sk = *gap.skeleton;
  WorldPose a, b;
  synth_world_pose(sk, gap.start, a);
  SkatingTally tally;
  for (std::size_t k = 0; k <= frames.size(); ++k) {
    synth_world_pose(sk, k < frames.size() ? frames[k] : gap.goal, b);
    tally.add(sk, a, b, gap.frame_time_s);
    std::swap(a, b);
  }
  return tally.skating_steps;
}

std::size_t frame_range_violations(const GapProblem& gap, const SynthFrame& f) {
  std::size_t v = 0;
  if (gap.range)
    for (std::size_t j = 0; j < f.local_rotations.size(); ++j)
      if (!within_range(*gap.skeleton, *gap.range, static_cast<int>(j), f.local_rotations[j])) ++v;
  return v;
}

namespace {

// How far (degrees) angle v, at its 360-degree turn nearest [lo, hi], lies
// outside the range (0 inside); `at` gets that turn's value.
double outside_range_deg(double v, double lo, double hi, double& at) {
  double best = std::numeric_limits<double>::infinity();
  for (int k = -1; k <= 1; ++k) {
    const double x = v + 360.0 * k;
    const double d = x < lo ? lo - x : (x > hi ? x - hi : 0.0);
    if (d < best) {
      best = d;
      at = x;
    }
  }
  return best;
}

// Joint j's rotation against its range: of the two Euler solutions
// (within_range's), the one whose worst channel is nearest the range, and
// that channel.
RangeViolation name_range_violation(const SynthSkeleton& sk, const RangeOfMotion& rom,
                                    std::size_t j, const Eigen::Quaterniond& local) {
  const auto& axes = sk.skeleton.channels[j].rotation_axis;
  const Eigen::Vector3d e = quaternion_to_euler(local, axes);
  const Eigen::Vector3d alt(e[0] + 180.0, 180.0 - e[1], e[2] + 180.0);
  RangeViolation best;
  best.excess_deg = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d* v : {&e, &alt}) {
    RangeViolation worst;
    worst.excess_deg = -1.0;
    for (std::size_t k = 0; k < 3; ++k) {
      double at = 0.0;
      const double lo = rom.min_deg[j][k], hi = rom.max_deg[j][k];
      const double d = outside_range_deg((*v)[static_cast<Eigen::Index>(k)], lo, hi, at);
      if (d <= worst.excess_deg) continue;
      worst.channel = std::string(1, static_cast<char>('X' + axes[k])) + "rotation";
      worst.min_deg = lo, worst.max_deg = hi, worst.value_deg = at, worst.excess_deg = d;
    }
    if (worst.excess_deg < best.excess_deg) best = worst;
  }
  best.joint = sk.skeleton.names[j];
  return best;
}

}  // namespace

std::vector<RangeViolation> range_violation_list(const GapProblem& gap,
                                                 const std::vector<SynthFrame>& frames) {
  std::vector<RangeViolation> out;
  if (!gap.range) return out;
  const SynthSkeleton& sk = *gap.skeleton;
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (std::size_t j = 0; j < frames[f].local_rotations.size(); ++j) {
      const Eigen::Quaterniond& q = frames[f].local_rotations[j];
      if (within_range(sk, *gap.range, static_cast<int>(j), q)) continue;
      out.push_back(name_range_violation(sk, *gap.range, j, q));
      out.back().frame = f;
    }
  return out;
}

std::size_t count_range_violations(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  std::size_t v = 0;
  for (const SynthFrame& f : frames) v += frame_range_violations(gap, f);
  return v;
}

double step_peak_angular_speed(const GapProblem& gap, const SynthFrame& a, const SynthFrame& b) {
  const SynthSkeleton& sk = *gap.skeleton;
  double peak = 0.0;
  for (std::size_t j = 0; j < a.local_rotations.size(); ++j) {
    if (sk.is_root_chain[j] && static_cast<int>(j) != sk.root_joint) continue;
    peak = std::max(
        peak, rotation_step(a.local_rotations[j], b.local_rotations[j]).norm() / gap.frame_time_s);
  }
  return peak;
}

double peak_angular_speed(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  double peak = 0.0;
  const SynthFrame* prev = &gap.start;
  for (const SynthFrame& f : frames) {
    peak = std::max(peak, step_peak_angular_speed(gap, *prev, f));
    prev = &f;
  }
  return std::max(peak, step_peak_angular_speed(gap, *prev, gap.goal));
}

}  // namespace synth_detail

using namespace synth_detail;

double end_steps_peak_angular_speed(const GapProblem& gap) {
  check_gap(gap);
  return std::max(step_peak_angular_speed(gap, gap.before, gap.start),
                  step_peak_angular_speed(gap, gap.goal, gap.after));
}

TransitionMeasures measure_transition(const GapProblem& gap,
                                      const std::vector<SynthFrame>& frames) {
  check_gap(gap);
  const SynthSkeleton& sk = *gap.skeleton;
  const double dt = gap.frame_time_s;
  const std::size_t n = sk.joint_count();
  std::vector<const SynthFrame*> seq;
  seq.push_back(&gap.before);
  seq.push_back(&gap.start);
  for (const SynthFrame& f : frames) {
    if (f.local_rotations.size() != n)
      throw std::invalid_argument("transition frame does not fit the skeleton");
    seq.push_back(&f);
  }
  seq.push_back(&gap.goal);
  seq.push_back(&gap.after);
  PathCache path;
  path.build_states(gap, frames);
  const std::size_t L = path.L;
  const std::vector<WorldPose>& world = path.world;
  const std::vector<BodyState>& states = path.states;
  const std::vector<NewtonEulerData>& ids = path.ids;
  TransitionMeasures m;
  m.frames = frames.size();
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  TransitionMeasures::EnergySplit& split = m.energy_split;
  SkatingTally skating;
  WorkEnergyTerms w_terms;
  std::size_t no_contact = ids[1].contact_count == 0 ? 1 : 0;
  for (std::size_t k = 1; k + 2 < L; ++k) {
    const double g = full_energy(sk.model, states[k].view(), states[k + 1].view(), dt, ids[k],
                                 ids[k + 1], ws, &terms);
    m.work_energy_J += work_energy(sk.model, states[k].view(), states[k + 1].view(), dt, ids[k],
                                   ids[k + 1], {}, &w_terms);
    m.unsupported_J += w_terms.unsupported_J;
    if (ids[k + 1].contact_count == 0) ++no_contact;
    m.step_energies_J.push_back(g);
    m.energy_J += g;
    split.h_J += terms.h.total();
    split.adjacent_J +=
        std::accumulate(terms.adjacent_work_J.begin(), terms.adjacent_work_J.end(), 0.0);
    split.contact_J +=
        std::accumulate(terms.contact_work_J.begin(), terms.contact_work_J.end(), 0.0);
    split.joint_J += std::accumulate(terms.joint_work_J.begin(), terms.joint_work_J.end(), 0.0);
    split.residual_work_J += terms.residual_work_J;
    split.residual_impulse_J += terms.residual_impulse_J;
    m.approximate_energy_J +=
        approximate_energy(sk.model, states[k].view(), states[k + 1].view(), dt);
    skating.add(sk, world[k], world[k + 1], dt);
    m.peak_angular_speed_radps =
        std::max(m.peak_angular_speed_radps, step_peak_angular_speed(gap, *seq[k], *seq[k + 1]));
  }
  m.no_contact_ratio = static_cast<double>(no_contact) / static_cast<double>(L - 2);
  m.range_violation_list = range_violation_list(gap, frames);
  m.range_violations = m.range_violation_list.size();
  m.foot_sliding_m = skating.sliding_m;
  m.foot_sliding_slow_m = skating.slow_sliding_m;
  m.skating_ratio = skating.ratio();
  m.skating_speed_mps = skating.mean_speed();
  m.airborne_ratio = skating.airborne_ratio();
  return m;
}

MotionMeasures measure_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                              double frame_time_s) {
  MotionMeasures m;
  if (frames.size() < 2) return m;
  WorldPose a, b;
  synth_world_pose(sk, frames[0], a);
  SkatingTally skating;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    synth_world_pose(sk, frames[k], b);
    skating.add(sk, a, b, frame_time_s);
    std::swap(a, b);
  }
  m.foot_sliding_m = skating.sliding_m;
  m.foot_sliding_slow_m = skating.slow_sliding_m;
  m.skating_ratio = skating.ratio();
  m.skating_speed_mps = skating.mean_speed();
  m.airborne_ratio = skating.airborne_ratio();
  return m;
}

namespace synth_detail {
namespace {

// The states of a whole motion (rates by central differences, one-sided at
// the ends) and their inverse dynamics (contacts included).
struct MotionDynamics {
  std::vector<WorldPose> world;
  std::vector<BodyState> states;
  std::vector<NewtonEulerData> ids;
};
MotionDynamics motion_dynamics(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                               double frame_time_s) {
  const std::size_t L = frames.size();
  MotionDynamics d{std::vector<WorldPose>(L), std::vector<BodyState>(L),
                   std::vector<NewtonEulerData>(L)};
  for (std::size_t k = 0; k < L; ++k) synth_world_pose(sk, frames[k], d.world[k]);
  for (std::size_t k = 0; k < L; ++k) {
    PoseView p{}, x{};
    if (k > 0) p = pose_view(d.world[k - 1]);
    if (k + 1 < L) x = pose_view(d.world[k + 1]);
    sequence_state(sk.model, k > 0 ? &p : nullptr, pose_view(d.world[k]), k + 1 < L ? &x : nullptr,
                   frame_time_s, d.states[k]);
    inverse_dynamics(sk.model, d.states[k].view(), d.ids[k]);
  }
  return d;
}

}  // namespace

std::size_t FootContactRow::contact_frames() const {
  return static_cast<std::size_t>(std::count(states.begin(), states.end(), 'c'));
}

std::vector<FootContactRow> foot_contact_rows(const SynthSkeleton& sk,
                                              const std::vector<SynthFrame>& frames,
                                              double frame_time_s) {
  std::vector<FootContactRow> rows;
  if (frames.size() < 2) return rows;
  const MotionDynamics d = motion_dynamics(sk, frames, frame_time_s);
  const EnergyParams& ep = sk.model.params;
  for (int j : sk.foot_joints) {
    const auto ju = static_cast<std::size_t>(j);
    FootContactRow row{j, sk.skeleton.names[ju],
                       sk.model.tip_contacts[ju] ? "joint origin or bone tip" : "joint origin",
                       std::string(frames.size(), '.'), std::numeric_limits<double>::infinity()};
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const double height = contact_point(sk, d.world[f], j).y() - ep.ground_height_m;
      row.lowest_m = std::min(row.lowest_m, height);
      if (d.ids[f].in_contact[ju])
        row.states[f] = 'c';
      else if (height <= ep.contact_height_m)
        row.states[f] = 's';
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace synth_detail

std::vector<double> motion_step_energies(const SynthSkeleton& sk,
                                         const std::vector<SynthFrame>& frames,
                                         double frame_time_s) {
  const std::size_t L = frames.size();
  std::vector<double> out;
  if (L < 2) return out;
  const synth_detail::MotionDynamics d = synth_detail::motion_dynamics(sk, frames, frame_time_s);
  const std::vector<BodyState>& states = d.states;
  const std::vector<NewtonEulerData>& ids = d.ids;
  NewtonEulerWorkspace ws;
  for (std::size_t k = 0; k + 1 < L; ++k)
    out.push_back(full_energy(sk.model, states[k].view(), states[k + 1].view(), frame_time_s,
                              ids[k], ids[k + 1], ws));
  return out;
}

}  // namespace mocap
