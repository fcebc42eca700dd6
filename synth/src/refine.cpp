// The refinement of a transition (refine.hpp): the job's setup and limits,
// its L-BFGS stages (exact and smoothed) and its coordinate polishing.
#include "mocap/synth/refine.hpp"

#include <tbb/parallel_for.h>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

#include "measures.hpp"
#include "transition_math.hpp"

namespace mocap {

using synth_detail::count_range_violations;
using synth_detail::frame_range_violations;
using synth_detail::peak_angular_speed;
using synth_detail::quat_exp;
using synth_detail::step_peak_angular_speed;

TransitionRefinement::TransitionRefinement(const GapProblem& gap, std::vector<SynthFrame>& frames,
                                           const RefineOptions& options)
    : gap_(gap), frames_(frames), options_(options), m_(frames.size()) {
  synth_detail::check_gap(gap);
  if (!(options.smoothing_J >= 0.0) || !std::isfinite(options.smoothing_J) ||
      !(options.polish_smoothing_J >= 0.0) || !std::isfinite(options.polish_smoothing_J))
    throw std::invalid_argument("refinement smoothing must be a finite number of joules >= 0");
  if (options.polish_max_window == 0)
    throw std::invalid_argument("polishing window must be at least 1 frame");
  const SynthSkeleton& sk = *gap.skeleton;
  const std::size_t n = sk.joint_count();
  for (const SynthFrame& f : frames)
    if (f.local_rotations.size() != n)
      throw std::invalid_argument("transition frame does not fit the skeleton");
  f_ = cache_.build(gap, frames);
  result_.energy_before_J = result_.energy_after_J = f_;
  // Variables of each frame: root position (m), then a rotation vector (rad)
  // per varied joint, applied on the right of the frame's rotation as given.
  for (std::size_t j = 0; j < n; ++j)
    if (!sk.is_root_chain[j] || static_cast<int>(j) == sk.root_joint)
      joints_.push_back(static_cast<int>(j));
  per_ = 3 + 3 * joints_.size();
  base_ = frames;
  // The limit checks sum the sliding in measure_transition's order
  // (PathCache::foot_sliding_with). The 0.1 nm slack lets a step through
  // whose planted feet move by round-off only; it is room the search uses
  // up, so it stays far below what the measures' comparisons allow (1e-9).
  slide_limit_ = std::max(cache_.foot_sliding(gap), options.foot_sliding_limit_m) + 1e-10;
  violation_limit_ = count_range_violations(gap, frames);
  speed_limit_ = std::max({peak_angular_speed(gap, frames), end_steps_peak_angular_speed(gap),
                           options.angular_speed_limit_radps}) +
                 1e-9;
  x_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m_ * per_));
  trial_.resize(m_);
  // Polishing's runs: every frame alone, then with polish_max_window = W > 1
  // runs of w = 2, 4, ... <= W frames overlapping by half, and the last w
  // frames when the runs miss them.
  for (std::size_t i = 0; i < m_; ++i) runs_.push_back({i, 1});
  for (std::size_t w = 2; w <= std::min(options.polish_max_window, m_); w *= 2) {
    std::size_t first = 0;
    for (; first + w <= m_; first += w / 2) runs_.push_back({first, w});
    if (first - w / 2 + w < m_) runs_.push_back({m_ - w, w});  // the last frames
  }
  children_.resize(n);
  if (options.polish_segment_moves)
    for (const int j : joints_)
      if (!(children_[static_cast<std::size_t>(j)] = sk.skeleton.children(j)).empty())
        segment_joints_.push_back(j);
  vars_ = per_ + 3 * segment_joints_.size();
  moved_.resize(std::min(options.polish_max_window, m_));
}

RefineResult TransitionRefinement::run() {
  if (m_ == 0 || (options_.iterations == 0 && options_.polish_sweeps == 0)) return result_;
  if (options_.smoothing_J > 0.0) {
    smoothed_stages();
  } else if (options_.iterations > 0) {
    lbfgs_stage(options_.iterations);
  }
  if (options_.polish_sweeps > 0) polishing();
  result_.energy_after_J = f_;
  return result_;
}

void TransitionRefinement::frame_of(std::size_t i, const double* x, SynthFrame& out) const {
  out = base_[i];
  out.root_position_m += Eigen::Vector3d(x[0], x[1], x[2]);
  for (std::size_t k = 0; k < joints_.size(); ++k) {
    const auto j = static_cast<std::size_t>(joints_[k]);
    out.local_rotations[j] = (base_[i].local_rotations[j] *
                              quat_exp(Eigen::Vector3d(x[3 + 3 * k], x[4 + 3 * k], x[5 + 3 * k])))
                                 .normalized();
  }
}

bool TransitionRefinement::within_limits(const std::vector<SynthFrame>& fs) const {
  return !options_.keep_limits || (cache_.foot_sliding(gap_) <= slide_limit_ &&
                                   count_range_violations(gap_, fs) <= violation_limit_ &&
                                   peak_angular_speed(gap_, fs) <= speed_limit_);
}

void TransitionRefinement::gradient(const Eigen::VectorXd& at, Eigen::VectorXd& out) {
  // Forward differences, the cache holding the transition at `at`; each
  // component is computed alone (the same result for every thread count).
  constexpr double eps = 1e-6;
  out.resize(static_cast<Eigen::Index>(m_ * per_));
  tbb::parallel_for(std::size_t{0}, m_, [&](std::size_t i) {
    Scratch& sc = scratch_.local();
    for (std::size_t v = 0; v < per_; ++v) {
      sc.xi = at.segment(static_cast<Eigen::Index>(i * per_), static_cast<Eigen::Index>(per_));
      sc.xi[static_cast<Eigen::Index>(v)] += eps;
      frame_of(i, sc.xi.data(), sc.changed);
      out[static_cast<Eigen::Index>(i * per_ + v)] =
          cache_.delta(gap_, i, 1, &sc.changed, sc.delta) / eps;
    }
  });
}

void TransitionRefinement::lbfgs_stage(std::size_t iterations) {
  // L-BFGS (the last 10 pairs, two-loop recursion) on the cache's g (exact,
  // or smoothed), from x / frames / f.
  hist_s_.clear();
  hist_y_.clear();
  gradient(x_, grad_);
  for (std::size_t it = 0; it < iterations; ++it) {
    dir_ = -grad_;
    alpha_.assign(hist_s_.size(), 0.0);
    for (std::size_t k = hist_s_.size(); k-- > 0;) {
      alpha_[k] = hist_s_[k].dot(dir_) / hist_y_[k].dot(hist_s_[k]);
      dir_ -= alpha_[k] * hist_y_[k];
    }
    if (!hist_s_.empty())
      dir_ *= hist_s_.back().dot(hist_y_.back()) / hist_y_.back().dot(hist_y_.back());
    for (std::size_t k = 0; k < hist_s_.size(); ++k)
      dir_ += hist_s_[k] * (alpha_[k] - hist_y_[k].dot(dir_) / hist_y_[k].dot(hist_s_[k]));
    if (!(dir_.dot(grad_) < 0.0)) {
      dir_ = -grad_;
      hist_s_.clear();
      hist_y_.clear();
    }
    const double slope = dir_.dot(grad_), biggest = dir_.cwiseAbs().maxCoeff();
    if (!(slope < 0.0) || !(biggest > 0.0)) break;
    // Steepest descent starts at 1 mm / 1 mrad for the largest component.
    double step = hist_s_.empty() ? 1e-3 / biggest : 1.0;
    bool accepted = false;
    double f_new = f_;
    for (int halvings = 0; halvings < 30 && !accepted; ++halvings, step *= 0.5) {
      x_new_ = x_ + step * dir_;
      for (std::size_t i = 0; i < m_; ++i) frame_of(i, x_new_.data() + i * per_, trial_[i]);
      f_new = cache_.build(gap_, trial_);
      accepted = f_new < f_ + 1e-4 * step * slope && within_limits(trial_);
    }
    if (!accepted) {
      cache_.build(gap_, frames_);
      if (hist_s_.empty()) break;  // no descent step even along the gradient
      hist_s_.clear();             // retry along the gradient
      hist_y_.clear();
      continue;
    }
    frames_ = trial_;
    gradient(x_new_, grad_new_);
    Eigen::VectorXd sv = x_new_ - x_, yv = grad_new_ - grad_;
    if (sv.dot(yv) > 1e-12) {
      if (hist_s_.size() == 10) {
        hist_s_.erase(hist_s_.begin());
        hist_y_.erase(hist_y_.begin());
      }
      hist_s_.push_back(std::move(sv));
      hist_y_.push_back(std::move(yv));
    }
    x_.swap(x_new_);
    grad_.swap(grad_new_);
    f_ = f_new;
    ++result_.steps;
  }
}

void TransitionRefinement::smoothed_stages() {
  // Continuation: s, s / 10, s / 100, then the exact g; after each smoothed
  // stage the frames are kept only if their exact g is lower and within
  // the limits (a smoothed step may raise the exact g).
  const std::size_t per_stage = options_.iterations / 4;
  std::vector<SynthFrame> kept = frames_;
  Eigen::VectorXd kept_x = x_;
  double kept_g = f_;
  double level = options_.smoothing_J;
  for (int stage = 0; stage < 3 && per_stage > 0; ++stage, level *= 0.1) {
    cache_.smoothing_J = level;
    f_ = cache_.build(gap_, frames_);
    lbfgs_stage(per_stage);
    cache_.smoothing_J = 0.0;
    const double exact = cache_.build(gap_, frames_);
    if (exact < kept_g && within_limits(frames_)) {
      kept = frames_;
      kept_x = x_;
      kept_g = exact;
    } else {
      frames_ = kept;
      x_ = kept_x;
    }
  }
  f_ = cache_.build(gap_, frames_);
  lbfgs_stage(options_.iterations - 3 * per_stage);
}

void TransitionRefinement::move(std::size_t i, std::size_t q, std::size_t v, double step,
                                Scratch& sc) {
  if (v < per_) {
    sc.xi = x_.segment(static_cast<Eigen::Index>((i + q) * per_), static_cast<Eigen::Index>(per_));
    sc.xi[static_cast<Eigen::Index>(v)] += step;
    frame_of(i + q, sc.xi.data(), moved_[q]);
    return;
  }
  const auto j = static_cast<std::size_t>(segment_joints_[(v - per_) / 3]);
  Eigen::Vector3d turn = Eigen::Vector3d::Zero();
  turn[static_cast<Eigen::Index>((v - per_) % 3)] = step;
  SynthFrame& out = moved_[q];
  out = frames_[i + q];
  out.local_rotations[j] = (out.local_rotations[j] * quat_exp(turn)).normalized();
  for (const int c : children_[j]) {
    Eigen::Quaterniond& rc = out.local_rotations[static_cast<std::size_t>(c)];
    rc = (quat_exp(-turn) * rc).normalized();
  }
}

void TransitionRefinement::polish_pass(double level_J) {
  // Coordinate polishing (it moves along the kinks where the quasi-Newton
  // steps stall): each variable tried +-d on its own, d doubling (to 0.1)
  // when a move is kept and halving when neither direction lowers g; a
  // variable is done below 1e-5. Moves:
  // - one variable of one frame (x);
  // - with polish_max_window = W > 1, the same variable of a run of w
  //   consecutive frames together (runs_): the rates inside the run barely
  //   change (root velocities not at all; a joint's relative turn keeps its
  //   angle) and those at its ends do, a direction single moves cannot take;
  // - with polish_segment_moves, one segment turned alone on one axis: its
  //   joint turned one way and each child turned back, so that the
  //   subtree keeps its orientations (and is carried); variables
  //   per + 3 k .. per + 3 k + 2 for segment_joints[k]. Such a move
  //   rebases its frames (base = the frame, x = 0).
  // Each move is evaluated locally (delta), kept only if g drops and the
  // limits hold (the path's sliding with the moved poses, the speeds of the
  // steps they touch, their frames' violations), and applied to the cache
  // in place. Serial, hence deterministic.
  Scratch& sc = scratch_.local();
  cache_.smoothing_J = level_J;
  f_ = cache_.build(gap_, frames_);
  std::size_t violations = count_range_violations(gap_, frames_);
  d_.assign(runs_.size() * vars_, 1e-2);
  for (std::size_t sweep = 0; sweep < options_.polish_sweeps; ++sweep) {
    bool active = false;
    for (std::size_t r = 0; r < runs_.size(); ++r) {
      const auto [i, count] = runs_[r];
      for (std::size_t v = 0; v < vars_; ++v) {
        double& dv = d_[r * vars_ + v];
        if (dv < 1e-5) continue;
        active = true;
        bool kept = false;
        for (const double sign : {1.0, -1.0}) {
          for (std::size_t q = 0; q < count; ++q) move(i, q, v, sign * dv, sc);
          const double dg = cache_.delta(gap_, i, count, moved_.data(), sc.delta);
          if (!(dg < -1e-12)) continue;
          std::size_t new_violations = violations;
          if (options_.keep_limits) {
            for (std::size_t q = 0; q < count; ++q)
              new_violations = new_violations + frame_range_violations(gap_, moved_[q]) -
                               frame_range_violations(gap_, frames_[i + q]);
            if (new_violations > violation_limit_ ||
                cache_.foot_sliding_with(gap_, i + 2, count, sc.delta.w_changed.data()) >
                    slide_limit_)
              continue;
            bool too_fast = false;
            for (std::size_t q = 0; q <= count && !too_fast; ++q) {
              const SynthFrame& a = q > 0 ? moved_[q - 1] : i == 0 ? gap_.start : frames_[i - 1];
              const SynthFrame& b = q < count         ? moved_[q]
                                    : i + count == m_ ? gap_.goal
                                                      : frames_[i + count];
              too_fast = step_peak_angular_speed(gap_, a, b) > speed_limit_;
            }
            if (too_fast) continue;
          }
          cache_.apply(i, count, sc.delta);
          for (std::size_t q = 0; q < count; ++q) {
            std::swap(frames_[i + q], moved_[q]);
            const auto xs = static_cast<Eigen::Index>((i + q) * per_);
            if (v < per_) {
              x_[xs + static_cast<Eigen::Index>(v)] += sign * dv;
            } else {
              base_[i + q] = frames_[i + q];
              x_.segment(xs, static_cast<Eigen::Index>(per_)).setZero();
            }
          }
          violations = new_violations;
          kept = true;
          ++result_.steps;
          break;
        }
        dv = kept ? std::min(0.1, 2.0 * dv) : 0.5 * dv;
      }
    }
    if (!active) break;
  }
  // The cache was updated move by move: it must hold what a rebuild gives
  // (a wrong local update would fail here rather than mislead).
  const double cached = std::accumulate(cache_.steps.begin(), cache_.steps.end(), 0.0);
  // The sum over the whole path (the measure's order of additions).
  f_ = cache_.build(gap_, frames_);
  if (!(std::abs(cached - f_) <= 1e-6 * std::max(1.0, std::abs(f_))))
    throw std::logic_error("refine_transition: polishing's local updates left the path");
  if (level_J > 0.0) {
    cache_.smoothing_J = 0.0;
    f_ = cache_.build(gap_, frames_);
  }
}

void TransitionRefinement::polishing() {
  if (options_.polish_smoothing_J > 0.0) {
    // A pass on the smoothed g first (it slides along the rounded kinks),
    // kept only if the exact g is lower (each move kept the limits).
    const std::vector<SynthFrame> kept_frames = frames_, kept_base = base_;
    const Eigen::VectorXd kept_x = x_;
    const double kept_g = f_;  // exact: the iterations end on the exact g
    polish_pass(options_.polish_smoothing_J);
    if (!(f_ < kept_g)) {
      frames_ = kept_frames;
      base_ = kept_base;
      x_ = kept_x;
    }
  }
  polish_pass(0.0);
}

RefineResult refine_transition(const GapProblem& gap, std::vector<SynthFrame>& frames,
                               const RefineOptions& options) {
  return TransitionRefinement(gap, frames, options).run();
}

}  // namespace mocap
