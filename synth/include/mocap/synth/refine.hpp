#pragma once
// Refinement of a transition (docs/synthesis.md "Refinement"): quasi-Newton
// iterations, then coordinate polishing, lowering the transition's g
// (measure_transition's energy_J) under the limits of the path it started
// from. refine_transition runs the whole job; TransitionRefinement holds
// its state, so that each stage can also be run (and tested) alone.
#include <tbb/enumerable_thread_specific.h>
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mocap/synth/path_cache.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

struct RefineResult {
  std::size_t steps = 0;  // accepted iterations + kept polishing moves
  double energy_before_J = 0.0;
  double energy_after_J = 0.0;
};

/// At most `iterations` quasi-Newton iterations (L-BFGS, the last 10 pairs)
/// on all inserted frames at once (each frame's root position, m, and a
/// rotation vector, rad, on every joint's local rotation but the dummies
/// above the root), minimising the transition's g. Gradients by forward
/// differences (1e-6), each recomputing only the steps the varied frame
/// touches; a step is accepted only when the whole path's g is lower (Armijo
/// condition, at most 30 halvings) and, with `keep_limits`, its foot sliding
/// is at most max(that of `frames` as given, `foot_sliding_limit_m`), its
/// peak joint angular speed at most max(that of `frames` as given,
/// end_steps_peak_angular_speed(gap), `angular_speed_limit_radps`), and it
/// has no more range violations than `frames` as given: the result is never
/// worse than the input in g (nor, with the limits, in sliding, speed or
/// violations). Stops early when no step along the gradient is accepted.
/// With `smoothing_J` = s > 0, a continuation: a quarter of the iterations
/// each on g smoothed at s, s / 10 and s / 100 joules
/// (NewtonEulerWorkspace::smoothing_J: L-BFGS stalls at the kinks of the
/// exact g, its terms being absolute values), each stage's frames kept only
/// if their exact g is lower and within the limits, then the rest on the
/// exact g. Then at most `polish_sweeps` sweeps of coordinate polishing on
/// the exact g (each variable alone, +-d with d per variable doubling on a
/// kept move and halving otherwise, from 1e-2 to 1e-5; moves evaluated and
/// applied locally, under the same limits; serial), with
/// `polish_max_window` > 1 also of runs of 2, 4, ... consecutive frames
/// moved together, with `polish_segment_moves` also of single segments
/// turned alone, and with `polish_smoothing_J` > 0 after a first pass on g
/// smoothed at that level (kept only if the exact g is lower). The sliding
/// limit has 1e-10 m of slack (the same sum as measure_transition's); the
/// local updates are checked against a rebuild after each pass
/// (std::logic_error if they disagree: a bug, not an input error). `steps`
/// counts accepted iterations and kept moves. Deterministic; an iteration
/// costs about frames x (3 + 3 x joints) local re-evaluations, the frames'
/// in parallel (TBB; the result does not depend on the thread count).
/// `frames` is replaced by the result. Throws std::invalid_argument on a bad
/// gap, frame or options (smoothing not finite or < 0, window 0).
RefineResult refine_transition(const GapProblem& gap, std::vector<SynthFrame>& frames,
                               const RefineOptions& options);

/// The refinement job: the gap, the frames (refined in place), the options,
/// and what its stages share (the path cache, the variables x of each frame
/// relative to its base frame, the limits, the L-BFGS history, scratch).
/// refine_transition(gap, frames, options) is
/// TransitionRefinement(gap, frames, options).run(). `gap` and `frames`
/// must outlive the job (the options are copied); not copyable (one job,
/// one run).
class TransitionRefinement {
 public:
  /// Checks the gap, the frames and the options (std::invalid_argument),
  /// builds the cache on the exact g and fixes the limits from `frames` as
  /// given (and the options).
  TransitionRefinement(const GapProblem& gap, std::vector<SynthFrame>& frames,
                       const RefineOptions& options);
  TransitionRefinement(const TransitionRefinement&) = delete;
  TransitionRefinement& operator=(const TransitionRefinement&) = delete;

  /// The whole refinement (refine_transition): the iterations (the smoothed
  /// stages first when options.smoothing_J > 0), then, with
  /// options.polish_sweeps > 0, polishing (a smoothed pass first, kept only
  /// if the exact g is lower, when options.polish_smoothing_J > 0, then the
  /// exact pass). Nothing when there are no frames, no iterations and no
  /// sweeps.
  RefineResult run();

  /// One L-BFGS stage: at most `iterations` iterations on the cache's g
  /// (exact, or smoothed at PathCache::smoothing_J) from the current frames,
  /// whose g on that level energy_J() must hold (as after construction).
  /// Each accepted step lowers that g and keeps the limits; energy_J() is
  /// then the new frames' g on that level.
  void lbfgs_stage(std::size_t iterations);

  /// One polishing pass (at most options.polish_sweeps sweeps) on g smoothed
  /// at `level_J` joules (0: exact), every kept move lowering that g and
  /// keeping the limits. The cache is left exact and energy_J() is the
  /// frames' exact g. std::logic_error if the local updates disagree with a
  /// rebuild.
  void polish_pass(double level_J);

  /// g of the current frames, joules, on the cache's level (exact between
  /// stages).
  double energy_J() const { return f_; }
  /// Steps so far and the energies (energy_after_J is set by run()).
  const RefineResult& result() const { return result_; }

 private:
  // Per-thread scratch of the gradient and of the polishing moves.
  struct Scratch {
    SynthFrame changed;
    Eigen::VectorXd xi;
    PathCache::DeltaScratch delta;
  };
  // A run of consecutive frames moved together by polishing.
  struct Run {
    std::size_t first, count;
  };

  // Frame i at variables x[0 .. per_) (base_[i] moved), into `out`.
  void frame_of(std::size_t i, const double* x, SynthFrame& out) const;
  // The limits on `fs`, whose poses the cache holds.
  bool within_limits(const std::vector<SynthFrame>& fs) const;
  // Forward differences of the cache's g at `at`, the frames in parallel.
  void gradient(const Eigen::VectorXd& at, Eigen::VectorXd& out);
  // The continuation: smoothed stages, each kept only if the exact g is
  // lower and within the limits, then the rest of the iterations exact.
  void smoothed_stages();
  // Polishing: the smoothed pass (kept only if the exact g is lower), then
  // the exact pass.
  void polishing();
  // Frame i + q with variable v moved by `step`, into moved_[q].
  void move(std::size_t i, std::size_t q, std::size_t v, double step, Scratch& sc);

  const GapProblem& gap_;
  std::vector<SynthFrame>& frames_;
  const RefineOptions options_;
  std::size_t m_ = 0;  // inserted frames
  // Varied joints: every joint but the dummies above the root.
  std::vector<int> joints_;
  std::size_t per_ = 0;  // variables per frame: 3 + 3 x joints
  // x = 0 of each frame (polishing's segment moves rebase a frame).
  std::vector<SynthFrame> base_;
  PathCache cache_;
  RefineResult result_;
  double f_ = 0.0;
  double slide_limit_ = 0.0;
  std::size_t violation_limit_ = 0;
  double speed_limit_ = 0.0;
  tbb::enumerable_thread_specific<Scratch> scratch_;
  // L-BFGS state.
  Eigen::VectorXd x_, grad_, grad_new_, dir_, x_new_;
  std::vector<Eigen::VectorXd> hist_s_, hist_y_;
  std::vector<double> alpha_;
  std::vector<SynthFrame> trial_;
  // Polishing moves: the runs, the joints of segment moves and their
  // children, variables per run (per_ + 3 per segment joint), step sizes,
  // the moved frames.
  std::vector<Run> runs_;
  std::vector<std::vector<int>> children_;
  std::vector<int> segment_joints_;
  std::size_t vars_ = 0;
  std::vector<double> d_;
  std::vector<SynthFrame> moved_;
};

}  // namespace mocap
