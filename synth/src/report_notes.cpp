// The reports' notes on foot contact, sliding, skating and range violations
// (report_notes.hpp), and mocap-synth's printed summary (synth_report_text).
#include "report_notes.hpp"

#include <algorithm>
#include <iomanip>
#include <map>
#include <sstream>
#include <tuple>

#include "report_views.hpp"

namespace mocap {
namespace synth_detail {

std::string sliding_skating_note(const EnergyParams& ep, const MotionMeasures& m) {
  std::ostringstream o;
  o << "foot sliding " << fixed(2, m.foot_sliding_m)
    << " m: the horizontal travel of every foot contact point (the foot's: its joint, the "
       "ankle; the toes': their joint or tip) while within "
    << fixed(0, 100 * ep.contact_height_m) << " cm of the ground, at any speed (of it "
    << fixed(2, m.foot_sliding_slow_m) << " m at contact speed, at most "
    << fixed(1, ep.contact_speed_mps)
    << " m/s; the rest is feet swinging low or gliding). skating ratio "
    << fixed(2, m.skating_ratio) << ": the fraction of steps in which a foot joint is below "
    << fixed(0, 100 * kSkatingHeightM) << " cm and moves faster than " << fixed(1, kSkatingSpeedMps)
    << " m/s. A walk's feet pass low and fast through the first band but are slow whenever "
       "they are flat on the ground, so much sliding beside little or no skating is a walk's "
       "own.";
  return o.str();
}

std::vector<RangeViolationGroup> group_range_violations(const std::vector<RangeViolation>& list) {
  std::map<std::pair<std::string, std::string>, RangeViolationGroup> by_channel;
  for (const RangeViolation& v : list) {
    RangeViolationGroup& g = by_channel[{v.joint, v.channel}];
    if (g.frames == 0 || v.excess_deg > g.worst_excess_deg) {
      g.worst_excess_deg = v.excess_deg;
      g.worst_value_deg = v.value_deg;
    }
    g.joint = v.joint, g.channel = v.channel, g.min_deg = v.min_deg, g.max_deg = v.max_deg;
    ++g.frames;
  }
  std::vector<RangeViolationGroup> out;
  for (auto& [key, g] : by_channel) out.push_back(std::move(g));
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.worst_excess_deg > b.worst_excess_deg;
  });
  return out;
}

std::string range_violation_summary(const std::vector<RangeViolation>& list,
                                    std::size_t max_groups) {
  const std::vector<RangeViolationGroup> groups = group_range_violations(list);
  std::ostringstream o;
  for (std::size_t i = 0; i < groups.size() && i < max_groups; ++i) {
    const RangeViolationGroup& g = groups[i];
    o << (i ? "; " : "") << g.joint << " " << g.channel << ", range [" << fixed(1, g.min_deg)
      << ", " << fixed(1, g.max_deg) << "] deg: " << g.frames
      << (g.frames == 1 ? " frame" : " frames") << ", up to " << fixed(1, g.worst_value_deg) << " ("
      << fixed(1, g.worst_excess_deg) << " outside)";
  }
  if (groups.size() > max_groups) o << "; and " << groups.size() - max_groups << " more";
  return o.str();
}

nlohmann::json about_measures_json(const SynthResult& result) {
  const EnergyParams& ep = result.skeleton->model.params;
  return {
      {"foot_sliding_m",
       {{"what",
         "horizontal travel of the foot and toe contact points (the foot's: its joint, the "
         "ankle; the toes': their joint or bone tip, the lower) while within contact_height_m "
         "of the ground in both frames of a step, at any speed"},
        {"contact_height_m", ep.contact_height_m}}},
      {"foot_sliding_slow_m",
       {{"what", "the part of foot_sliding_m in steps at most contact_speed_mps fast"},
        {"contact_speed_mps", ep.contact_speed_mps}}},
      {"foot_skating_ratio",
       {{"what",
         "fraction of steps in which a foot or toe joint origin is below height_m in both frames "
         "and moves horizontally faster than speed_mps"},
        {"height_m", kSkatingHeightM},
        {"speed_mps", kSkatingSpeedMps}}},
      {"sliding_and_skating", sliding_skating_note(ep, result.motion_measures)},
      {"foot_contacts",
       "per foot segment and frame, the energy model's contact: c in contact (contact point "
       "within contact_height_m and slower than contact_speed_mps), s within that height but "
       "faster (no support), . higher"},
      {"range_violations",
       {{"what",
         "(inserted frame, joint) pairs whose rotation is outside the range of motion: the "
         "union of the captured channel ranges of the skeleton's clips in the index; "
         "range_violation_list names the joint, the channel furthest outside, its range, the "
         "value and the excess"},
        {"slack_deg", 0.5}}}};
}

nlohmann::json foot_contacts_json(const std::vector<FootContactRow>& rows) {
  nlohmann::json out = nlohmann::json::array();
  for (const FootContactRow& r : rows)
    out.push_back({{"joint", r.name},
                   {"contact_points", r.points},
                   {"frames", r.states.size()},
                   {"contact_frames", r.contact_frames()},
                   {"lowest_m", r.lowest_m},
                   {"states", r.states}});
  return out;
}

std::string never_in_reach_note(const EnergyParams& ep, const FootContactRow& row) {
  if (row.lowest_m <= ep.contact_height_m) return "";
  return "never within " + fixed(0, 100 * ep.contact_height_m) + " cm (lowest " +
         fixed(1, 100 * row.lowest_m) +
         " cm): the energy model has no heel point, so a heel on the ground shows in the toes' "
         "row (their joint, the ball of the foot, is then low too)";
}

std::string foot_contacts_text(const EnergyParams& ep, const std::vector<FootContactRow>& rows) {
  std::ostringstream o;
  for (const FootContactRow& r : rows) {
    o << r.name << " (" << r.points << "): in contact " << r.contact_frames() << " of "
      << r.states.size() << " frames, " << std::count(r.states.begin(), r.states.end(), 's')
      << " low but too fast";
    const std::string never = never_in_reach_note(ep, r);
    o << (never.empty() ? "" : "; ") << never << "\n";
  }
  return o.str();
}

std::string style_summary_note(const SynthResult& result) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(2);
  const char* sep = "";
  for (const auto& s : result.styles) {
    if (s.of == "motion before transfer") continue;
    o << sep << (s.of == "motion" ? std::string("output") : s.of) << ": " << s.label
      << " (p = " << s.p << ")";
    sep = "; ";
  }
  if (result.style_transfer) {
    const StyleTransferReport& t = *result.style_transfer;
    o << sep << "turned toward " << t.params.style << " (strength " << t.params.strength;
    for (const auto& s : result.styles)
      if (s.of == "motion before transfer")
        o << "; before the transfer: " << s.label << ", p = " << s.p;
    o << "); " << t.held_foot_frames
      << " (leg, frame) pairs held where the untransferred feet are, the root moved at most "
      << std::setprecision(3) << t.max_root_drop_m << " m";
  }
  return o.str();
}

}  // namespace synth_detail

namespace {

// "style:  toward S (recognised before: A, p = P; after: B, p = Q); the held
// feet and the root's move": what the style transfer did, for the printed
// summary.
std::string style_transfer_note(const SynthResult& result) {
  const StyleTransferReport& t = *result.style_transfer;
  std::ostringstream o;
  o << std::fixed << std::setprecision(2) << "style:  toward " << t.params.style << " (recognised";
  for (const char* of : {"motion before transfer", "motion"})
    for (const auto& s : result.styles)
      if (s.of == of)
        o << (s.of == "motion" ? "; after: " : " before: ") << s.label << ", p = " << s.p;
  o << "); " << t.held_foot_frames
    << " (leg, frame) pairs held where the untransferred feet are, the root moved at most "
    << std::setprecision(3) << t.max_root_drop_m << " m";
  return o.str();
}

}  // namespace

std::string synth_report_text(const SynthResult& result) {
  using namespace synth_detail;
  std::ostringstream o;
  if (!result.skeleton) return "";
  o << "feet:   " << sliding_skating_note(result.skeleton->model.params, result.motion_measures)
    << "\n";
  std::istringstream rows(
      foot_contacts_text(result.skeleton->model.params,
                         foot_contact_rows(*result.skeleton, result.frames, result.frame_time_s)));
  for (std::string line; std::getline(rows, line);) o << "        " << line << "\n";
  if (result.style_transfer) o << style_transfer_note(result) << "\n";
  for (const TransitionReport& t : result.transitions)
    if (t.measures.range_violations > 0)
      o << "range:  pair " << t.pair << " " << t.side << ": " << t.measures.range_violations
        << " (frame, joint) outside the captured range: "
        << range_violation_summary(t.measures.range_violation_list) << "\n";
  return o.str();
}

}  // namespace mocap
