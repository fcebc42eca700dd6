#pragma once
// JSON forms shared by REPORT.json (synth_report_json) and
// mocap-synth-quality's --json: one mapping each, so that the two outputs
// cannot drift apart (docs/synthesis.md lists the fields).
#include <nlohmann/json.hpp>

#include "mocap/synth/synth.hpp"

namespace mocap {

/// A transition's measures: frames, g_J, h_J, foot_sliding_m,
/// foot_sliding_slow_m, range_violations (the count) and
/// range_violation_list (range_violation_list_json), peak_angular_speed_radps,
/// step_energies_J and g_split_J ({h, adjacent, contact, joint,
/// residual_work, residual_impulse}, joules).
nlohmann::json measures_json(const TransitionMeasures& m);

/// The named range violations: an array of {frame, joint, channel, min_deg,
/// max_deg, value_deg, excess_deg} (RangeViolation), [] for none.
nlohmann::json range_violation_list_json(const std::vector<RangeViolation>& list);

/// The supplementation parameters both tools report: max_states,
/// cost_threshold_J and the refinement's (SupplementParams::refine: refine_iterations,
/// refine_smoothing_J, refine_polish_sweeps, refine_polish_window,
/// refine_polish_segments, refine_polish_smoothing_J).
nlohmann::json supplement_params_json(const SupplementParams& params);

}  // namespace mocap
