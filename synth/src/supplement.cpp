// Supplementation of a gap: the A*-based search of the paper's figure 4 and
// the slerp / inertialization baselines, plus the measures of a transition.
// The method and every choice are documented in docs/synthesis.md.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "mocap/energy.hpp"
#include "mocap/newton_euler.hpp"
#include "mocap/synth.hpp"

namespace mocap {
namespace {

Eigen::Quaterniond quat_exp(const Eigen::Vector3d& v) {
  const double a = v.norm();
  if (a < 1e-12) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, v / a));
}
// log(a^-1 b) in a's local frame (rotation vector).
Eigen::Vector3d local_log(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return rotation_vector((a.conjugate() * b).normalized());
}

void check_gap(const GapProblem& gap) {
  if (gap.skeleton == nullptr) throw std::invalid_argument("gap: no skeleton");
  if (!(gap.frame_time_s > 0.0) || !std::isfinite(gap.frame_time_s))
    throw std::invalid_argument("gap: frame time must be > 0");
  const std::size_t n = gap.skeleton->joint_count();
  for (const SynthFrame* f : {&gap.before, &gap.start, &gap.goal, &gap.after})
    if (f->local_rotations.size() != n)
      throw std::invalid_argument("gap: frame has " + std::to_string(f->local_rotations.size()) +
                                  " joint rotations, the skeleton " + std::to_string(n));
  if (gap.range != nullptr && gap.range->has_range.size() != n)
    throw std::invalid_argument("gap: range of motion does not fit the skeleton");
}

PoseView view_of(const WorldPose& w) { return pose_view(w); }

// Energies of steps between world poses with rates from their neighbours.
struct StepEvaluator {
  const SynthSkeleton& sk;
  double dt;
  BodyState sa, sb;
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  std::size_t evaluations = 0;

  StepEvaluator(const SynthSkeleton& s, double frame_time) : sk(s), dt(frame_time) {}

  // g(A -> B): A's rates from (a_prev, A, B), B's from (A, B, b_next).
  double g(const WorldPose* a_prev, const WorldPose& a, const WorldPose& b, const WorldPose* b_next,
           bool want_terms) {
    const PoseView pa = view_of(a), pb = view_of(b);
    PoseView pap{}, pbn{};
    if (a_prev) pap = view_of(*a_prev);
    if (b_next) pbn = view_of(*b_next);
    sequence_state(sk.model, a_prev ? &pap : nullptr, pa, &pb, dt, sa);
    sequence_state(sk.model, &pa, pb, b_next ? &pbn : nullptr, dt, sb);
    ++evaluations;
    return full_energy(sk.model, sa.view(), sb.view(), dt, ws, want_terms ? &terms : nullptr);
  }
};

// One step of the cubic Hermite path from (x0, v0) to (x1, v1) over duration T, at time t.
template <class V>
V hermite(const V& x0, const V& v0, const V& x1, const V& v1, double T, double t) {
  const double s = t / T, s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * T * v0 + (-2 * s3 + 3 * s2) * x1 +
         (s3 - s2) * T * v1;
}

// Base proposal: one Hermite step toward the goal over `remaining` steps.
SynthFrame hermite_step(const GapProblem& gap, const SynthFrame& prev, const SynthFrame& cur,
                        std::size_t remaining) {
  const double dt = gap.frame_time_s, T = static_cast<double>(remaining) * dt;
  SynthFrame out;
  const Eigen::Vector3d v0 = (cur.root_position_m - prev.root_position_m) / dt;
  const Eigen::Vector3d v1 = (gap.after.root_position_m - gap.goal.root_position_m) / dt;
  out.root_position_m = hermite(cur.root_position_m, v0, gap.goal.root_position_m, v1, T, dt);
  const std::size_t n = cur.local_rotations.size();
  out.local_rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Quaterniond& qg = gap.goal.local_rotations[j];
    const Eigen::Vector3d x0 = local_log(qg, cur.local_rotations[j]);
    const Eigen::Vector3d xp = local_log(qg, prev.local_rotations[j]);
    const Eigen::Vector3d w0 = (x0 - xp) / dt;
    const Eigen::Vector3d w1 = local_log(qg, gap.after.local_rotations[j]) / dt;
    const Eigen::Vector3d x = hermite(x0, w0, Eigen::Vector3d::Zero().eval(), w1, T, dt);
    out.local_rotations[j] = (qg * quat_exp(x)).normalized();
  }
  return out;
}

// The geodesic step: root linear, joints slerp, 1 / remaining of the way.
SynthFrame geodesic_step(const GapProblem& gap, const SynthFrame& cur, std::size_t remaining) {
  const double s = 1.0 / static_cast<double>(remaining);
  SynthFrame out;
  out.root_position_m = (1.0 - s) * cur.root_position_m + s * gap.goal.root_position_m;
  const std::size_t n = cur.local_rotations.size();
  out.local_rotations.resize(n);
  for (std::size_t j = 0; j < n; ++j)
    out.local_rotations[j] = cur.local_rotations[j].slerp(s, gap.goal.local_rotations[j]).normalized();
  return out;
}

// Bollo's inertialization decay of a scalar offset x0 with rate v0 over t1, at t.
double inertialize_decay(double x0, double v0, double t1, double t) {
  if (x0 == 0.0 && v0 == 0.0) return 0.0;
  if (x0 > 0.0 ? v0 > 0.0 : v0 < 0.0) v0 = 0.0;  // never push the offset further out
  if (v0 != 0.0) t1 = std::min(t1, -5.0 * x0 / v0);
  if (t >= t1 || t1 <= 0.0) return 0.0;
  const double t12 = t1 * t1;
  const double a0 = (-8.0 * v0 * t1 - 20.0 * x0) / t12;
  const double A = -(a0 * t12 + 6.0 * v0 * t1 + 12.0 * x0) / (2.0 * t12 * t12 * t1);
  const double B = (3.0 * a0 * t12 + 16.0 * v0 * t1 + 30.0 * x0) / (2.0 * t12 * t12);
  const double C = -(3.0 * a0 * t12 + 12.0 * v0 * t1 + 20.0 * x0) / (2.0 * t12 * t1);
  const double t2 = t * t, t3 = t2 * t;
  return A * t3 * t2 + B * t2 * t2 + C * t3 + 0.5 * a0 * t2 + v0 * t + x0;
}
Eigen::Vector3d inertialize_decay(const Eigen::Vector3d& x0, const Eigen::Vector3d& v0, double t1,
                                  double t) {
  const double m = x0.norm();
  if (m < 1e-12) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d dir = x0 / m;
  return dir * inertialize_decay(m, v0.dot(dir), t1, t);
}

// Lowest contact point of a foot joint (origin, or bone tip when it is one).
Eigen::Vector3d contact_point(const SynthSkeleton& sk, const WorldPose& w, int j) {
  const auto ju = static_cast<std::size_t>(j);
  Eigen::Vector3d p = w.positions_m[ju];
  if (sk.model.tip_contacts[ju]) {
    const Eigen::Vector3d tip = p + w.rotations[ju] * sk.model.tips_local_m[ju];
    if (tip.y() < p.y()) p = tip;
  }
  return p;
}

double step_foot_sliding(const SynthSkeleton& sk, const WorldPose& a, const WorldPose& b, double dt) {
  const EnergyParams& ep = sk.model.params;
  double sum = 0.0;
  for (int j : sk.foot_joints) {
    const Eigen::Vector3d pa = contact_point(sk, a, j), pb = contact_point(sk, b, j);
    const bool low = pa.y() - ep.ground_height_m <= ep.contact_height_m &&
                     pb.y() - ep.ground_height_m <= ep.contact_height_m;
    const Eigen::Vector3d d = pb - pa;
    if (low && d.norm() / dt <= ep.contact_speed_mps) sum += std::hypot(d.x(), d.z());
  }
  return sum;
}

// A leg for foot planting: hip, knee and ankle joints (the ankle a foot joint
// whose parent is not one) and the foot joints it carries (ankle, toes).
struct LegChain {
  int hip = -1, knee = -1, ankle = -1;
  std::vector<int> feet;
};

std::vector<LegChain> leg_chains(const SynthSkeleton& sk) {
  std::vector<LegChain> legs;
  const auto is_foot = [&](int j) {
    return std::find(sk.foot_joints.begin(), sk.foot_joints.end(), j) != sk.foot_joints.end();
  };
  for (int j : sk.foot_joints) {
    const int knee = sk.skeleton.parents[static_cast<std::size_t>(j)];
    if (knee < 0 || is_foot(knee)) continue;
    const int hip = sk.skeleton.parents[static_cast<std::size_t>(knee)];
    if (hip < 0 || sk.is_root_chain[static_cast<std::size_t>(hip)] ||
        sk.is_root_chain[static_cast<std::size_t>(knee)])
      continue;
    LegChain leg{hip, knee, j, {}};
    for (int f : sk.foot_joints)
      for (int a = f; a >= 0; a = sk.skeleton.parents[static_cast<std::size_t>(a)])
        if (a == j) {
          leg.feet.push_back(f);
          break;
        }
    legs.push_back(std::move(leg));
  }
  return legs;
}

// Turns the leg of `f` so that its ankle lies at `target` with the world
// rotation `target_rotation` (two-bone inverse kinematics: the knee angle
// gives the hip-ankle distance, clamped to the reachable range; the hip
// turns the hip-ankle line onto the target; the ankle takes the rotation),
// each joint then clamped to the range of motion. `w` is scratch. False when
// the leg is straight (no knee plane) or degenerate.
bool plant_leg(const SynthSkeleton& sk, const RangeOfMotion* range, const LegChain& leg,
               const Eigen::Vector3d& target, const Eigen::Quaterniond& target_rotation, SynthFrame& f,
               WorldPose& w) {
  const auto hip = static_cast<std::size_t>(leg.hip), knee = static_cast<std::size_t>(leg.knee),
             ankle = static_cast<std::size_t>(leg.ankle);
  synth_world_pose(sk, f, w);
  const Eigen::Vector3d a = w.positions_m[hip], b = w.positions_m[knee], c = w.positions_m[ankle];
  const double lab = (b - a).norm(), lcb = (c - b).norm();
  if (lab < 1e-6 || lcb < 1e-6) return false;
  const Eigen::Vector3d bend = (a - b).cross(c - b);
  if (bend.norm() < 1e-9 * lab * lcb) return false;
  const double lat = std::clamp((target - a).norm(), std::abs(lab - lcb) + 1e-4, lab + lcb - 1e-4);
  const double angle0 = std::acos(std::clamp((a - b).normalized().dot((c - b).normalized()), -1.0, 1.0));
  const double angle1 = std::acos(std::clamp((lab * lab + lcb * lcb - lat * lat) / (2.0 * lab * lcb), -1.0, 1.0));
  const Eigen::Quaterniond rk(Eigen::AngleAxisd(angle1 - angle0, bend.normalized()));
  f.local_rotations[knee] = (f.local_rotations[knee] * (w.rotations[knee].conjugate() * rk * w.rotations[knee])).normalized();
  synth_world_pose(sk, f, w);
  const Eigen::Quaterniond rh =
      Eigen::Quaterniond::FromTwoVectors(w.positions_m[ankle] - w.positions_m[hip], target - w.positions_m[hip]);
  f.local_rotations[hip] = (f.local_rotations[hip] * (w.rotations[hip].conjugate() * rh * w.rotations[hip])).normalized();
  synth_world_pose(sk, f, w);
  f.local_rotations[ankle] = (w.rotations[knee].conjugate() * target_rotation).normalized();
  if (range)
    for (std::size_t j : {hip, knee, ankle}) f.local_rotations[j] = clamp_to_range(sk, *range, static_cast<int>(j), f.local_rotations[j]);
  return true;
}

// (frame, joint) pairs of `frames` outside the gap's range of motion (0
// without a range).
std::size_t frame_range_violations(const GapProblem& gap, const SynthFrame& f) {
  std::size_t v = 0;
  if (gap.range)
    for (std::size_t j = 0; j < f.local_rotations.size(); ++j)
      if (!within_range(*gap.skeleton, *gap.range, static_cast<int>(j), f.local_rotations[j])) ++v;
  return v;
}
std::size_t count_range_violations(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  std::size_t v = 0;
  for (const SynthFrame& f : frames) v += frame_range_violations(gap, f);
  return v;
}

// Largest local joint angular speed of the step a -> b (the dummies above
// the root excepted), rad/s: measure_transition's peak is the largest over
// the transition's steps.
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

// That peak over S_0 -> frames... -> S_G.
double peak_angular_speed(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  double peak = 0.0;
  const SynthFrame* prev = &gap.start;
  for (const SynthFrame& f : frames) {
    peak = std::max(peak, step_peak_angular_speed(gap, *prev, f));
    prev = &f;
  }
  return std::max(peak, step_peak_angular_speed(gap, *prev, gap.goal));
}

// The sequence S_-1, S_0, frames..., S_G, S_G+1 with its world poses, states
// (rates by central differences), inverse dynamics and the g of every step
// S_0 -> ... -> S_G: g of a transition (measure_transition's energy_J
// without the other measures), and what the refinement's finite
// differences recompute locally.
struct PathCache {
  std::vector<WorldPose> world;
  std::vector<BodyState> states;
  std::vector<NewtonEulerData> ids;
  std::vector<double> steps;  // steps[k]: g(state k -> state k + 1), k = 1 .. L-3
  NewtonEulerWorkspace ws;
  std::size_t L = 0;
  double smoothing_J = 0.0;  // > 0: the steps hold the smoothed g (NewtonEulerWorkspace)
  // Scratch of delta() (one per thread: delta() only reads the cache),
  // sized for the longest run of changed frames seen.
  struct DeltaScratch {
    std::vector<WorldPose> w_changed;         // the changed frames' poses
    std::vector<BodyState> s_changed;         // their states and the two beside them
    std::vector<NewtonEulerData> id_changed;  // (count + 2 of each)
    NewtonEulerWorkspace ws;
    std::vector<double> steps_changed;  // the recomputed steps, k0 .. k1
    void reserve(std::size_t count) {
      if (w_changed.size() < count) w_changed.resize(count);
      if (s_changed.size() < count + 2) s_changed.resize(count + 2);
      if (id_changed.size() < count + 2) id_changed.resize(count + 2);
      if (steps_changed.size() < count + 3) steps_changed.resize(count + 3);
    }
  };

  // The world poses of the sequence only (all foot_sliding() needs).
  void build_poses(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
    const SynthSkeleton& sk = *gap.skeleton;
    L = frames.size() + 4;
    if (world.size() < L) world.resize(L);
    synth_world_pose(sk, gap.before, world[0]);
    synth_world_pose(sk, gap.start, world[1]);
    for (std::size_t i = 0; i < frames.size(); ++i) synth_world_pose(sk, frames[i], world[2 + i]);
    synth_world_pose(sk, gap.goal, world[L - 2]);
    synth_world_pose(sk, gap.after, world[L - 1]);
  }

  // The world poses, then states 1 .. L-2 with central rates and their
  // inverse dynamics (what measure_transition also needs).
  void build_states(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
    build_poses(gap, frames);
    if (states.size() < L) states.resize(L);
    if (ids.size() < L) ids.resize(L);
    for (std::size_t k = 1; k + 1 < L; ++k) {
      state_at(gap, k, 0, 0, nullptr, states[k]);
      inverse_dynamics(gap.skeleton->model, states[k].view(), ids[k]);
    }
  }

  // Builds the cache for `frames`; returns the transition's g.
  double build(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
    const SynthSkeleton& sk = *gap.skeleton;
    build_states(gap, frames);
    steps.assign(L, 0.0);
    ws.smoothing_J = smoothing_J;
    double g = 0.0;
    for (std::size_t k = 1; k + 2 < L; ++k) {
      steps[k] = full_energy(sk.model, states[k].view(), states[k + 1].view(), gap.frame_time_s,
                             ids[k], ids[k + 1], ws);
      g += steps[k];
    }
    return g;
  }

  // Foot sliding of the cached transition (measure_transition's).
  double foot_sliding(const GapProblem& gap) const { return foot_sliding_with(gap, 0, 0, nullptr); }

  // The same sum with changed[0 .. count) in place of the poses at sequence
  // indices first .. first + count - 1 (the same additions in the same
  // order: what foot_sliding() gives once those poses are applied).
  double foot_sliding_with(const GapProblem& gap, std::size_t first, std::size_t count,
                           const WorldPose* changed) const {
    const auto pose = [&](std::size_t q) -> const WorldPose& {
      return q >= first && q < first + count ? changed[q - first] : world[q];
    };
    double sum = 0.0;
    for (std::size_t k = 1; k + 2 < L; ++k)
      sum += step_foot_sliding(*gap.skeleton, pose(k), pose(k + 1), gap.frame_time_s);
    return sum;
  }

  // Change of the transition's g when inserted frames i .. i + count - 1
  // become changed[0 .. count): only states i+1 .. i+count+2 (theirs and
  // their neighbours' rates) and the steps touching them are recomputed.
  double delta(const GapProblem& gap, std::size_t i, std::size_t count, const SynthFrame* changed,
               DeltaScratch& sc) const {
    sc.reserve(count);
    sc.ws.smoothing_J = smoothing_J;
    const SynthSkeleton& sk = *gap.skeleton;
    const std::size_t s0 = i + 2, s1 = s0 + count - 1;  // sequence indices of the frames
    for (std::size_t q = 0; q < count; ++q) synth_world_pose(sk, changed[q], sc.w_changed[q]);
    for (std::size_t d = 0; d < count + 2; ++d) {
      state_at(gap, s0 - 1 + d, s0, count, sc.w_changed.data(), sc.s_changed[d]);
      inverse_dynamics(sk.model, sc.s_changed[d].view(), sc.id_changed[d]);
    }
    const auto changed_state = [&](std::size_t k) { return k + 1 >= s0 && k <= s1 + 1; };
    const std::size_t k0 = std::max<std::size_t>(1, s0 - 2), k1 = std::min(L - 3, s1 + 1);
    double before = 0.0, after = 0.0;
    for (std::size_t k = k0; k <= k1; ++k) {
      before += steps[k];
      const BodyState& a = changed_state(k) ? sc.s_changed[k + 1 - s0] : states[k];
      const BodyState& b = changed_state(k + 1) ? sc.s_changed[k + 2 - s0] : states[k + 1];
      const NewtonEulerData& ia = changed_state(k) ? sc.id_changed[k + 1 - s0] : ids[k];
      const NewtonEulerData& ib = changed_state(k + 1) ? sc.id_changed[k + 2 - s0] : ids[k + 1];
      sc.steps_changed[k - k0] =
          full_energy(sk.model, a.view(), b.view(), gap.frame_time_s, ia, ib, sc.ws);
      after += sc.steps_changed[k - k0];
    }
    return after - before;
  }

  // Makes the last delta() for inserted frames i .. i + count - 1 (computed
  // into `sc`) the cached path: their poses, the states and the steps
  // touching them (exact steps: the cache must not be smoothed).
  void apply(std::size_t i, std::size_t count, DeltaScratch& sc) {
    const std::size_t s0 = i + 2, s1 = s0 + count - 1;
    for (std::size_t q = 0; q < count; ++q) std::swap(world[s0 + q], sc.w_changed[q]);
    for (std::size_t d = 0; d < count + 2; ++d) {
      std::swap(states[s0 - 1 + d], sc.s_changed[d]);
      std::swap(ids[s0 - 1 + d], sc.id_changed[d]);
    }
    const std::size_t k0 = std::max<std::size_t>(1, s0 - 2), k1 = std::min(L - 3, s1 + 1);
    for (std::size_t k = k0; k <= k1; ++k) steps[k] = sc.steps_changed[k - k0];
  }

  // State k of the sequence, its rates by central differences, with
  // changed[0 .. count) in place of the world poses at first ..
  // first + count - 1.
  void state_at(const GapProblem& gap, std::size_t k, std::size_t first, std::size_t count,
                const WorldPose* changed, BodyState& out) const {
    const auto pose = [&](std::size_t q) {
      return pose_view(q >= first && q < first + count ? changed[q - first] : world[q]);
    };
    const PoseView p = pose(k - 1), c = pose(k), x = pose(k + 1);
    sequence_state(gap.skeleton->model, &p, c, &x, gap.frame_time_s, out);
  }
};

}  // namespace

const char* transition_method_name(TransitionMethod m) {
  switch (m) {
    case TransitionMethod::astar: return "astar";
    case TransitionMethod::slerp: return "slerp";
    case TransitionMethod::inertialize: return "inertialize";
  }
  return "?";
}

std::size_t estimate_transition_frames(const GapProblem& gap, const SupplementParams& params) {
  check_gap(gap);
  double angle = 0.0;
  const std::size_t n = gap.skeleton->joint_count();
  for (std::size_t j = 0; j < n; ++j)
    angle = std::max(angle, local_log(gap.start.local_rotations[j], gap.goal.local_rotations[j]).norm());
  const double dist = (gap.goal.root_position_m - gap.start.root_position_m).norm();
  const double t = std::max({angle / params.ref_angular_speed_radps, dist / params.ref_speed_mps,
                             params.min_duration_s});
  const auto frames = static_cast<std::size_t>(std::ceil(t / gap.frame_time_s));
  return std::clamp<std::size_t>(frames, 1, std::max<std::size_t>(1, params.max_states));
}

std::size_t choose_transition_frames(const GapProblem& gap, const SupplementParams& params) {
  const std::size_t estimate = estimate_transition_frames(gap, params);
  if (!params.choose_length) return estimate;
  const std::size_t cap = std::max<std::size_t>(1, params.max_states);
  const std::size_t hi = std::min(cap, 2 * estimate + 2);
  // Coarse grid (steps growing by ~20%), then every length between the
  // best grid point's neighbours; ties go to the shorter length.
  std::vector<std::size_t> grid{1};
  for (std::size_t m = 2; m < hi; m = std::max(m + 1, m + m / 5)) grid.push_back(m);
  if (hi > 1) grid.push_back(hi);
  PathCache sc;
  std::vector<double> energy(hi + 1, -1.0);
  auto eval = [&](std::size_t m) {
    if (energy[m] < 0.0) energy[m] = sc.build(gap, slerp_transition(gap, m));
    return energy[m];
  };
  std::size_t best = grid[0];
  std::size_t at = 0;
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (eval(grid[i]) < eval(best)) {
      best = grid[i];
      at = i;
    }
  const std::size_t lo2 = at > 0 ? grid[at - 1] + 1 : 1;
  const std::size_t hi2 = at + 1 < grid.size() ? grid[at + 1] - 1 : hi;
  for (std::size_t m = lo2; m <= hi2; ++m)
    if (eval(m) < eval(best)) best = m;
  return best;
}

namespace {

// The search of figure 4 planned over `estimate` inserted frames.
std::vector<SynthFrame> astar_search(const GapProblem& gap, const SupplementParams& params,
                                     std::size_t estimate, SupplementStats* stats) {
  const SynthSkeleton& sk = *gap.skeleton;
  const double dt = gap.frame_time_s;
  const std::size_t n = sk.joint_count();
  StepEvaluator ev(sk, dt);
  WorldPose w_goal, w_after, w_prev, w_cur, w_cand;
  synth_world_pose(sk, gap.goal, w_goal);
  synth_world_pose(sk, gap.after, w_after);
  // Neighbours of each joint (parent and children that carry rotations).
  std::vector<std::vector<int>> adjacent(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = sk.skeleton.parents[j];
    if (p >= 0 && (!sk.is_root_chain[static_cast<std::size_t>(p)] || p == sk.root_joint))
      adjacent[j].push_back(p);
    for (int c : sk.skeleton.children(static_cast<int>(j))) adjacent[j].push_back(c);
  }

  const std::vector<LegChain> legs = params.plant_feet ? leg_chains(sk) : std::vector<LegChain>{};
  WorldPose w_ik;
  // CLOSED: accepted states (the path); OPEN: this iteration's candidates.
  std::vector<SynthFrame> closed;
  SynthFrame pprev, prev = gap.before, cur = gap.start;
  bool have_pprev = false;
  WorldPose w_pprev;
  std::string reason = "max_states";
  std::size_t iterations = 0;
  std::vector<std::pair<double, int>> costs;
  std::vector<int> varied;
  std::vector<WorldPose> seq_world;
  std::vector<BodyState> seq_states;
  std::vector<NewtonEulerData> seq_ids;
  SynthFrame roll_frame;
  double window_slide = 0.0;
  for (;;) {
    if (have_pprev) synth_world_pose(sk, pprev, w_pprev);
    synth_world_pose(sk, prev, w_prev);
    synth_world_pose(sk, cur, w_cur);
    // Stop: the step cost to the goal is below T_c.
    const double to_goal = ev.g(&w_prev, w_cur, w_goal, &w_after, false);
    if (to_goal < params.cost_threshold_J) {
      reason = "threshold";
      break;
    }
    if (closed.size() >= params.max_states) break;
    if (closed.size() >= estimate) {
      reason = "horizon";
      break;
    }
    ++iterations;
    const std::size_t remaining = std::max<std::size_t>(2, estimate + 1 - std::min(estimate, closed.size()));
    // f(C) = g over the steps C changes (prev -> cur -> C -> D_1, rates by
    // central differences) + the estimate of the rest: the geodesic
    // completion D_1 .. D_{r-2} -> S_G from C (the slerp of the remaining
    // steps), each of its steps costed by h (the paper's h(S1' -> Sf) taken
    // step by step along the straight completion), or by g when
    // params.exact_lookahead.
    const std::size_t rollout = remaining - 2;
    auto score = [&](const SynthFrame& c) {
      // Pose list: prev, cur, C, D_1..D_k, goal, after.
      const std::size_t L = 3 + rollout + 2;
      if (seq_world.size() < L) seq_world.resize(L);
      if (seq_states.size() < L) seq_states.resize(L);
      if (seq_ids.size() < L) seq_ids.resize(L);
      std::vector<const WorldPose*> P(L);
      P[0] = &w_prev;
      P[1] = &w_cur;
      synth_world_pose(sk, c, seq_world[2]);
      P[2] = &seq_world[2];
      for (std::size_t k = 1; k <= rollout; ++k) {
        const double s = static_cast<double>(k) / static_cast<double>(rollout + 1);
        SynthFrame& d = roll_frame;
        d.root_position_m = (1.0 - s) * c.root_position_m + s * gap.goal.root_position_m;
        d.local_rotations.resize(n);
        for (std::size_t j = 0; j < n; ++j)
          d.local_rotations[j] = c.local_rotations[j].slerp(s, gap.goal.local_rotations[j]).normalized();
        synth_world_pose(sk, d, seq_world[2 + k]);
        P[2 + k] = &seq_world[2 + k];
      }
      P[L - 2] = &w_goal;
      P[L - 1] = &w_after;
      // States 0 .. L-2 (prev's predecessor: pprev, when there is one).
      for (std::size_t k = 0; k + 1 < L; ++k) {
        const PoseView pc = view_of(*P[k]), px = view_of(*P[k + 1]);
        PoseView pp{};
        const bool has_prev = k > 0 || have_pprev;
        if (k > 0) pp = view_of(*P[k - 1]);
        else if (have_pprev) pp = view_of(w_pprev);
        sequence_state(sk.model, has_prev ? &pp : nullptr, pc, &px, dt, seq_states[k]);
      }
      // Foot sliding over the steps from cur on (the rest of the path).
      window_slide = 0.0;
      for (std::size_t k = 1; k + 2 < L; ++k) window_slide += step_foot_sliding(sk, *P[k], *P[k + 1], dt);
      double f = 0.0;
      bool have_id = false;  // seq_ids[k] holds state k's inverse dynamics
      // The step S_-1 -> S_0 is not part of the transition: skipped.
      for (std::size_t k = closed.empty() ? 1 : 0; k + 2 < L; ++k) {
        // g on the steps C changes and on the last two (into S_G, where the
        // velocity jump is), h (or g: exact_lookahead) in between.
        if (k <= 2 || k + 4 >= L || params.exact_lookahead) {
          if (!have_id) inverse_dynamics(sk.model, seq_states[k].view(), seq_ids[k]);
          inverse_dynamics(sk.model, seq_states[k + 1].view(), seq_ids[k + 1]);
          have_id = true;
          ++ev.evaluations;
          f += full_energy(sk.model, seq_states[k].view(), seq_states[k + 1].view(), dt, seq_ids[k],
                           seq_ids[k + 1], ev.ws);
        } else {
          have_id = false;
          f += approximate_energy(sk.model, seq_states[k].view(), seq_states[k + 1].view(), dt);
        }
      }
      return f;
    };
    // Base proposal: the geodesic step toward the goal over the remaining steps;
    // the velocity-continuous Hermite step is offered per joint as a variant.
    const SynthFrame smooth = hermite_step(gap, prev, cur, remaining);
    SynthFrame best = geodesic_step(gap, cur, remaining);
    if (params.smooth_root) best.root_position_m = smooth.root_position_m;
    double best_f = score(best);
    // A candidate may not slide the feet more than the geodesic completion
    // from cur (the previous iteration's path): the path never slides more
    // than the slerp transition of the same length.
    const double slide_limit = window_slide + 1e-9;
    auto try_candidate = [&](SynthFrame&& cand) {
      const double f = score(cand);
      if (f < best_f && window_slide <= slide_limit) {
        best_f = f;
        best = std::move(cand);
      }
    };
    // Contact-aware proposals: a foot on the ground in S stays where it is
    // (fully or half way from the proposal's), its leg turned by inverse
    // kinematics, each leg alone and both together.
    if (!legs.empty()) {
      synth_world_pose(sk, best, w_cand);
      const EnergyParams& ep = sk.model.params;
      std::vector<std::size_t> down;
      for (std::size_t l = 0; l < legs.size(); ++l)
        for (int fj : legs[l].feet)
          if (contact_point(sk, w_cur, fj).y() - ep.ground_height_m <= ep.contact_height_m) {
            down.push_back(l);
            break;
          }
      const SynthFrame base = best;
      auto planted = [&](const SynthFrame& from, std::size_t l, double alpha, SynthFrame& out) {
        const auto ankle = static_cast<std::size_t>(legs[l].ankle);
        const Eigen::Vector3d t = (1.0 - alpha) * w_cand.positions_m[ankle] + alpha * w_cur.positions_m[ankle];
        const Eigen::Quaterniond r = w_cand.rotations[ankle].slerp(alpha, w_cur.rotations[ankle]);
        out = from;
        return plant_leg(sk, gap.range, legs[l], t, r, out, w_ik);
      };
      SynthFrame cand, both;
      for (double alpha : {1.0, 0.5}) {
        for (std::size_t l : down)
          if (planted(base, l, alpha, cand)) try_candidate(SynthFrame(cand));
        bool all = down.size() > 1;
        both = base;
        for (std::size_t l = 0; all && l < down.size(); ++l) {
          all = planted(both, down[l], alpha, cand);
          both = cand;
        }
        if (all) try_candidate(std::move(both));
      }
    }
    // The costliest joints of the proposal step, in decreasing order.
    synth_world_pose(sk, best, w_cand);
    ev.g(&w_prev, w_cur, w_cand, nullptr, true);
    costs.clear();
    for (std::size_t j = 0; j < n; ++j) {
      const double c = ev.terms.g.joint_J[j] + ev.terms.g.segment_J[j];
      if (c > 0.0) costs.emplace_back(c, static_cast<int>(j));
    }
    std::sort(costs.begin(), costs.end(), [](const auto& x, const auto& y) {
      return x.first != y.first ? x.first > y.first : x.second < y.second;
    });
    varied.clear();
    for (const auto& [c, j] : costs) {
      if (varied.size() >= params.joints_per_iteration) break;
      // Its adjacent joint that stands highest (itself when it has none).
      int a = j;
      double top = -1e300;
      for (int k : adjacent[static_cast<std::size_t>(j)]) {
        const double y = w_cur.positions_m[static_cast<std::size_t>(k)].y();
        if (y > top) {
          top = y;
          a = k;
        }
      }
      if (sk.is_root_chain[static_cast<std::size_t>(a)] && a != sk.root_joint) continue;
      if (std::find(varied.begin(), varied.end(), a) != varied.end()) continue;
      varied.push_back(a);
      const auto au = static_cast<std::size_t>(a);
      const Eigen::Quaterniond base = best.local_rotations[au];
      const Eigen::Quaterniond here = cur.local_rotations[au];
      // Variants: the smooth (Hermite) rotation, half-way to it, and the
      // step scaled by 1 +- 0.25, 0.5 (within the range of motion).
      std::vector<Eigen::Quaterniond> variants;
      variants.push_back(smooth.local_rotations[au]);
      variants.push_back(base.slerp(0.5, smooth.local_rotations[au]));
      const Eigen::Vector3d step = local_log(here, base);
      if (step.norm() > 1e-6)
        for (double t : {0.5, 0.75, 1.25, 1.5}) variants.push_back(here * quat_exp(t * step));
      for (Eigen::Quaterniond q : variants) {
        q.normalize();
        if (gap.range) q = clamp_to_range(sk, *gap.range, a, q);
        SynthFrame cand = best;
        cand.local_rotations[au] = q;
        if (a == sk.root_joint) {
          SynthFrame cand2 = cand;
          cand2.root_position_m = smooth.root_position_m;
          try_candidate(std::move(cand2));
          cand2 = cand;
          cand2.root_position_m = 0.5 * (best.root_position_m + smooth.root_position_m);
          try_candidate(std::move(cand2));
        }
        try_candidate(std::move(cand));
      }
    }
    closed.push_back(best);
    pprev = std::move(prev);
    have_pprev = true;
    prev = std::move(cur);
    cur = best;
  }
  if (stats) {
    stats->iterations += iterations;
    stats->energy_evaluations += ev.evaluations;
    stats->estimated_frames = estimate;
    stats->stop_reason = reason;
  }
  return closed;
}

}  // namespace

double end_steps_peak_angular_speed(const GapProblem& gap) {
  check_gap(gap);
  return std::max(step_peak_angular_speed(gap, gap.before, gap.start),
                  step_peak_angular_speed(gap, gap.goal, gap.after));
}

RefineResult refine_transition(const GapProblem& gap, std::vector<SynthFrame>& frames,
                               const RefineOptions& options) {
  check_gap(gap);
  if (!(options.smoothing_J >= 0.0) || !std::isfinite(options.smoothing_J) ||
      !(options.polish_smoothing_J >= 0.0) || !std::isfinite(options.polish_smoothing_J))
    throw std::invalid_argument("refinement smoothing must be a finite number of joules >= 0");
  if (options.polish_max_window == 0)
    throw std::invalid_argument("polishing window must be at least 1 frame");
  const SynthSkeleton& sk = *gap.skeleton;
  const std::size_t n = sk.joint_count(), m = frames.size();
  for (const SynthFrame& f : frames)
    if (f.local_rotations.size() != n)
      throw std::invalid_argument("transition frame does not fit the skeleton");
  PathCache cache;
  RefineResult result;
  double f = cache.build(gap, frames);
  result.energy_before_J = result.energy_after_J = f;
  if (m == 0 || (options.iterations == 0 && options.polish_sweeps == 0)) return result;
  // Variables of each frame: root position (m), then a rotation vector (rad)
  // per varied joint, applied on the right of the frame's rotation as given.
  std::vector<int> joints;
  for (std::size_t j = 0; j < n; ++j)
    if (!sk.is_root_chain[j] || static_cast<int>(j) == sk.root_joint)
      joints.push_back(static_cast<int>(j));
  const std::size_t per = 3 + 3 * joints.size(), N = m * per;
  std::vector<SynthFrame> base = frames;  // x = 0 (polishing rebases a frame)
  const auto frame_of = [&](std::size_t i, const double* x, SynthFrame& out) {
    out = base[i];
    out.root_position_m += Eigen::Vector3d(x[0], x[1], x[2]);
    for (std::size_t k = 0; k < joints.size(); ++k) {
      const auto j = static_cast<std::size_t>(joints[k]);
      out.local_rotations[j] = (base[i].local_rotations[j] *
                                quat_exp(Eigen::Vector3d(x[3 + 3 * k], x[4 + 3 * k], x[5 + 3 * k])))
                                   .normalized();
    }
  };
  // The limit checks sum the sliding in measure_transition's order
  // (PathCache::foot_sliding_with). The 0.1 nm slack lets a step through
  // whose planted feet move by round-off only; it is room the search uses
  // up, so it stays far below what the measures' comparisons allow (1e-9).
  const double slide_limit =
      std::max(cache.foot_sliding(gap), options.foot_sliding_limit_m) + 1e-10;
  const std::size_t violation_limit = count_range_violations(gap, frames);
  const double speed_limit =
      std::max({peak_angular_speed(gap, frames), end_steps_peak_angular_speed(gap),
                options.angular_speed_limit_radps}) +
      1e-9;
  const auto within_limits = [&](const std::vector<SynthFrame>& fs) {
    return !options.keep_limits || (cache.foot_sliding(gap) <= slide_limit &&
                                    count_range_violations(gap, fs) <= violation_limit &&
                                    peak_angular_speed(gap, fs) <= speed_limit);
  };
  // Forward differences, the cache holding the transition at `at`; the
  // frames in parallel (each component is computed alone: the same result
  // for every thread count).
  constexpr double eps = 1e-6;
  struct Scratch {
    SynthFrame changed;
    Eigen::VectorXd xi;
    PathCache::DeltaScratch delta;
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  const auto gradient = [&](const Eigen::VectorXd& at, Eigen::VectorXd& out) {
    out.resize(static_cast<Eigen::Index>(N));
    tbb::parallel_for(std::size_t{0}, m, [&](std::size_t i) {
      Scratch& sc = scratch.local();
      for (std::size_t v = 0; v < per; ++v) {
        sc.xi = at.segment(static_cast<Eigen::Index>(i * per), static_cast<Eigen::Index>(per));
        sc.xi[static_cast<Eigen::Index>(v)] += eps;
        frame_of(i, sc.xi.data(), sc.changed);
        out[static_cast<Eigen::Index>(i * per + v)] =
            cache.delta(gap, i, 1, &sc.changed, sc.delta) / eps;
      }
    });
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(N)), grad, grad_new, dir,
                  x_new;
  std::vector<Eigen::VectorXd> hist_s, hist_y;
  std::vector<double> alpha;
  std::vector<SynthFrame> trial(m);
  // L-BFGS (the last 10 pairs, two-loop recursion) on the cache's g (exact,
  // or smoothed), from x / frames / f.
  const auto lbfgs = [&](std::size_t iterations) {
    hist_s.clear();
    hist_y.clear();
    gradient(x, grad);
    for (std::size_t it = 0; it < iterations; ++it) {
      dir = -grad;
      alpha.assign(hist_s.size(), 0.0);
      for (std::size_t k = hist_s.size(); k-- > 0;) {
        alpha[k] = hist_s[k].dot(dir) / hist_y[k].dot(hist_s[k]);
        dir -= alpha[k] * hist_y[k];
      }
      if (!hist_s.empty())
        dir *= hist_s.back().dot(hist_y.back()) / hist_y.back().dot(hist_y.back());
      for (std::size_t k = 0; k < hist_s.size(); ++k)
        dir += hist_s[k] * (alpha[k] - hist_y[k].dot(dir) / hist_y[k].dot(hist_s[k]));
      if (!(dir.dot(grad) < 0.0)) {
        dir = -grad;
        hist_s.clear();
        hist_y.clear();
      }
      const double slope = dir.dot(grad), biggest = dir.cwiseAbs().maxCoeff();
      if (!(slope < 0.0) || !(biggest > 0.0)) break;
      // Steepest descent starts at 1 mm / 1 mrad for the largest component.
      double step = hist_s.empty() ? 1e-3 / biggest : 1.0;
      bool accepted = false;
      double f_new = f;
      for (int halvings = 0; halvings < 30 && !accepted; ++halvings, step *= 0.5) {
        x_new = x + step * dir;
        for (std::size_t i = 0; i < m; ++i) frame_of(i, x_new.data() + i * per, trial[i]);
        f_new = cache.build(gap, trial);
        accepted = f_new < f + 1e-4 * step * slope && within_limits(trial);
      }
      if (!accepted) {
        cache.build(gap, frames);
        if (hist_s.empty()) break;  // no descent step even along the gradient
        hist_s.clear();             // retry along the gradient
        hist_y.clear();
        continue;
      }
      frames = trial;
      gradient(x_new, grad_new);
      Eigen::VectorXd sv = x_new - x, yv = grad_new - grad;
      if (sv.dot(yv) > 1e-12) {
        if (hist_s.size() == 10) {
          hist_s.erase(hist_s.begin());
          hist_y.erase(hist_y.begin());
        }
        hist_s.push_back(std::move(sv));
        hist_y.push_back(std::move(yv));
      }
      x.swap(x_new);
      grad.swap(grad_new);
      f = f_new;
      ++result.steps;
    }
  };
  if (options.smoothing_J > 0.0) {
    // Continuation: s, s / 10, s / 100, then the exact g; after each smoothed
    // stage the frames are kept only if their exact g is lower and within
    // the limits (a smoothed step may raise the exact g).
    const std::size_t per_stage = options.iterations / 4;
    std::vector<SynthFrame> kept = frames;
    Eigen::VectorXd kept_x = x;
    double kept_g = f;
    double level = options.smoothing_J;
    for (int stage = 0; stage < 3 && per_stage > 0; ++stage, level *= 0.1) {
      cache.smoothing_J = level;
      f = cache.build(gap, frames);
      lbfgs(per_stage);
      cache.smoothing_J = 0.0;
      const double exact = cache.build(gap, frames);
      if (exact < kept_g && within_limits(frames)) {
        kept = frames;
        kept_x = x;
        kept_g = exact;
      } else {
        frames = kept;
        x = kept_x;
      }
    }
    f = cache.build(gap, frames);
    lbfgs(options.iterations - 3 * per_stage);
  } else if (options.iterations > 0) {
    lbfgs(options.iterations);
  }
  if (options.polish_sweeps > 0) {
    // Coordinate polishing (it moves along the kinks where the quasi-Newton
    // steps stall): each variable tried +-d on its own, d doubling (to 0.1)
    // when a move is kept and halving when neither direction lowers g; a
    // variable is done below 1e-5. Moves:
    // - one variable of one frame (x);
    // - with polish_max_window = W > 1, the same variable of a run of w
    //   consecutive frames together (w = 2, 4, ... <= W, runs overlapping by
    //   half): the rates inside the run barely change (root velocities not
    //   at all; a joint's relative turn keeps its angle) and those at its
    //   ends do, a direction single moves cannot take;
    // - with polish_segment_moves, one segment turned alone on one axis: its
    //   joint turned one way and each child turned back, so that the
    //   subtree keeps its orientations (and is carried); variables
    //   per + 3 k .. per + 3 k + 2 for segment_joints[k]. Such a move
    //   rebases its frames (base = the frame, x = 0).
    // Each move is evaluated locally (delta), kept only if g drops and the
    // limits hold (the path's sliding with the moved poses, the speeds of the
    // steps they touch, their frames' violations), and applied to the cache
    // in place. Serial, hence deterministic.
    struct Run {
      std::size_t first, count;
    };
    std::vector<Run> runs;
    for (std::size_t i = 0; i < m; ++i) runs.push_back({i, 1});
    for (std::size_t w = 2; w <= std::min(options.polish_max_window, m); w *= 2) {
      std::size_t first = 0;
      for (; first + w <= m; first += w / 2) runs.push_back({first, w});
      if (first - w / 2 + w < m) runs.push_back({m - w, w});  // the last frames
    }
    std::vector<std::vector<int>> children(n);  // of the joints of segment moves
    std::vector<int> segment_joints;
    if (options.polish_segment_moves)
      for (const int j : joints)
        if (!(children[static_cast<std::size_t>(j)] = sk.skeleton.children(j)).empty())
          segment_joints.push_back(j);
    const std::size_t vars = per + 3 * segment_joints.size();
    std::vector<double> d;
    std::vector<SynthFrame> moved(std::min(options.polish_max_window, m));
    Scratch& sc = scratch.local();
    // Frame i + q with variable v moved by `step`, into moved[q].
    const auto move = [&](std::size_t i, std::size_t q, std::size_t v, double step) {
      if (v < per) {
        sc.xi = x.segment(static_cast<Eigen::Index>((i + q) * per), static_cast<Eigen::Index>(per));
        sc.xi[static_cast<Eigen::Index>(v)] += step;
        frame_of(i + q, sc.xi.data(), moved[q]);
        return;
      }
      const auto j = static_cast<std::size_t>(segment_joints[(v - per) / 3]);
      Eigen::Vector3d turn = Eigen::Vector3d::Zero();
      turn[static_cast<Eigen::Index>((v - per) % 3)] = step;
      SynthFrame& out = moved[q];
      out = frames[i + q];
      out.local_rotations[j] = (out.local_rotations[j] * quat_exp(turn)).normalized();
      for (const int c : children[j]) {
        Eigen::Quaterniond& rc = out.local_rotations[static_cast<std::size_t>(c)];
        rc = (quat_exp(-turn) * rc).normalized();
      }
    };
    // One polishing pass on g smoothed at `level` (0: exact), at most
    // polish_sweeps sweeps; the cache is left exact.
    const auto polish = [&](double level) {
      cache.smoothing_J = level;
      f = cache.build(gap, frames);
      std::size_t violations = count_range_violations(gap, frames);
      d.assign(runs.size() * vars, 1e-2);
      for (std::size_t sweep = 0; sweep < options.polish_sweeps; ++sweep) {
        bool active = false;
        for (std::size_t r = 0; r < runs.size(); ++r) {
          const auto [i, count] = runs[r];
          for (std::size_t v = 0; v < vars; ++v) {
            double& dv = d[r * vars + v];
            if (dv < 1e-5) continue;
            active = true;
            bool kept = false;
            for (const double sign : {1.0, -1.0}) {
              for (std::size_t q = 0; q < count; ++q) move(i, q, v, sign * dv);
              const double dg = cache.delta(gap, i, count, moved.data(), sc.delta);
              if (!(dg < -1e-12)) continue;
              std::size_t new_violations = violations;
              if (options.keep_limits) {
                for (std::size_t q = 0; q < count; ++q)
                  new_violations = new_violations + frame_range_violations(gap, moved[q]) -
                                   frame_range_violations(gap, frames[i + q]);
                if (new_violations > violation_limit ||
                    cache.foot_sliding_with(gap, i + 2, count, sc.delta.w_changed.data()) >
                        slide_limit)
                  continue;
                bool too_fast = false;
                for (std::size_t q = 0; q <= count && !too_fast; ++q) {
                  const SynthFrame& a = q > 0 ? moved[q - 1] : i == 0 ? gap.start : frames[i - 1];
                  const SynthFrame& b = q < count        ? moved[q]
                                        : i + count == m ? gap.goal
                                                         : frames[i + count];
                  too_fast = step_peak_angular_speed(gap, a, b) > speed_limit;
                }
                if (too_fast) continue;
              }
              cache.apply(i, count, sc.delta);
              for (std::size_t q = 0; q < count; ++q) {
                std::swap(frames[i + q], moved[q]);
                const auto xs = static_cast<Eigen::Index>((i + q) * per);
                if (v < per) {
                  x[xs + static_cast<Eigen::Index>(v)] += sign * dv;
                } else {
                  base[i + q] = frames[i + q];
                  x.segment(xs, static_cast<Eigen::Index>(per)).setZero();
                }
              }
              violations = new_violations;
              kept = true;
              ++result.steps;
              break;
            }
            dv = kept ? std::min(0.1, 2.0 * dv) : 0.5 * dv;
          }
        }
        if (!active) break;
      }
      // The cache was updated move by move: it must hold what a rebuild gives
      // (a wrong local update would fail here rather than mislead).
      const double cached = std::accumulate(cache.steps.begin(), cache.steps.end(), 0.0);
      // The sum over the whole path (the measure's order of additions).
      f = cache.build(gap, frames);
      if (!(std::abs(cached - f) <= 1e-6 * std::max(1.0, std::abs(f))))
        throw std::logic_error("refine_transition: polishing's local updates left the path");
      if (level > 0.0) {
        cache.smoothing_J = 0.0;
        f = cache.build(gap, frames);
      }
    };
    if (options.polish_smoothing_J > 0.0) {
      // A pass on the smoothed g first (it slides along the rounded kinks),
      // kept only if the exact g is lower (each move kept the limits).
      const std::vector<SynthFrame> kept_frames = frames, kept_base = base;
      const Eigen::VectorXd kept_x = x;
      const double kept_g = f;  // exact: the iterations end on the exact g
      polish(options.polish_smoothing_J);
      if (!(f < kept_g)) {
        frames = kept_frames;
        base = kept_base;
        x = kept_x;
      }
    }
    polish(0.0);
  }
  result.energy_after_J = f;
  return result;
}

std::vector<SynthFrame> supplement_astar(const GapProblem& gap, const SupplementParams& params,
                                         SupplementStats* stats) {
  check_gap(gap);
  if (!(params.cost_threshold_J >= 0.0)) throw std::invalid_argument("cost threshold must be >= 0");
  SupplementStats local;
  SupplementStats& st = stats ? *stats : local;
  st = SupplementStats{};
  std::vector<SynthFrame> frames =
      astar_search(gap, params, choose_transition_frames(gap, params), &st);
  if (params.refine_iterations > 0 || params.refine_polish_sweeps > 0) {
    // Feet may slide as much as the slerp transition of the same length's
    // (the search's own bound), not more; no joint may turn faster than in
    // that slerp, the search's path or the captured steps at either end.
    PathCache slerp_path;
    const std::vector<SynthFrame> slerp = slerp_transition(gap, frames.size());
    slerp_path.build_poses(gap, slerp);
    const RefineOptions ro{params.refine_iterations,        slerp_path.foot_sliding(gap),
                           params.refine_keep_limits,       params.refine_smoothing_J,
                           params.refine_polish_sweeps,     peak_angular_speed(gap, slerp),
                           params.refine_polish_window,     params.refine_polish_segments,
                           params.refine_polish_smoothing_J};
    const RefineResult r = refine_transition(gap, frames, ro);
    st.refine_steps = r.steps;
    st.refine_gain_J = r.energy_before_J - r.energy_after_J;
  }
  return frames;
}

std::vector<SynthFrame> slerp_transition(const GapProblem& gap, std::size_t frames) {
  check_gap(gap);
  std::vector<SynthFrame> out(frames);
  const std::size_t n = gap.skeleton->joint_count();
  for (std::size_t i = 0; i < frames; ++i) {
    const double s = static_cast<double>(i + 1) / static_cast<double>(frames + 1);
    SynthFrame& f = out[i];
    f.root_position_m = (1.0 - s) * gap.start.root_position_m + s * gap.goal.root_position_m;
    f.local_rotations.resize(n);
    for (std::size_t j = 0; j < n; ++j)
      f.local_rotations[j] = gap.start.local_rotations[j].slerp(s, gap.goal.local_rotations[j]).normalized();
  }
  return out;
}

std::vector<SynthFrame> inertialize_transition(const GapProblem& gap, std::size_t frames) {
  check_gap(gap);
  const double dt = gap.frame_time_s;
  const double t1 = static_cast<double>(frames + 1) * dt;
  const std::size_t n = gap.skeleton->joint_count();
  // Target track: the goal extrapolated backwards with its own rates.
  const Eigen::Vector3d vg = (gap.after.root_position_m - gap.goal.root_position_m) / dt;
  auto target_root = [&](double tau) { return Eigen::Vector3d(gap.goal.root_position_m - vg * tau); };
  std::vector<Eigen::Vector3d> wg(n);
  for (std::size_t j = 0; j < n; ++j)
    wg[j] = local_log(gap.goal.local_rotations[j], gap.after.local_rotations[j]) / dt;
  auto target_rot = [&](std::size_t j, double tau) {
    return Eigen::Quaterniond((gap.goal.local_rotations[j] * quat_exp(-wg[j] * tau)).normalized());
  };
  // Offsets at the start (value and rate).
  const Eigen::Vector3d px0 = gap.start.root_position_m - target_root(t1);
  const Eigen::Vector3d pxm = gap.before.root_position_m - target_root(t1 + dt);
  const Eigen::Vector3d pv0 = (px0 - pxm) / dt;
  std::vector<Eigen::Vector3d> rx0(n), rv0(n);
  for (std::size_t j = 0; j < n; ++j) {
    rx0[j] = local_log(target_rot(j, t1), gap.start.local_rotations[j]);
    const Eigen::Vector3d xm = local_log(target_rot(j, t1 + dt), gap.before.local_rotations[j]);
    rv0[j] = (rx0[j] - xm) / dt;
  }
  std::vector<SynthFrame> out(frames);
  for (std::size_t i = 0; i < frames; ++i) {
    const double t = static_cast<double>(i + 1) * dt, tau = t1 - t;
    SynthFrame& f = out[i];
    f.root_position_m = target_root(tau) + inertialize_decay(px0, pv0, t1, t);
    f.local_rotations.resize(n);
    for (std::size_t j = 0; j < n; ++j)
      f.local_rotations[j] =
          (target_rot(j, tau) * quat_exp(inertialize_decay(rx0[j], rv0[j], t1, t))).normalized();
  }
  return out;
}

TransitionMeasures measure_transition(const GapProblem& gap, const std::vector<SynthFrame>& frames) {
  check_gap(gap);
  const SynthSkeleton& sk = *gap.skeleton;
  const double dt = gap.frame_time_s;
  const std::size_t n = sk.joint_count();
  std::vector<const SynthFrame*> seq;
  seq.push_back(&gap.before);
  seq.push_back(&gap.start);
  for (const SynthFrame& f : frames) {
    if (f.local_rotations.size() != n) throw std::invalid_argument("transition frame does not fit the skeleton");
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
  for (std::size_t k = 1; k + 2 < L; ++k) {
    const double g = full_energy(sk.model, states[k].view(), states[k + 1].view(), dt, ids[k],
                                 ids[k + 1], ws, &terms);
    m.step_energies_J.push_back(g);
    m.energy_J += g;
    split.h_J += terms.h.total();
    split.adjacent_J += std::accumulate(terms.adjacent_work_J.begin(), terms.adjacent_work_J.end(), 0.0);
    split.contact_J += std::accumulate(terms.contact_work_J.begin(), terms.contact_work_J.end(), 0.0);
    split.joint_J += std::accumulate(terms.joint_work_J.begin(), terms.joint_work_J.end(), 0.0);
    split.residual_work_J += terms.residual_work_J;
    split.residual_impulse_J += terms.residual_impulse_J;
    m.approximate_energy_J += approximate_energy(sk.model, states[k].view(), states[k + 1].view(), dt);
    m.foot_sliding_m += step_foot_sliding(sk, world[k], world[k + 1], dt);
    m.peak_angular_speed_radps =
        std::max(m.peak_angular_speed_radps, step_peak_angular_speed(gap, *seq[k], *seq[k + 1]));
  }
  m.range_violations = count_range_violations(gap, frames);
  return m;
}

std::vector<double> motion_step_energies(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                                         double frame_time_s) {
  const std::size_t L = frames.size();
  std::vector<double> out;
  if (L < 2) return out;
  std::vector<WorldPose> world(L);
  for (std::size_t k = 0; k < L; ++k) synth_world_pose(sk, frames[k], world[k]);
  std::vector<BodyState> states(L);
  std::vector<NewtonEulerData> ids(L);
  for (std::size_t k = 0; k < L; ++k) {
    PoseView p{}, x{};
    if (k > 0) p = pose_view(world[k - 1]);
    if (k + 1 < L) x = pose_view(world[k + 1]);
    sequence_state(sk.model, k > 0 ? &p : nullptr, pose_view(world[k]), k + 1 < L ? &x : nullptr,
                   frame_time_s, states[k]);
    inverse_dynamics(sk.model, states[k].view(), ids[k]);
  }
  NewtonEulerWorkspace ws;
  for (std::size_t k = 0; k + 1 < L; ++k)
    out.push_back(full_energy(sk.model, states[k].view(), states[k + 1].view(), frame_time_s, ids[k],
                              ids[k + 1], ws));
  return out;
}

}  // namespace mocap
