// The stepping pass (foot_steps.hpp): a state per leg (in the air at S_0,
// planted, swinging) advanced frame by frame along the hips' path, then
// each leg's ankle put on its target by two-bone inverse kinematics.
#include "foot_steps.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "transition_math.hpp"

namespace mocap::synth_detail {
namespace {

struct AnklePose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

double horizontal_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::hypot(a.x() - b.x(), a.z() - b.z());
}

double smoothstep(double s) {
  return s * s * (3.0 - 2.0 * s);
}

// One leg over the poses W_0 (S_0), W_1 .. W_N (the inserted frames) and
// W_{N+1} (S_G).
class LegSteps {
  static constexpr double kReachMarginM = 0.005, kFarMarginM = 0.10, kClearanceM = 0.02;

 public:
  enum class Mode { air, planted, swinging };

  // before / after: the captured neighbours S_-1 and S_G+1.
  LegSteps(const LegChain& leg, const std::vector<WorldPose>& w, const WorldPose& before,
           const WorldPose& after, double ground, double dt, const SteppingParams& p,
           std::size_t swing_frames)
      : leg_(leg), w_(w), p_(p), swing_frames_(swing_frames), ground_(ground) {
    const auto hip = static_cast<std::size_t>(leg.hip), knee = static_cast<std::size_t>(leg.knee),
               a = static_cast<std::size_t>(leg.ankle);
    length_ = (w[0].positions_m[knee] - w[0].positions_m[hip]).norm() +
              (w[0].positions_m[a] - w[0].positions_m[knee]).norm();
    const std::size_t last = w.size() - 1;
    start_on_ground_ =
        lowest(w[0]) < p.plant_height_m &&
        horizontal_distance(before.positions_m[a], w[0].positions_m[a]) < p.plant_speed_mps * dt;
    goal_on_ground_ =
        lowest(w[last]) < p.plant_height_m &&
        horizontal_distance(w[last].positions_m[a], after.positions_m[a]) < p.plant_speed_mps * dt;
    goal_ = own(last);
    // The foot's joints in the ankle's frame, and the ankle's rotation on
    // the ground (S_0's when planted there, else S_G's).
    const Eigen::Quaterniond inv = w[0].rotations[a].conjugate();
    for (int f : leg.feet)
      foot_offsets_.push_back(
          inv * (w[0].positions_m[static_cast<std::size_t>(f)] - w[0].positions_m[a]));
    ground_rotation_ = start_on_ground_ ? w[0].rotations[a] : goal_.rotation;
    if (start_on_ground_) {
      mode_ = Mode::planted;
      target_ = own(0);
    }
  }

  Mode mode() const { return mode_; }
  /// This leg is done when its foot stands where S_G has it (or S_G has it
  /// in the air and it is on its way there).
  bool away_from_goal() const {
    return mode_ == Mode::air ||
           (mode_ == Mode::planted && (target_.position - goal_.position).norm() > p_.settle_m) ||
           (mode_ == Mode::swinging && !final_swing_);
  }
  /// Advances to frame i (1 .. N) and returns the ankle's target there.
  /// `others_swinging`: another leg is in the air; `away`: legs (this one
  /// included) not yet where S_G has them.
  const AnklePose* advance(std::size_t i, bool others_swinging, std::size_t away) {
    const std::size_t last = w_.size() - 1;
    const std::size_t left = last - i;  // steps after this frame's
    if (mode_ == Mode::air) {           // half way through a swing at S_0: lands half a swing later
      target_ = own(i - 1);
      swing_from(i, goal_on_ground_ && left < swing_frames_, (swing_frames_ + 1) / 2);
    } else if (mode_ == Mode::planted) {
      const bool relocate = (target_.position - goal_.position).norm() > p_.settle_m;
      // Out of reach: further from the hip than the leg's length allows
      // and than the pose's own foot. Far: further horizontally than the
      // release share of the reach and than the pose's own foot, by a margin.
      const double own_off = (hip(i) - own(i).position).norm();
      const bool out_of_reach = (hip(i) - target_.position).norm() >
                                std::max(p_.reach_fraction * length_, own_off + kReachMarginM);
      const bool far = horizontal_distance(hip(i), target_.position) >
                       std::max(p_.release_fraction * horizontal_reach(i),
                                horizontal_distance(hip(i), own(i).position) + kFarMarginM);
      if (relocate && left < swing_frames_ * away && (!others_swinging || left < 2)) {
        swing_from(i, true, swing_frames_);
      } else if (out_of_reach || (far && !others_swinging)) {
        swing_from(i, left < 2 * swing_frames_, swing_frames_);
      } else {
        if (!relocate) settle(i);  // the last few millimetres onto S_G's foot
        return &target_;
      }
    }
    const double s =
        static_cast<double>(i + 1 - swing_start_) / static_cast<double>(land_ + 1 - swing_start_);
    const double e = smoothstep(s);
    target_.position = (1.0 - e) * from_.position + e * to_.position;
    target_.position.y() += p_.lift_m * std::sin(std::numbers::pi * s);
    target_.rotation = from_.rotation.slerp(e, to_.rotation);
    if (i == land_) {
      mode_ = Mode::planted;
      target_ = to_;
    }
    return &target_;
  }

 private:
  Eigen::Vector3d hip(std::size_t i) const {
    return w_[i].positions_m[static_cast<std::size_t>(leg_.hip)];
  }
  AnklePose own(std::size_t i) const {
    const auto a = static_cast<std::size_t>(leg_.ankle);
    return {w_[i].positions_m[a], w_[i].rotations[a]};
  }
  // Height of the leg's lowest foot joint in `w` above the ground.
  double lowest(const WorldPose& w) const {
    double y = 1e300;
    for (int f : leg_.feet) y = std::min(y, w.positions_m[static_cast<std::size_t>(f)].y());
    return y - ground_;
  }
  // How far from the hip (horizontally) the planted ankle can stay at frame
  // i: the leg at reach_fraction of its length down to the ankle's height.
  double horizontal_reach(std::size_t i) const {
    const double down = hip(i).y() - target_.position.y();
    const double l = p_.reach_fraction * length_;
    return down < l ? std::sqrt(l * l - down * down) : 0.0;
  }
  // The foot moves onto S_G's over the steps left.
  void settle(std::size_t i) {
    const double t = 1.0 / static_cast<double>(w_.size() - i);
    target_.position += t * (goal_.position - target_.position);
    target_.rotation = target_.rotation.slerp(t, goal_.rotation);
  }
  // Lift-off at frame i. A final swing lands on S_G's foot (at S_G itself
  // when that is less than half a swing later, or when S_G has the foot in
  // the air); any other lands swing_frames_ later below the hip, ahead by
  // half the hip's travel over the swing.
  void swing_from(std::size_t i, bool final_swing, std::size_t frames) {
    const std::size_t last = w_.size() - 1;
    mode_ = Mode::swinging;
    final_swing_ = final_swing;
    from_ = target_;
    swing_start_ = i;
    land_ = std::min(last, i + frames - 1);
    if (2 * (last - land_) < frames || (final_swing && !goal_on_ground_)) land_ = last;
    if (final_swing || land_ == last) {
      final_swing_ = true;
      to_ = goal_;
      return;
    }
    const Eigen::Vector3d h = hip(land_), travel = h - hip(i - 1);
    const double t = static_cast<double>(land_) / static_cast<double>(last);
    to_.rotation = ground_rotation_.slerp(t, goal_.rotation);
    to_.position = Eigen::Vector3d(h.x() + 0.5 * travel.x(), 0.0, h.z() + 0.5 * travel.z());
    // Ankle height: the lowest foot joint kClearanceM above the ground.
    double low = 0.0;
    for (const Eigen::Vector3d& o : foot_offsets_) low = std::min(low, (to_.rotation * o).y());
    to_.position.y() = ground_ + kClearanceM - low;
  }

  const LegChain& leg_;
  const std::vector<WorldPose>& w_;
  const SteppingParams& p_;
  const std::size_t swing_frames_;
  const double ground_;
  double length_ = 0.0;
  std::vector<Eigen::Vector3d> foot_offsets_;
  Eigen::Quaterniond ground_rotation_ = Eigen::Quaterniond::Identity();
  bool start_on_ground_ = false, goal_on_ground_ = false, final_swing_ = false;
  Mode mode_ = Mode::air;
  AnklePose goal_, target_, from_, to_;
  std::size_t swing_start_ = 0, land_ = 0;
};

}  // namespace

SteppingParams stepping_params(const GapProblem& gap) {
  SteppingParams p;
  if (gap.gait_swing_s > 0.0) p.swing_s = gap.gait_swing_s;
  return p;
}

std::vector<std::vector<AnkleTarget>> plan_steps(const GapProblem& gap,
                                                 const std::vector<SynthFrame>& frames,
                                                 const SteppingParams& params) {
  const SynthSkeleton& sk = *gap.skeleton;
  const std::vector<LegChain> legs = leg_chains(sk);
  if (legs.empty() || frames.empty()) return {};
  const std::size_t n = frames.size();
  std::vector<WorldPose> w(n + 2);
  synth_world_pose(sk, gap.start, w[0]);
  for (std::size_t i = 0; i < n; ++i) synth_world_pose(sk, frames[i], w[i + 1]);
  synth_world_pose(sk, gap.goal, w[n + 1]);
  // A swing lasts swing_s, or a share of the transition for each leg.
  const double share = static_cast<double>(n + 1) / static_cast<double>(legs.size());
  const auto swing_frames = static_cast<std::size_t>(
      std::max(3.0, std::min(std::round(params.swing_s / gap.frame_time_s), std::floor(share))));
  WorldPose before, after;
  synth_world_pose(sk, gap.before, before);
  synth_world_pose(sk, gap.after, after);
  std::vector<LegSteps> steps;
  steps.reserve(legs.size());
  for (const LegChain& leg : legs)
    steps.emplace_back(leg, w, before, after, sk.model.params.ground_height_m, gap.frame_time_s,
                       params, swing_frames);
  std::vector<std::vector<AnkleTarget>> plan(n, std::vector<AnkleTarget>(legs.size()));
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t l = 0; l < legs.size(); ++l) {
      bool others_swinging = false;
      std::size_t away = 0;
      for (std::size_t k = 0; k < steps.size(); ++k) {
        if (k != l && steps[k].mode() != LegSteps::Mode::planted) others_swinging = true;
        if (steps[k].away_from_goal()) ++away;
      }
      const AnklePose* t = steps[l].advance(i, others_swinging, std::max<std::size_t>(1, away));
      plan[i - 1][l] = {t->position, t->rotation, steps[l].mode() != LegSteps::Mode::planted};
    }
  return plan;
}

double gait_swing_s(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                    double frame_time_s, const SteppingParams& params) {
  const std::vector<LegChain> legs = leg_chains(sk);
  if (legs.empty() || frames.size() < 3) return 0.0;
  const double ground = sk.model.params.ground_height_m;
  std::vector<WorldPose> w(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) synth_world_pose(sk, frames[i], w[i]);
  std::vector<double> swings;
  for (const LegChain& leg : legs) {
    std::size_t last_down = 0;
    bool seen_down = false;
    for (std::size_t i = 0; i < w.size(); ++i) {
      const std::size_t j = i > 0 ? i - 1 : i + 1;  // speeds over the step beside
      bool down = false;
      for (int f : leg.feet) {
        const auto fu = static_cast<std::size_t>(f);
        down = down || (w[i].positions_m[fu].y() - ground < params.plant_height_m &&
                        horizontal_distance(w[i].positions_m[fu], w[j].positions_m[fu]) <
                            params.plant_speed_mps * frame_time_s);
      }
      if (!down) continue;
      if (seen_down && i > last_down + 1)
        swings.push_back(static_cast<double>(i - last_down - 1) * frame_time_s);
      seen_down = true;
      last_down = i;
    }
  }
  if (swings.empty()) return 0.0;
  const auto mid = swings.begin() + static_cast<std::ptrdiff_t>(swings.size() / 2);
  std::nth_element(swings.begin(), mid, swings.end());
  return *mid;
}

void step_feet(const GapProblem& gap, std::vector<SynthFrame>& frames,
               const SteppingParams& params) {
  const std::vector<std::vector<AnkleTarget>> plan = plan_steps(gap, frames, params);
  if (plan.empty()) return;
  const SynthSkeleton& sk = *gap.skeleton;
  const std::vector<LegChain> legs = leg_chains(sk);
  WorldPose scratch;
  for (std::size_t i = 0; i < frames.size(); ++i)
    for (std::size_t l = 0; l < legs.size(); ++l)
      plant_leg(sk, gap.range, legs[l], plan[i][l].position, plan[i][l].rotation, frames[i],
                scratch);
}

}  // namespace mocap::synth_detail

namespace mocap {

void step_transition_feet(const GapProblem& gap, std::vector<SynthFrame>& frames) {
  synth_detail::check_gap(gap);
  synth_detail::step_feet(gap, frames, synth_detail::stepping_params(gap));
}

}  // namespace mocap
