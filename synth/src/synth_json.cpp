// JSON forms of the measures and parameters (synth_json.hpp).
#include "mocap/synth/synth_json.hpp"

namespace mocap {

nlohmann::json range_violation_list_json(const std::vector<RangeViolation>& list) {
  nlohmann::json out = nlohmann::json::array();
  for (const RangeViolation& v : list)
    out.push_back({{"frame", v.frame},
                   {"joint", v.joint},
                   {"channel", v.channel},
                   {"min_deg", v.min_deg},
                   {"max_deg", v.max_deg},
                   {"value_deg", v.value_deg},
                   {"excess_deg", v.excess_deg}});
  return out;
}

nlohmann::json measures_json(const TransitionMeasures& m) {
  return {{"frames", m.frames},
          {"g_J", m.energy_J},
          {"g_paper_J", m.energy_J},
          {"h_J", m.approximate_energy_J},
          {"foot_sliding_m", m.foot_sliding_m},
          {"foot_sliding_slow_m", m.foot_sliding_slow_m},
          {"foot_skating_ratio", m.skating_ratio},
          {"skating_speed_mps", m.skating_speed_mps},
          {"airborne_ratio", m.airborne_ratio},
          {"w_J", m.work_energy_J},
          {"unsupported_J", m.unsupported_J},
          {"no_contact_ratio", m.no_contact_ratio},
          {"range_violations", m.range_violations},
          {"range_violation_list", range_violation_list_json(m.range_violation_list)},
          {"peak_angular_speed_radps", m.peak_angular_speed_radps},
          {"step_energies_J", m.step_energies_J},
          {"g_split_J",
           {{"h", m.energy_split.h_J},
            {"adjacent", m.energy_split.adjacent_J},
            {"contact", m.energy_split.contact_J},
            {"joint", m.energy_split.joint_J},
            {"residual_work", m.energy_split.residual_work_J},
            {"residual_impulse", m.energy_split.residual_impulse_J}}}};
}

nlohmann::json supplement_params_json(const SupplementParams& params) {
  return {{"energy", params.energy == SearchEnergy::work ? "w" : "g"},
          {"max_states", params.max_states},
          {"cost_threshold_J", params.cost_threshold_J},
          {"step_feet", params.step_feet},
          {"refine_iterations", params.refine.iterations},
          {"refine_smoothing_J", params.refine.smoothing_J},
          {"refine_polish_sweeps", params.refine.polish_sweeps},
          {"refine_polish_window", params.refine.polish_max_window},
          {"refine_polish_segments", params.refine.polish_segment_moves},
          {"refine_polish_smoothing_J", params.refine.polish_smoothing_J}};
}

}  // namespace mocap
