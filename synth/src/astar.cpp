// The A* search of the paper's figure 4 (astar.hpp): one state accepted per
// iteration, chosen among the geodesic step, its foot-planted variants,
// (searching on W) its stepping variants and per-joint variants by f = the
// energy (g or W) of the steps it changes + the cost of its geodesic
// completion to the goal. docs/synthesis.md gives every choice.
#include "astar.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "foot_planting.hpp"
#include "foot_steps.hpp"
#include "measures.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/dynamics/work_energy.hpp"
#include "transition_math.hpp"

namespace mocap::synth_detail {
namespace {

// Stepping proposals (search on W): a swing's length, seconds, and the
// ankle's rise or fall per proposed step, metres.
constexpr double kSwingS = 0.4;
constexpr double kLiftStepM = 0.03;

// The search's energy of one step from inverse dynamics already run on both
// states: g, or W (SupplementParams::energy); per-joint costs into the terms
// when given.
double step_energy(SearchEnergy energy, const DynamicsModel& model, const StateView& a,
                   const StateView& b, double dt, const NewtonEulerData& da,
                   const NewtonEulerData& db, NewtonEulerWorkspace& ws, FullEnergyTerms* g_terms,
                   WorkEnergyTerms* w_terms) {
  if (energy == SearchEnergy::work) return work_energy(model, a, b, dt, da, db, {}, w_terms);
  return full_energy(model, a, b, dt, da, db, ws, g_terms);
}

// Energies of steps between world poses with rates from their neighbours.
struct StepEvaluator {
  const SynthSkeleton& sk;
  double dt;
  SearchEnergy energy;
  BodyState sa, sb;
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  WorkEnergyTerms w_terms;
  WorkEnergyTerms w_scratch;  // score()'s: W's terms reused, not allocated per step
  std::size_t evaluations = 0;

  StepEvaluator(const SynthSkeleton& s, double frame_time, SearchEnergy e)
      : sk(s), dt(frame_time), energy(e) {}

  // The step's energy (g or W) A -> B: A's rates from (a_prev, A, B), B's
  // from (A, B, b_next); with want_terms, joint_cost() then gives each
  // joint's part.
  double g(const WorldPose* a_prev, const WorldPose& a, const WorldPose& b, const WorldPose* b_next,
           bool want_terms) {
    const PoseView pa = pose_view(a), pb = pose_view(b);
    PoseView pap{}, pbn{};
    if (a_prev) pap = pose_view(*a_prev);
    if (b_next) pbn = pose_view(*b_next);
    sequence_state(sk.model, a_prev ? &pap : nullptr, pa, &pb, dt, sa);
    sequence_state(sk.model, &pa, pb, b_next ? &pbn : nullptr, dt, sb);
    ++evaluations;
    inverse_dynamics(sk.model, sa.view(), ws.a);
    inverse_dynamics(sk.model, sb.view(), ws.b);
    return step_energy(energy, sk.model, sa.view(), sb.view(), dt, ws.a, ws.b, ws,
                       want_terms ? &terms : nullptr, want_terms ? &w_terms : nullptr);
  }

  // Joint j's part of the last g(..., true): its segment and joint terms of
  // g, or its joint work and ground work in W.
  double joint_cost(std::size_t j) const {
    if (energy == SearchEnergy::work) return w_terms.joint_J[j] + w_terms.ground_J[j];
    return terms.g.joint_J[j] + terms.g.segment_J[j];
  }
};

// The search's state: the path so far (CLOSED), the current state and its
// two predecessors, this iteration's best candidate (OPEN is scanned as it
// is generated), and scratch reused by every candidate.
class AStarSearch {
 public:
  AStarSearch(const GapProblem& gap, const SupplementParams& params, std::size_t planned)
      : gap_(gap),
        params_(params),
        sk_(*gap.skeleton),
        dt_(gap.frame_time_s),
        n_(sk_.joint_count()),
        planned_(planned),
        ev_(sk_, dt_, params.energy) {
    synth_world_pose(sk_, gap.goal, w_goal_);
    synth_world_pose(sk_, gap.after, w_after_);
    // Neighbours of each joint (parent and children that carry rotations).
    adjacent_.resize(n_);
    for (std::size_t j = 0; j < n_; ++j) {
      const int p = sk_.skeleton.parents[j];
      if (p >= 0 && (!sk_.is_root_chain[static_cast<std::size_t>(p)] || p == sk_.root_joint))
        adjacent_[j].push_back(p);
      for (int c : sk_.skeleton.children(static_cast<int>(j))) adjacent_[j].push_back(c);
    }
    if (params.plant_feet || params.energy == SearchEnergy::work) legs_ = leg_chains(sk_);
    // A leg's ankle height when it stands: the lower of S_0's and S_G's.
    WorldPose w_start;
    synth_world_pose(sk_, gap.start, w_start);
    for (const LegChain& leg : legs_) {
      const auto a = static_cast<std::size_t>(leg.ankle);
      stance_height_.push_back(std::min(w_start.positions_m[a].y(), w_goal_.positions_m[a].y()));
    }
    prev_ = gap.before;
    cur_ = gap.start;
    // The stepping plan over the planned slerp path, its swings timed by the
    // gait on either side (the search on W proposes it frame by frame).
    if (params.energy == SearchEnergy::work && !legs_.empty() && planned_ > 0)
      step_plan_ = plan_steps(gap, slerp_transition(gap, planned_), stepping_params(gap));
  }

  std::vector<SynthFrame> run(SupplementStats* stats) {
    std::string reason = "max_states";
    std::size_t iterations = 0;
    for (;;) {
      if (have_pprev_) synth_world_pose(sk_, pprev_, w_pprev_);
      synth_world_pose(sk_, prev_, w_prev_);
      synth_world_pose(sk_, cur_, w_cur_);
      // Stop: the step cost to the goal is below T_c.
      const double to_goal = ev_.g(&w_prev_, w_cur_, w_goal_, &w_after_, false);
      if (to_goal < params_.cost_threshold_J) {
        reason = "threshold";
        break;
      }
      if (closed_.size() >= params_.max_states) break;
      if (closed_.size() >= planned_) {
        reason = "horizon";
        break;
      }
      ++iterations;
      iterate();
      closed_.push_back(best_);
      pprev_ = std::move(prev_);
      have_pprev_ = true;
      prev_ = std::move(cur_);
      cur_ = best_;
    }
    if (stats) {
      stats->iterations += iterations;
      stats->energy_evaluations += ev_.evaluations;
      stats->estimated_frames = planned_;
      stats->stop_reason = reason;
    }
    return std::move(closed_);
  }

 private:
  // One iteration: the best successor of cur_ into best_.
  void iterate() {
    const std::size_t remaining =
        std::max<std::size_t>(2, planned_ + 1 - std::min(planned_, closed_.size()));
    rollout_ = remaining - 2;
    // Base proposal: the geodesic step toward the goal over the remaining
    // steps; the velocity-continuous Hermite step is offered per joint as a
    // variant.
    smooth_ = hermite_step(gap_, prev_, cur_, remaining);
    best_ = geodesic_step(gap_, cur_, remaining);
    if (params_.smooth_root) best_.root_position_m = smooth_.root_position_m;
    best_f_ = score(best_);
    // A candidate may not slide the feet more than the geodesic completion
    // from cur (the previous iteration's path): the path never slides more
    // than the slerp transition of the same length.
    slide_limit_ = window_slide_ + 1e-9;
    if (!legs_.empty() && params_.plant_feet) try_planted_feet();
    if (params_.energy == SearchEnergy::work) {
      // The whole velocity-continuous (Hermite) step, and half-way to it:
      // the step that meets S_G with its own velocity, where W's price of
      // a velocity jump (unsupported force) is highest.
      const SynthFrame base = best_;
      try_candidate(SynthFrame(smooth_));
      SynthFrame half;
      geodesic_frame(base, smooth_, 0.5, half);
      try_candidate(std::move(half));
      if (!legs_.empty()) try_steps(remaining);
      if (closed_.size() < step_plan_.size()) try_planned_steps(step_plan_[closed_.size()], base);
    }
    try_joint_variants();
  }

  // f(C) = g over the steps C changes (prev -> cur -> C -> D_1, rates by
  // central differences) + the estimate of the rest: the geodesic
  // completion D_1 .. D_{r-2} -> S_G from C (the slerp of the remaining
  // steps), each of its steps costed by h (the paper's h(S1' -> Sf) taken
  // step by step along the straight completion), or by g when
  // params.exact_lookahead. Also sets window_slide_: the foot sliding over
  // the steps from cur on.
  double score(const SynthFrame& c) {
    // Pose list: prev, cur, C, D_1..D_k, goal, after.
    const std::size_t L = 3 + rollout_ + 2;
    if (seq_world_.size() < L) seq_world_.resize(L);
    if (seq_states_.size() < L) seq_states_.resize(L);
    if (seq_ids_.size() < L) seq_ids_.resize(L);
    if (poses_.size() < L) poses_.resize(L);
    poses_[0] = &w_prev_;
    poses_[1] = &w_cur_;
    synth_world_pose(sk_, c, seq_world_[2]);
    poses_[2] = &seq_world_[2];
    for (std::size_t k = 1; k <= rollout_; ++k) {
      const double s = static_cast<double>(k) / static_cast<double>(rollout_ + 1);
      geodesic_frame(c, gap_.goal, s, roll_frame_);
      synth_world_pose(sk_, roll_frame_, seq_world_[2 + k]);
      poses_[2 + k] = &seq_world_[2 + k];
    }
    poses_[L - 2] = &w_goal_;
    poses_[L - 1] = &w_after_;
    // States 0 .. L-2 (prev's predecessor: pprev, when there is one).
    for (std::size_t k = 0; k + 1 < L; ++k) {
      const PoseView pc = pose_view(*poses_[k]), px = pose_view(*poses_[k + 1]);
      PoseView pp{};
      const bool has_prev = k > 0 || have_pprev_;
      if (k > 0)
        pp = pose_view(*poses_[k - 1]);
      else if (have_pprev_)
        pp = pose_view(w_pprev_);
      sequence_state(sk_.model, has_prev ? &pp : nullptr, pc, &px, dt_, seq_states_[k]);
    }
    window_slide_ = 0.0;
    for (std::size_t k = 1; k + 2 < L; ++k)
      window_slide_ += step_foot_sliding(sk_, *poses_[k], *poses_[k + 1], dt_);
    double f = 0.0;
    bool have_id = false;  // seq_ids_[k] holds state k's inverse dynamics
    // The step S_-1 -> S_0 is not part of the transition: skipped.
    for (std::size_t k = closed_.empty() ? 1 : 0; k + 2 < L; ++k) {
      // g on the steps C changes and on the last two (into S_G, where the
      // velocity jump is), h (or g: exact_lookahead) in between.
      if (k <= 2 || k + 4 >= L || params_.exact_lookahead || params_.energy == SearchEnergy::work) {
        if (!have_id) inverse_dynamics(sk_.model, seq_states_[k].view(), seq_ids_[k]);
        inverse_dynamics(sk_.model, seq_states_[k + 1].view(), seq_ids_[k + 1]);
        have_id = true;
        ++ev_.evaluations;
        f +=
            step_energy(params_.energy, sk_.model, seq_states_[k].view(), seq_states_[k + 1].view(),
                        dt_, seq_ids_[k], seq_ids_[k + 1], ev_.ws, nullptr, &ev_.w_scratch);
      } else {
        have_id = false;
        f += approximate_energy(sk_.model, seq_states_[k].view(), seq_states_[k + 1].view(), dt_);
      }
    }
    return f;
  }

  // Keeps `cand` as best_ when its f is lower and, in the search on g, it
  // slides no more than the geodesic completion (W prices sliding itself:
  // friction of a contact, or the support a fast foot does not give).
  void try_candidate(SynthFrame&& cand) {
    const double f = score(cand);
    if (f < best_f_ && (window_slide_ <= slide_limit_ || params_.energy == SearchEnergy::work)) {
      best_f_ = f;
      best_ = std::move(cand);
    }
  }

  // Contact-aware proposals: a foot on the ground in S stays where it is
  // (fully or half way from the proposal's), its leg turned by inverse
  // kinematics, each leg alone and both together.
  void try_planted_feet() {
    synth_world_pose(sk_, best_, w_cand_);
    std::vector<std::size_t> down;
    for (std::size_t l = 0; l < legs_.size(); ++l)
      if (leg_down(l)) down.push_back(l);
    const SynthFrame base = best_;
    auto planted = [&](const SynthFrame& from, std::size_t l, double alpha, SynthFrame& out) {
      const auto ankle = static_cast<std::size_t>(legs_[l].ankle);
      const Eigen::Vector3d t =
          (1.0 - alpha) * w_cand_.positions_m[ankle] + alpha * w_cur_.positions_m[ankle];
      const Eigen::Quaterniond r = w_cand_.rotations[ankle].slerp(alpha, w_cur_.rotations[ankle]);
      out = from;
      return plant_leg(sk_, gap_.range, legs_[l], t, r, out, w_ik_);
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

  // Stepping proposals (the search on W only): each leg's ankle lifted,
  // carried or set down toward where the geodesic completion would have it
  // a swing from now (S_G's foot when fewer steps remain), its leg turned by
  // inverse kinematics, with the other leg kept planted where it is down.
  // W prices what a glide or a step costs; the search chooses.
  void try_steps(std::size_t remaining) {
    const SynthFrame base = best_;
    synth_world_pose(sk_, base, w_cand_);
    const auto swing = static_cast<std::size_t>(std::ceil(kSwingS / dt_));
    const double s = std::min(1.0, static_cast<double>(swing) / static_cast<double>(remaining));
    geodesic_frame(cur_, gap_.goal, s, roll_frame_);
    synth_world_pose(sk_, roll_frame_, w_ahead_);
    for (std::size_t l = 0; l < legs_.size(); ++l) {
      SynthFrame planted = base;  // the other legs, where down, kept in place
      if (!plant_other_legs(l, planted)) continue;
      const auto ankle = static_cast<std::size_t>(legs_[l].ankle);
      const Eigen::Vector3d now = w_cur_.positions_m[ankle];
      const Eigen::Vector3d ahead = w_ahead_.positions_m[ankle];
      const double stance = stance_height_[l];
      for (double u : {0.25, 0.5}) {
        for (double dy : {kLiftStepM, 0.0, -kLiftStepM, -1.0}) {  // -1: set down
          Eigen::Vector3d t = now + u * (ahead - now);
          t.y() = dy < -0.5 ? stance : std::max(stance, now.y() + dy);
          SynthFrame cand = planted;
          const Eigen::Quaterniond r = w_cur_.rotations[ankle].slerp(u, w_ahead_.rotations[ankle]);
          if (plant_leg(sk_, gap_.range, legs_[l], t, r, cand, w_ik_))
            try_candidate(std::move(cand));
        }
      }
    }
  }

  // The stepping plan's frame as proposals: every leg's ankle where the
  // plan has it (all legs; each leg alone; every leg half way from the
  // proposal's own ankle), the legs turned by inverse kinematics.
  void try_planned_steps(const std::vector<AnkleTarget>& targets, const SynthFrame& base) {
    synth_world_pose(sk_, base, w_cand_);
    SynthFrame all = base, half = base, one;
    bool all_ok = true, half_ok = true;
    for (std::size_t l = 0; l < legs_.size(); ++l) {
      const AnkleTarget& t = targets[l];
      const auto ankle = static_cast<std::size_t>(legs_[l].ankle);
      one = base;
      if (plant_leg(sk_, gap_.range, legs_[l], t.position, t.rotation, one, w_ik_))
        try_candidate(SynthFrame(one));
      all_ok = all_ok && plant_leg(sk_, gap_.range, legs_[l], t.position, t.rotation, all, w_ik_);
      const Eigen::Vector3d mid = 0.5 * (w_cand_.positions_m[ankle] + t.position);
      const Eigen::Quaterniond r = w_cand_.rotations[ankle].slerp(0.5, t.rotation);
      half_ok = half_ok && plant_leg(sk_, gap_.range, legs_[l], mid, r, half, w_ik_);
    }
    if (legs_.size() > 1 && all_ok) try_candidate(std::move(all));
    if (half_ok) try_candidate(std::move(half));
  }

  // Leg l is down in cur_: one of its foot joints' contact points within
  // contact height of the ground.
  bool leg_down(std::size_t l) const {
    const EnergyParams& ep = sk_.model.params;
    for (int fj : legs_[l].feet)
      if (contact_point(sk_, w_cur_, fj).y() - ep.ground_height_m <= ep.contact_height_m)
        return true;
    return false;
  }

  // Every leg but `skip` that is down in cur_ kept where it is (planted);
  // false when inverse kinematics fails for one.
  bool plant_other_legs(std::size_t skip, SynthFrame& f) {
    for (std::size_t l = 0; l < legs_.size(); ++l) {
      if (l == skip || !leg_down(l)) continue;
      const auto ankle = static_cast<std::size_t>(legs_[l].ankle);
      if (!plant_leg(sk_, gap_.range, legs_[l], w_cur_.positions_m[ankle], w_cur_.rotations[ankle],
                     f, w_ik_))
        return false;
    }
    return true;
  }

  // The costliest joints of the proposal step, in decreasing order, each
  // mapped to its adjacent joint that stands highest; that joint's rotation
  // varied.
  void try_joint_variants() {
    synth_world_pose(sk_, best_, w_cand_);
    ev_.g(&w_prev_, w_cur_, w_cand_, nullptr, true);
    costs_.clear();
    for (std::size_t j = 0; j < n_; ++j) {
      const double c = ev_.joint_cost(j);
      if (c > 0.0) costs_.emplace_back(c, static_cast<int>(j));
    }
    std::sort(costs_.begin(), costs_.end(), [](const auto& x, const auto& y) {
      return x.first != y.first ? x.first > y.first : x.second < y.second;
    });
    varied_.clear();
    for (const auto& [c, j] : costs_) {
      if (varied_.size() >= params_.joints_per_iteration) break;
      // Its adjacent joint that stands highest (itself when it has none).
      int a = j;
      double top = -1e300;
      for (int k : adjacent_[static_cast<std::size_t>(j)]) {
        const double y = w_cur_.positions_m[static_cast<std::size_t>(k)].y();
        if (y > top) {
          top = y;
          a = k;
        }
      }
      if (sk_.is_root_chain[static_cast<std::size_t>(a)] && a != sk_.root_joint) continue;
      if (std::find(varied_.begin(), varied_.end(), a) != varied_.end()) continue;
      varied_.push_back(a);
      try_rotation_variants(a);
    }
  }

  // Variants of joint a: the smooth (Hermite) rotation, half-way to it, and
  // the step scaled by 1 +- 0.25, 0.5 (within the range of motion); for the
  // root joint also with the Hermite root position and half-way to it.
  void try_rotation_variants(int a) {
    const auto au = static_cast<std::size_t>(a);
    const Eigen::Quaterniond base = best_.local_rotations[au];
    const Eigen::Quaterniond here = cur_.local_rotations[au];
    std::vector<Eigen::Quaterniond> variants;
    variants.push_back(smooth_.local_rotations[au]);
    variants.push_back(base.slerp(0.5, smooth_.local_rotations[au]));
    const Eigen::Vector3d step = local_log(here, base);
    if (step.norm() > 1e-6)
      for (double t : {0.5, 0.75, 1.25, 1.5}) variants.push_back(here * quat_exp(t * step));
    for (Eigen::Quaterniond q : variants) {
      q.normalize();
      if (gap_.range) q = clamp_to_range(sk_, *gap_.range, a, q);
      SynthFrame cand = best_;
      cand.local_rotations[au] = q;
      if (a == sk_.root_joint) {
        SynthFrame cand2 = cand;
        cand2.root_position_m = smooth_.root_position_m;
        try_candidate(std::move(cand2));
        cand2 = cand;
        cand2.root_position_m = 0.5 * (best_.root_position_m + smooth_.root_position_m);
        try_candidate(std::move(cand2));
      }
      try_candidate(std::move(cand));
    }
  }

  const GapProblem& gap_;
  const SupplementParams& params_;
  const SynthSkeleton& sk_;
  const double dt_;
  const std::size_t n_;
  const std::size_t planned_;
  StepEvaluator ev_;
  WorldPose w_goal_, w_after_, w_prev_, w_cur_, w_cand_, w_ik_, w_pprev_, w_ahead_;
  std::vector<double> stance_height_;  // per leg: its ankle's height standing, m
  // The stepping plan over the planned slerp path: [inserted frame][leg].
  std::vector<std::vector<AnkleTarget>> step_plan_;
  std::vector<std::vector<int>> adjacent_;
  std::vector<LegChain> legs_;
  // CLOSED: accepted states (the path).
  std::vector<SynthFrame> closed_;
  SynthFrame pprev_, prev_, cur_;
  bool have_pprev_ = false;
  // This iteration: geodesic completion length, Hermite step, best
  // candidate and its f, the sliding bound.
  std::size_t rollout_ = 0;
  SynthFrame smooth_, best_;
  double best_f_ = 0.0, slide_limit_ = 0.0;
  // Scratch of score() (reused by every candidate) and of the joint choice.
  std::vector<WorldPose> seq_world_;
  std::vector<BodyState> seq_states_;
  std::vector<NewtonEulerData> seq_ids_;
  std::vector<const WorldPose*> poses_;
  SynthFrame roll_frame_;
  double window_slide_ = 0.0;
  std::vector<std::pair<double, int>> costs_;
  std::vector<int> varied_;
};

}  // namespace

std::vector<SynthFrame> astar_search(const GapProblem& gap, const SupplementParams& params,
                                     std::size_t planned_frames, SupplementStats* stats) {
  return AStarSearch(gap, params, planned_frames).run(stats);
}

}  // namespace mocap::synth_detail
