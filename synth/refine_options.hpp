// The refinement options of mocap-synth and mocap-synth-quality (one
// declaration for both tools; docs/synthesis.md "Refinement") and the check
// of the supplementation values read from their command lines.
#pragma once

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstddef>

#include "mocap/common/util/error.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

inline void add_refine_options(CLI::App& app, SupplementParams& params) {
  app.add_option("--refine", params.refine.iterations,
                 "after the A* search, at most N iterations lowering g on the whole transition "
                 "(about 4 ms each; 0: none)")
      ->check(CLI::Range(std::size_t{0}, std::size_t{100000}))
      ->capture_default_str();
  app.add_option("--refine-smoothing", params.refine.smoothing_J,
                 "with --refine: start on g smoothed at this many joules, then a tenth, a "
                 "hundredth, then exact (a quarter of the iterations each; 0: exact throughout)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  app.add_option("--refine-polish", params.refine.polish_sweeps,
                 "after the refinement's iterations (if any), at most this many sweeps of "
                 "coordinate polishing per pass (slow: seconds per gap; 0: none)")
      ->check(CLI::Range(std::size_t{0}, std::size_t{100000}))
      ->capture_default_str();
  app.add_option("--refine-polish-window", params.refine.polish_max_window,
                 "with --refine-polish: also move one variable of up to this many consecutive "
                 "frames together (2, 4, ... frames; 1: single frames only)")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1024}))
      ->capture_default_str();
  app.add_flag("--refine-polish-segments", params.refine.polish_segment_moves,
               "with --refine-polish: also turn single segments (a joint one way, its children "
               "back)");
  app.add_option("--refine-polish-smoothing", params.refine.polish_smoothing_J,
                 "with --refine-polish: a first pass on g smoothed at this many joules, then the "
                 "exact pass (0: exact only). Deep setting: --refine-polish 100 "
                 "--refine-polish-window 8 --refine-polish-smoothing 0.3")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
}

/// The values read from the command line that CLI11's ranges let through
/// (NaN passes a range check): InputError naming the option. T_c must be a
/// number >= 0 joules, the smoothing levels finite.
inline void check_supplement_options(const SupplementParams& params) {
  if (!(params.cost_threshold_J >= 0.0)) throw InputError("--cost-threshold", 0, "must be >= 0");
  if (!std::isfinite(params.refine.smoothing_J))
    throw InputError("--refine-smoothing", 0, "must be a finite number of joules >= 0");
  if (!std::isfinite(params.refine.polish_smoothing_J))
    throw InputError("--refine-polish-smoothing", 0, "must be a finite number of joules >= 0");
}

}  // namespace mocap
