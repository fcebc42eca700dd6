// What the reports' foot and range measures mean, in words (private to
// synth/src): REPORT.json's "about_measures" and "foot_contacts", the HTML
// report's notes and mocap-synth's printed summary (synth_report_text) take
// their sentences from here, so that the three say the same thing.
// Units: metres, m/s, degrees.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "measures.hpp"
#include "mocap/synth/synth.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap::synth_detail {

/// Why the contact-based foot sliding and the skating ratio can disagree
/// (4 m of sliding and a skating ratio of 0.00 in one walk), with the
/// motion's own numbers and both thresholds: sliding counts every contact
/// point within contact_height_m (10 cm), at any speed, so a foot swinging
/// low adds to it; skating needs a joint origin below 5 cm moving faster
/// than 0.5 m/s, which a planted foot never does.
std::string sliding_skating_note(const EnergyParams& ep, const MotionMeasures& m);

/// The range violations of one joint channel, over a transition's frames.
struct RangeViolationGroup {
  std::string joint, channel;
  double min_deg = 0.0, max_deg = 0.0;  // the channel's range, degrees
  std::size_t frames = 0;               // violations of this joint channel
  double worst_value_deg = 0.0;         // the value furthest outside
  double worst_excess_deg = 0.0;        // how far outside it is, degrees
};
/// `list` grouped by (joint, channel), the largest excess first (ties: by
/// joint, then channel); empty for an empty list.
std::vector<RangeViolationGroup> group_range_violations(const std::vector<RangeViolation>& list);

/// One line of the groups, at most `max_groups` of them and "and N more":
/// "joint_LeftLeg Xrotation, range [-2.0, 140.0] deg: 11 frames, up to 152.3
/// (12.3 outside)". "" for an empty list.
std::string range_violation_summary(const std::vector<RangeViolation>& list,
                                    std::size_t max_groups = 4);

/// The motion's styles for the HTML report (SynthResult::styles and
/// style_transfer): "output: old (p = 0.37); partial 1: angry (p = 0.50)",
/// then, with a style transfer, "turned toward tired (strength 1.00; before
/// the transfer: childish, p = 0.26); 41 (leg, frame) pairs held where the
/// untransferred feet are, the root moved at most 0.001 m". "" when the
/// result has neither (no style model).
std::string style_summary_note(const SynthResult& result);

/// REPORT.json's "about_measures": per measure what it counts and its
/// thresholds, and the sliding / skating note of this motion.
nlohmann::json about_measures_json(const SynthResult& result);

/// REPORT.json's motion.foot_contacts: per foot segment {joint,
/// contact_points, frames, contact_frames, lowest_m, states}
/// (FootContactRow).
nlohmann::json foot_contacts_json(const std::vector<FootContactRow>& rows);

/// Why a row has no contact when its point never comes within
/// contact_height_m ("never within 10 cm (lowest 11.2 cm): ..."; a Bandai
/// Namco ankle stands that high, so the model's foot contact is the
/// toes'); "" when it does come within.
std::string never_in_reach_note(const EnergyParams& ep, const FootContactRow& row);

/// One line per foot segment: "Toes_L (joint origin or bone tip): in
/// contact 104 of 195 frames, 46 low but too fast", and the
/// never_in_reach_note of a row that has one.
std::string foot_contacts_text(const EnergyParams& ep, const std::vector<FootContactRow>& rows);

}  // namespace mocap::synth_detail
