#pragma once
// Supplementation (paper section 2.4, figure 4) and its baselines.
//
// A gap joins a start state S_0 (with its predecessor S_-1, which gives its
// velocity) to a goal S_G (with its successor S_G+1) at the frame time dt.
// The transition is the list of inserted frames S_1..S_m; the energy of a
// transition is the sum of the full energy change g over its steps
// S_0 -> S_1 -> ... -> S_m -> S_G, every state's rates by central differences
// over the whole sequence S_-1 .. S_G+1 (dynamics.hpp sequence_state).
//
// Three methods (docs/synthesis.md):
//  - astar: best-first search over states, one state accepted per iteration
//    (the paper's OPEN/CLOSED loop), over the length whose geodesic path has
//    the lowest g (choose_transition_frames): from the current state the base
//    proposal is the geodesic step toward the goal, or that step with a foot
//    that is on the ground kept in place (inverse kinematics of the leg,
//    plant_feet); it is refined joint by joint: the
//    joints with the largest terms of g(current -> proposal), in decreasing
//    order, each mapped to its adjacent joint that stands highest; that
//    joint's local rotation is varied (velocity-continuing Hermite rotation,
//    half way to it, the step scaled), clamped to the range of motion, and
//    the variant with the lowest f = g(steps it changes) + the estimate of
//    the rest (the geodesic completion from it to the goal, costed step by
//    step by g; by h between its first and last two steps when
//    exact_lookahead is off) is kept, provided it slides
//    the feet no more than the geodesic completion. Stops when
//    g(S -> S_G) < T_c, when the planned length is used up, or after T_n.
//    Where the path's feet skate, the stepping pass (step_feet) then turns
//    the legs so that planted feet stay and moving feet step. Optionally
//    followed by refine_transition (refine.hpp; SupplementParams::refine):
//    L-BFGS on every inserted frame at once, exact g.
//  - slerp: linear root, slerp per joint, the same number of frames;
//  - inertialize: the goal pose (extrapolated backwards with its own
//    velocity) plus the start offset decayed by Bollo's quintic.
// All deterministic; time bounded by T_n x candidates per iteration.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"

namespace mocap {

/// The refinement's settings (refine_transition, mocap/synth/refine.hpp).
struct RefineOptions {
  std::size_t iterations = 0;
  /// Metres; the input's own sliding is always allowed.
  double foot_sliding_limit_m = 0.0;
  /// false: no sliding, speed or range condition (measures how low g can go).
  bool keep_limits = true;
  /// Joules, >= 0 (finite); 0: no smoothed stages.
  double smoothing_J = 0.0;
  /// After the iterations: at most this many sweeps of coordinate polishing
  /// on the exact g (every variable of every frame tried alone, +-d); 0: none.
  std::size_t polish_sweeps = 0;
  /// rad/s; the input's own peak (TransitionMeasures::peak_angular_speed_radps)
  /// and end_steps_peak_angular_speed(gap) are always allowed.
  double angular_speed_limit_radps = 0.0;
  /// Polishing also moves one variable of w consecutive frames together,
  /// w = 2, 4, ... up to this (>= 1); 1: single frames only.
  std::size_t polish_max_window = 1;
  /// Polishing also turns each segment alone (its joint one way, the
  /// joint's children back).
  bool polish_segment_moves = false;
  /// Joules, >= 0 (finite); > 0: a polishing pass on g smoothed at this
  /// level first, then the exact pass.
  double polish_smoothing_J = 0.0;
};

enum class TransitionMethod { astar, slerp, inertialize };
const char* transition_method_name(TransitionMethod m);

/// The energy the A* search minimises (docs/synthesis.md "The search's
/// energy"): the paper's g (newton_euler.hpp) or W, the work energy
/// (work_energy.hpp; its unsupported force priced at the default 5 m/s).
enum class SearchEnergy { g, work };

struct SupplementParams {
  /// The search's step cost, its stop test (T_c) and its choice of the
  /// joints to vary. Default W (docs/synthesis.md "The search's energy":
  /// the energy that ranks captured locomotion above a glide); g is the
  /// paper's.
  SearchEnergy energy = SearchEnergy::work;
  /// T_n: at most this many inserted states (frames) per gap.
  std::size_t max_states = 60;
  /// T_c: stop when the step cost g(S -> S_G) is below this, joules.
  double cost_threshold_J = 5.0;
  /// Costliest joints refined per iteration.
  std::size_t joints_per_iteration = 3;
  /// Reference speeds for the initial length estimate: the largest joint
  /// rotation over ref_angular_speed, root displacement over ref_speed.
  double ref_angular_speed_radps = 4.0;
  double ref_speed_mps = 1.5;
  /// Root translation of the base proposal: the velocity-matching Hermite
  /// step (true) or the straight line (false).
  bool smooth_root = false;
  /// Cost every step of a candidate's geodesic completion with g (default:
  /// the path's g can then only go down from the geodesic's); false: g on
  /// its first and last two steps, h (the paper's heuristic) between.
  bool exact_lookahead = true;
  /// Contact-aware proposals: a foot within contact height of the ground in
  /// the current state is kept in place (its leg turned by inverse kinematics).
  bool plant_feet = true;
  /// After the search, where its path's feet skate: the stepping pass
  /// (step_transition_feet), kept when it skates in fewer steps. Feet on
  /// the ground stay planted; a foot that must move is lifted and set down
  /// ahead. Off by default: it removes the skating but raises W by 59-70 %
  /// and doubles the peak joint speed against the capture's
  /// (docs/synthesis.md "Stepping"); false: the search's own legs.
  bool step_feet = false;
  /// Choose the length (choose_transition_frames) instead of taking the
  /// estimate.
  bool choose_length = true;
  /// > 0: exactly this many inserted frames (timed key poses: the time is
  /// given); the search then runs to its horizon (no T_c stop) and T_n
  /// does not cap it. 0: the length is chosen (choose_length).
  std::size_t fixed_frames = 0;
  /// Shortest transition considered by the estimate, seconds.
  double min_duration_s = 0.1;
  /// After the search: the refinement of the whole path (refine_transition,
  /// mocap/synth/refine.hpp); none when refine.iterations and refine.polish_sweeps
  /// are 0 (the default, which the median-time goal is measured with).
  /// supplement_astar sets refine.foot_sliding_limit_m and
  /// refine.angular_speed_limit_radps to those of the slerp transition of
  /// the same length (the values given are not used): the feet slide at most
  /// as much as in that slerp (a stepped path: as much as in itself) and no
  /// joint turns faster than in it, in the path or in the captured steps at
  /// either end. The refinement runs after the stepping pass.
  RefineOptions refine;
};

struct GapProblem {
  const SynthSkeleton* skeleton = nullptr;
  const RangeOfMotion* range = nullptr;
  SynthFrame before;  // S_-1
  SynthFrame start;   // S_0
  SynthFrame goal;    // S_G
  SynthFrame after;   // S_G+1
  double frame_time_s = 0.0;
  /// The swing of the gait on either side of the gap, seconds: the median
  /// swing of the partial motion's legs (gait_swing_s in synth/src), which
  /// the stepping proposals and the stepping pass give their swings; 0 when
  /// unknown (the motion there does not step): 0.4 s.
  double gait_swing_s = 0.0;
};

struct SupplementStats {
  std::size_t iterations = 0;
  std::size_t energy_evaluations = 0;
  /// Length estimate the Hermite proposals started from.
  std::size_t estimated_frames = 0;
  /// Why the search stopped: "threshold" (g(S -> S_G) < T_c), "horizon"
  /// (the Hermite path's planned length was used up), "max_states" (T_n).
  std::string stop_reason;
  /// Refinement (SupplementParams::refine): steps accepted, and
  /// how much g they took off the search's path, joules.
  std::size_t refine_steps = 0;
  double refine_gain_J = 0.0;
  /// The stepping pass (SupplementParams::step_feet) replaced the legs.
  bool stepped = false;
};

/// Initial length estimate (frames to insert), in [1, max_states].
std::size_t estimate_transition_frames(const GapProblem& gap, const SupplementParams& params);

/// The length the supplementation plans with: among 1 .. min(T_n, 2 x the
/// estimate + 2) inserted frames, the one whose geodesic (slerp) transition
/// has the lowest g (a coarse grid, then every length around its best point);
/// the estimate itself when params.choose_length is false.
std::size_t choose_transition_frames(const GapProblem& gap, const SupplementParams& params);

/// A*-based supplementation (header). Throws std::invalid_argument on a bad gap.
std::vector<SynthFrame> supplement_astar(const GapProblem& gap, const SupplementParams& params,
                                         SupplementStats* stats = nullptr);
/// Largest local joint angular speed (TransitionMeasures::peak_angular_speed_radps's
/// definition), rad/s, of the captured steps at the gap's ends, S_-1 -> S_0
/// and S_G -> S_G+1: how fast the clips themselves turn a joint there.
double end_steps_peak_angular_speed(const GapProblem& gap);

/// The stepping pass of supplement_astar (SupplementParams::step_feet) on
/// any transition of `gap` (`frames` changed in place: the legs' rotations):
/// feet on the ground stay planted, and a foot that must move is lifted and
/// set down ahead (docs/synthesis.md "Stepping").
void step_transition_feet(const GapProblem& gap, std::vector<SynthFrame>& frames);

/// `frames` inserted frames: root linear, joints slerp, at i / (frames + 1).
std::vector<SynthFrame> slerp_transition(const GapProblem& gap, std::size_t frames);
/// `frames` inserted frames of inertialization toward the goal (header).
std::vector<SynthFrame> inertialize_transition(const GapProblem& gap, std::size_t frames);

/// One (inserted frame, joint) pair outside the range of motion
/// (RangeOfMotion: the union of the captured channel ranges of the
/// skeleton's clips; within_range's test, 0.5 degree slack): the channel
/// furthest outside, in the Euler solution and 360-degree turn nearest the
/// range.
struct RangeViolation {
  /// The inserted frame, 0 = the transition's first.
  std::size_t frame = 0;
  std::string joint;    // the skeleton's joint name
  std::string channel;  // "Xrotation", "Yrotation" or "Zrotation"
  /// The channel's range and its value, degrees (value outside [min, max]).
  double min_deg = 0.0, max_deg = 0.0, value_deg = 0.0;
  /// How far outside the range the value is, degrees (> 0.5: the slack).
  double excess_deg = 0.0;
};

/// The measures of a transition (the report's).
struct TransitionMeasures {
  std::size_t frames = 0;
  /// Sum of g over the steps S_0 -> ... -> S_G, joules.
  double energy_J = 0.0;
  /// Sum of h over the same steps, joules.
  double approximate_energy_J = 0.0;
  /// Horizontal displacement of foot / toe contact points while in contact
  /// (within EnergyParams::contact_height_m of the ground in both frames of
  /// a step, however fast they move), metres, over the same steps.
  double foot_sliding_m = 0.0;
  /// The part of foot_sliding_m at contact speed: steps in which a contact
  /// point moves horizontally at most EnergyParams::contact_speed_mps
  /// (0.8 m/s). The rest is faster: a foot swinging low, or gliding.
  double foot_sliding_slow_m = 0.0;
  /// Foot-skating ratio (docs/synthesis.md "Measures"): the fraction of the
  /// same steps in which a foot or toe joint is below 5 cm above the ground
  /// in both frames while moving horizontally faster than 0.5 m/s.
  double skating_ratio = 0.0;
  /// Mean horizontal speed of those joints in those steps, m/s (0: none).
  double skating_speed_mps = 0.0;
  /// Airborne ratio: the fraction of the same steps in which every foot and
  /// toe joint is 5 cm or more above the ground in both frames (no foot on
  /// the ground: a flight phase, or feet floating).
  double airborne_ratio = 0.0;
  /// (frame, joint) pairs of the inserted frames outside the range of motion.
  std::size_t range_violations = 0;
  /// Those pairs named, in frame then joint order (range_violations of them).
  std::vector<RangeViolation> range_violation_list;
  /// max over steps and joints of |log(q_f+1 q_f^-1)| / dt, local rotations, rad/s.
  double peak_angular_speed_radps = 0.0;
  /// W, the work energy (work_energy.hpp), over the same steps, and its
  /// unsupported part (v_u T |F_res|: the support no contact gives), joules.
  double work_energy_J = 0.0;
  double unsupported_J = 0.0;
  /// The fraction of the states S_0 .. S_G with no contact point on the
  /// ground (inverse_dynamics's contact test).
  double no_contact_ratio = 0.0;
  /// g of each step (frames + 1 values), joules.
  std::vector<double> step_energies_J;
  /// energy_J split by term (docs/energy.md, "g"), summed over the same
  /// steps; the six add up to energy_J. h_J is the h part of g (equal to
  /// approximate_energy_J up to round-off), adjacent_J the work of the
  /// adjacent segments' forces, contact_J the ground reaction's (friction
  /// included), joint_J the joint torques', residual_work_J and
  /// residual_impulse_J the root residual's (what no contact supplies).
  struct EnergySplit {
    double h_J = 0.0;
    double adjacent_J = 0.0;
    double contact_J = 0.0;
    double joint_J = 0.0;
    double residual_work_J = 0.0;
    double residual_impulse_J = 0.0;
    /// Adds `o` term by term (sums over transitions).
    EnergySplit& operator+=(const EnergySplit& o) {
      h_J += o.h_J;
      adjacent_J += o.adjacent_J;
      contact_J += o.contact_J;
      joint_J += o.joint_J;
      residual_work_J += o.residual_work_J;
      residual_impulse_J += o.residual_impulse_J;
      return *this;
    }
  } energy_split;
};
TransitionMeasures measure_transition(const GapProblem& gap, const std::vector<SynthFrame>& frames);

/// The sliding measures of a whole motion (every step of `frames`).
struct MotionMeasures {
  double foot_sliding_m = 0.0;
  double foot_sliding_slow_m = 0.0;  // TransitionMeasures::foot_sliding_slow_m
  double skating_ratio = 0.0;
  double skating_speed_mps = 0.0;
  double airborne_ratio = 0.0;
};
MotionMeasures measure_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                              double frame_time_s);

/// Per-step g along a whole motion (frames.size() - 1 values; rates by
/// central differences, one-sided at the ends), and the foot sliding of the
/// motion. Used for the report's energy curve.
std::vector<double> motion_step_energies(const SynthSkeleton& sk,
                                         const std::vector<SynthFrame>& frames,
                                         double frame_time_s);

}  // namespace mocap

namespace mocap {

/// Horizontal root velocity of `b` from its predecessor `a`, m/s.
Eigen::Vector3d horizontal_root_velocity(const SynthFrame& a, const SynthFrame& b, double dt);

/// The rigid placement (yaw + horizontal translation) that makes a piece
/// starting with `first` (velocity v_first, horizontal, m/s, in the piece's
/// own frame) continue from a state `end` (velocity v_end): the piece is
/// turned so that its first heading is `heading_rad` (default: end's heading)
/// and moved so that its first root lands, horizontally, at
///   end.root + (v_end + v_first') / 2 * travel_time_s
/// (v_first' = v_first turned), i.e. where the mean of the two velocities
/// carries the root during the gap. Height is kept.
Placement continuation_placement(const SynthSkeleton& sk, const SynthFrame& end,
                                 const Eigen::Vector3d& v_end, const SynthFrame& first,
                                 const Eigen::Vector3d& v_first, double travel_time_s,
                                 const double* heading_rad = nullptr);

}  // namespace mocap
