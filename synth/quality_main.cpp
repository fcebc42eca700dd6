// mocap-synth-quality: A* supplementation against slerp and inertialization
// on real gaps (docs/synthesis.md "Quality"). A gap joins frame |X|/3 of a
// clip X to frame |Y|/2 of another clip Y of the same content label (set 1:
// consecutive clips of each content, different styles); Y is placed with the
// assembly rule (continuation_placement over the estimated gap time). Prints
// a markdown table and a summary; --json writes every measure.
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/synth/synth.hpp"
#include "mocap/synth/synth_json.hpp"
#include "refine_options.hpp"

namespace {

std::string file_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  std::string n = s == std::string::npos ? path : path.substr(s + 1);
  if (n.size() > 4 && n.ends_with(".bvh")) n.resize(n.size() - 4);
  return n;
}

// What the command line gives (add_quality_options); the job (run_quality) reads it.
struct QualityArgs {
  std::string index_path, json_path, label_key = "content";
  std::size_t max_gaps = 34, pairs_per_label = 3;
  double from_fraction = 1.0 / 3.0, to_fraction = 0.5;
  mocap::SupplementParams params;
  bool h_lookahead = false;
  bool no_plant = false, no_choose = false;
  bool step = false, no_step = false;
  std::string energy = "w";
  bool refine_free = false;
};

// The CLI11 declaration of the options (in the order --help lists them).
void add_quality_options(CLI::App& app, QualityArgs& q) {
  app.add_option("--index", q.index_path, "index file (mocap-index build)")->required();
  app.add_option("--gaps", q.max_gaps, "at most this many gaps")->capture_default_str();
  app.add_option("--pairs-per-label", q.pairs_per_label, "gaps per content label")
      ->capture_default_str();
  app.add_option("--from-fraction", q.from_fraction, "gap start: this fraction of X's frames")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--to-fraction", q.to_fraction, "gap goal: this fraction of Y's frames")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--label", q.label_key, "label key whose equal values make a gap")
      ->capture_default_str();
  app.add_option("--max-states", q.params.max_states, "T_n")->capture_default_str();
  app.add_option("--cost-threshold", q.params.cost_threshold_J, "T_c, joules")
      ->capture_default_str();
  app.add_flag("--h-lookahead", q.h_lookahead,
               "cost the middle of a candidate's completion with h instead of g");
  app.add_flag("--no-choose-length", q.no_choose,
               "plan with the length estimate instead of choosing the length");
  app.add_flag("--no-plant-feet", q.no_plant, "no contact-aware (foot planting) proposals");
  app.add_option("--energy", q.energy, "the energy the search minimises: w (default) or g")
      ->check(CLI::IsMember({"w", "g"}))
      ->capture_default_str();
  auto* step = app.add_flag("--step-feet", q.step,
                            "the stepping pass after the search (slerp and inertialization get "
                            "it too)");
  app.add_flag("--no-step-feet", q.no_step, "no stepping pass (the default)")->excludes(step);
  mocap::add_refine_options(app, q.params);
  app.add_flag("--refine-free", q.refine_free,
               "let the refinement slide the feet, turn joints faster and leave the range of "
               "motion (how low g can go)");
  app.add_option("--json", q.json_path, "write all measures as JSON");
}

// The two clips of a gap: from X (x) to Y (y).
struct GapSpec {
  std::size_t x, y;
};

// The gaps: per label, the first pairs (i < j, index order) of clips on one
// skeleton, taken round-robin over the labels; at most --gaps.
std::vector<GapSpec> pick_gaps(const mocap::Index& index, const QualityArgs& q) {
  // Clips by label value (index order), skeleton of the first.
  std::map<std::string, std::vector<std::size_t>> by_label;
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    const std::string v = index.label(c, q.label_key);
    if (!v.empty() && index.clips()[c].frame_count >= 20) by_label[v].push_back(c);
  }
  std::vector<GapSpec> specs;
  std::vector<std::vector<GapSpec>> per_label;
  for (const auto& [label, clips] : by_label) {
    std::vector<GapSpec> v;
    for (std::size_t i = 0; i < clips.size() && v.size() < q.pairs_per_label; ++i)
      for (std::size_t j = i + 1; j < clips.size() && v.size() < q.pairs_per_label; ++j)
        if (index.clips()[clips[i]].skeleton == index.clips()[clips[j]].skeleton) {
          v.push_back({clips[i], clips[j]});
          i = j;
          break;
        }
    per_label.push_back(std::move(v));
  }
  for (std::size_t round = 0; round < q.pairs_per_label; ++round)
    for (const auto& v : per_label)
      if (round < v.size()) specs.push_back(v[round]);
  if (specs.size() > q.max_gaps) specs.resize(q.max_gaps);
  if (specs.empty())
    throw mocap::InputError(q.index_path, 0, "no clips with label '" + q.label_key + "'");
  return specs;
}

// Frame a of X and frame b of Y that a gap joins.
struct GapFrames {
  std::size_t a, b;
};

GapFrames gap_frames(const mocap::IndexClip& cx, const mocap::IndexClip& cy, const QualityArgs& q) {
  const auto frame_at = [](std::size_t count, double fraction) {
    return static_cast<std::size_t>(std::floor(fraction * static_cast<double>(count) + 1e-9));
  };
  const std::size_t a =
      std::clamp<std::size_t>(frame_at(cx.frame_count, q.from_fraction), 1, cx.frame_count - 1);
  const std::size_t b =
      std::min<std::size_t>(frame_at(cy.frame_count, q.to_fraction), cy.frame_count - 2);
  return {a, b};
}

// The gap problem from frame a of clip x to frame b of clip y, Y placed by
// the assembly rule over the estimated gap time (sk and rom must outlive it).
mocap::GapProblem place_gap(const mocap::Index& index, const mocap::SynthSkeleton& sk,
                            const mocap::RangeOfMotion& rom, const GapSpec& spec,
                            const GapFrames& f, const mocap::SupplementParams& params) {
  mocap::GapProblem gap;
  gap.skeleton = &sk;
  gap.range = &rom;
  gap.frame_time_s = index.clips()[spec.x].frame_time_s;
  gap.before = mocap::clip_frame(index, spec.x, f.a - 1);
  gap.start = mocap::clip_frame(index, spec.x, f.a);
  const mocap::SynthFrame g0 = mocap::clip_frame(index, spec.y, f.b);
  const mocap::SynthFrame g1 = mocap::clip_frame(index, spec.y, f.b + 1);
  const double dt = gap.frame_time_s;
  const Eigen::Vector3d ve = mocap::horizontal_root_velocity(gap.before, gap.start, dt);
  const Eigen::Vector3d vf = mocap::horizontal_root_velocity(g0, g1, dt);
  // Estimate the length with the goal on the spot, then place it.
  mocap::Placement p = mocap::continuation_placement(sk, gap.start, ve, g0, vf, 0.0);
  gap.goal = mocap::place_frame(sk, g0, p);
  gap.after = mocap::place_frame(sk, g1, p);
  const std::size_t est = mocap::estimate_transition_frames(gap, params);
  p = mocap::continuation_placement(sk, gap.start, ve, g0, vf, static_cast<double>(est + 1) * dt);
  gap.goal = mocap::place_frame(sk, g0, p);
  gap.after = mocap::place_frame(sk, g1, p);
  return gap;
}

// The measures of one gap's transitions: A*, slerp, inertialize, and slerp
// with A*'s stepping pass (when it has one); A*'s statistics and times.
struct MethodMeasures {
  // slerp, inert: the baselines as they are (gliding); *_stepped: after the
  // same stepping pass as A*'s (the same as slerp / inert without one).
  mocap::TransitionMeasures astar, slerp, inert, slerp_stepped, inert_stepped;
  mocap::SupplementStats stats;
  double ms = 0.0, cpu_ms = 0.0;
};

MethodMeasures run_methods(const mocap::GapProblem& gap, const mocap::SupplementParams& params) {
  MethodMeasures m;
  const std::clock_t c0 = std::clock();
  const auto t0 = std::chrono::steady_clock::now();
  const auto astar = mocap::supplement_astar(gap, params, &m.stats);
  const auto t1 = std::chrono::steady_clock::now();
  const std::clock_t c1 = std::clock();
  m.ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  // Processor time of this (single-threaded) process: unaffected by
  // other processes sharing the core.
  m.cpu_ms = 1000.0 * static_cast<double>(c1 - c0) / CLOCKS_PER_SEC;
  const auto slerp = mocap::slerp_transition(gap, astar.size());
  const auto inert = mocap::inertialize_transition(gap, astar.size());
  m.astar = mocap::measure_transition(gap, astar);
  m.slerp = mocap::measure_transition(gap, slerp);
  m.inert = mocap::measure_transition(gap, inert);
  // Slerp and inertialization with the same stepping pass as A*'s (when it
  // has one): the like-for-like comparison.
  auto slerp_stepped = slerp;
  auto inert_stepped = inert;
  if (params.step_feet) {
    mocap::step_transition_feet(gap, slerp_stepped);
    mocap::step_transition_feet(gap, inert_stepped);
  }
  m.slerp_stepped = mocap::measure_transition(gap, slerp_stepped);
  m.inert_stepped = mocap::measure_transition(gap, inert_stepped);
  return m;
}

// The source clips' own measures around the gap, over as many captured steps
// before frame a of X and from frame b of Y as the transition has.
struct SourceMeasures {
  double skating_ratio = 0.0;   // over both windows' steps together
  double airborne_ratio = 0.0;  // likewise
  double foot_sliding_m = 0.0;  // contact-based, the mean of the two windows
  double energy_J = 0.0;        // g, the mean of the two windows
  // W, its unsupported part, the fraction of states without contact and the
  // peak joint speed (measure_transition's), the mean of the two windows.
  double w_J = 0.0, unsupported_J = 0.0, no_contact_ratio = 0.0, peak_angular_speed_radps = 0.0;
};

// measure_transition's measures of clip frames first..last (first < last) as
// if they were a transition: S_0 = first, S_G = last, the clip's own
// neighbours (where it has them) as S_-1 and S_G+1.
mocap::TransitionMeasures window_measures(const mocap::Index& index, const mocap::SynthSkeleton& sk,
                                          const mocap::RangeOfMotion& rom, std::size_t clip,
                                          std::size_t first, std::size_t last, double dt) {
  const std::size_t count = index.clips()[clip].frame_count;
  mocap::GapProblem gap{&sk,
                        &rom,
                        mocap::clip_frame(index, clip, first > 0 ? first - 1 : 0),
                        mocap::clip_frame(index, clip, first),
                        mocap::clip_frame(index, clip, last),
                        mocap::clip_frame(index, clip, std::min(last + 1, count - 1)),
                        dt};
  std::vector<mocap::SynthFrame> inner;
  for (std::size_t k = first + 1; k < last; ++k) inner.push_back(mocap::clip_frame(index, clip, k));
  return mocap::measure_transition(gap, inner);
}

SourceMeasures measure_source(const mocap::Index& index, const mocap::SynthSkeleton& sk,
                              const mocap::RangeOfMotion& rom, const GapSpec& spec,
                              const GapFrames& f, std::size_t steps, double dt) {
  const std::size_t y_frames = index.clips()[spec.y].frame_count;
  std::vector<mocap::SynthFrame> before_gap, after_gap;
  for (std::size_t k = f.a > steps ? f.a - steps : 0; k <= f.a; ++k)
    before_gap.push_back(mocap::clip_frame(index, spec.x, k));
  for (std::size_t k = f.b; k <= std::min(y_frames - 1, f.b + steps); ++k)
    after_gap.push_back(mocap::clip_frame(index, spec.y, k));
  const mocap::MotionMeasures src_x = mocap::measure_motion(sk, before_gap, dt);
  const mocap::MotionMeasures src_y = mocap::measure_motion(sk, after_gap, dt);
  const double n_x = static_cast<double>(before_gap.size() - 1);
  const double n_y = static_cast<double>(after_gap.size() - 1);
  // A ratio over both windows' steps together.
  const auto over_both = [&](double mocap::MotionMeasures::*ratio) {
    return n_x + n_y > 0 ? (src_x.*ratio * n_x + src_y.*ratio * n_y) / (n_x + n_y) : 0.0;
  };
  SourceMeasures s;
  s.skating_ratio = over_both(&mocap::MotionMeasures::skating_ratio);
  s.airborne_ratio = over_both(&mocap::MotionMeasures::airborne_ratio);
  s.foot_sliding_m = 0.5 * (src_x.foot_sliding_m + src_y.foot_sliding_m);
  for (const auto* window : {&before_gap, &after_gap})
    for (double e : mocap::motion_step_energies(sk, *window, dt)) s.energy_J += 0.5 * e;
  const std::size_t y_last = std::min(y_frames - 1, f.b + steps);
  for (const mocap::TransitionMeasures& w :
       {window_measures(index, sk, rom, spec.x, f.a > steps ? f.a - steps : 0, f.a, dt),
        window_measures(index, sk, rom, spec.y, f.b, std::max(y_last, f.b + 1), dt)}) {
    s.w_J += 0.5 * w.work_energy_J;
    s.unsupported_J += 0.5 * w.unsupported_J;
    s.no_contact_ratio += 0.5 * w.no_contact_ratio;
    s.peak_angular_speed_radps += 0.5 * w.peak_angular_speed_radps;
  }
  return s;
}

// One method's measures summed over the gaps, in gap order.
struct MethodSums {
  double energy_J = 0.0, foot_sliding_m = 0.0, skating_ratio = 0.0, airborne_ratio = 0.0;
  double w_J = 0.0, unsupported_J = 0.0, no_contact_ratio = 0.0, peak_angular_speed_radps = 0.0;
  std::size_t range_violations = 0;
  mocap::TransitionMeasures::EnergySplit split;
  void add(const mocap::TransitionMeasures& m) {
    energy_J += m.energy_J;
    foot_sliding_m += m.foot_sliding_m;
    skating_ratio += m.skating_ratio;
    airborne_ratio += m.airborne_ratio;
    range_violations += m.range_violations;
    split += m.energy_split;
    w_J += m.work_energy_J;
    unsupported_J += m.unsupported_J;
    no_contact_ratio += m.no_contact_ratio;
    peak_angular_speed_radps += m.peak_angular_speed_radps;
  }
};

// Everything the summary reports, accumulated gap by gap (add_gap).
struct QualityTotals {
  std::size_t gaps = 0;
  MethodSums astar, slerp, inert, slerp_stepped, inert_stepped;
  SourceMeasures source;  // sums
  std::size_t lower = 0, lower_stepped = 0, slide_ok = 0, skate_ok = 0;
  // Like for like: in the search's energy, against the baselines with the
  // same stepping pass.
  mocap::SearchEnergy energy = mocap::SearchEnergy::work;
  std::size_t lower_like_slerp = 0, lower_like_inert = 0;
  std::vector<double> times_ms, cpu_times_ms;

  void add_gap(const MethodMeasures& m, const SourceMeasures& s) {
    ++gaps;
    times_ms.push_back(m.ms);
    cpu_times_ms.push_back(m.cpu_ms);
    if (m.astar.energy_J < m.slerp.energy_J) ++lower;
    if (m.astar.energy_J < m.slerp_stepped.energy_J) ++lower_stepped;
    const auto searched = [this](const mocap::TransitionMeasures& x) {
      return energy == mocap::SearchEnergy::work ? x.work_energy_J : x.energy_J;
    };
    if (searched(m.astar) < searched(m.slerp_stepped)) ++lower_like_slerp;
    if (searched(m.astar) < searched(m.inert_stepped)) ++lower_like_inert;
    if (m.astar.foot_sliding_m <= m.slerp.foot_sliding_m + 1e-9) ++slide_ok;
    if (m.astar.skating_ratio <= m.slerp.skating_ratio + 1e-12) ++skate_ok;
    astar.add(m.astar);
    slerp.add(m.slerp);
    inert.add(m.inert);
    slerp_stepped.add(m.slerp_stepped);
    inert_stepped.add(m.inert_stepped);
    source.w_J += s.w_J;
    source.unsupported_J += s.unsupported_J;
    source.no_contact_ratio += s.no_contact_ratio;
    source.peak_angular_speed_radps += s.peak_angular_speed_radps;
    source.skating_ratio += s.skating_ratio;
    source.airborne_ratio += s.airborne_ratio;
    source.foot_sliding_m += s.foot_sliding_m;
    source.energy_J += s.energy_J;
  }
};

void print_table_header() {
  std::printf(
      "| # | from (frame) | to (frame) | frames | g A* (J) | g slerp (J) | g inert. (J) | "
      "A*/slerp | slide A* (m) | slide slerp (m) | skating A* / slerp / inert. / source | "
      "viol. A*/slerp | peak ω A* (rad/s) | time A* (ms) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

void print_gap_row(std::size_t gi, const std::string& from, const std::string& to,
                   const GapFrames& f, const MethodMeasures& m, const SourceMeasures& s) {
  const mocap::TransitionMeasures &ma = m.astar, &ms_ = m.slerp, &mi = m.inert;
  std::printf(
      "| %zu | %s (%zu) | %s (%zu) | %zu | %.1f | %.1f | %.1f | %.2f | %.3f | %.3f | "
      "%.2f / %.2f / %.2f / %.2f | %zu/%zu | %.1f | %.1f |\n",
      gi + 1, from.c_str(), f.a, to.c_str(), f.b, ma.frames, ma.energy_J, ms_.energy_J, mi.energy_J,
      ma.energy_J / ms_.energy_J, ma.foot_sliding_m, ms_.foot_sliding_m, ma.skating_ratio,
      ms_.skating_ratio, mi.skating_ratio, s.skating_ratio, ma.range_violations,
      ms_.range_violations, ma.peak_angular_speed_radps, m.ms);
}

nlohmann::json gap_row_json(const std::string& from, const std::string& to, const GapFrames& f,
                            const MethodMeasures& m, const SourceMeasures& s) {
  return {{"from", from},
          {"from_frame", f.a},
          {"to", to},
          {"to_frame", f.b},
          {"astar", mocap::measures_json(m.astar)},
          {"slerp", mocap::measures_json(m.slerp)},
          {"inertialize", mocap::measures_json(m.inert)},
          {"source_foot_skating_ratio", s.skating_ratio},
          {"source_foot_sliding_m", s.foot_sliding_m},
          {"source_energy_J", s.energy_J},
          {"astar_ms", m.ms},
          {"astar_cpu_ms", m.cpu_ms},
          {"stop_reason", m.stats.stop_reason},
          {"estimated_frames", m.stats.estimated_frames},
          {"energy_evaluations", m.stats.energy_evaluations},
          {"refine_steps", m.stats.refine_steps},
          {"refine_gain_J", m.stats.refine_gain_J}};
}

// Gap gi: placed, supplemented by each method, measured; its row printed and
// kept; the totals updated.
void run_gap(const mocap::Index& index, const QualityArgs& q, std::size_t gi, const GapSpec& spec,
             QualityTotals& totals, nlohmann::json& rows) {
  const mocap::IndexClip& cx = index.clips()[spec.x];
  const mocap::IndexClip& cy = index.clips()[spec.y];
  const mocap::SynthSkeleton sk = mocap::make_synth_skeleton(index, cx.skeleton, spec.x);
  const mocap::RangeOfMotion rom =
      mocap::range_of_motion(index, sk, index.skeletons()[cx.skeleton].clips);
  const GapFrames f = gap_frames(cx, cy, q);
  const mocap::GapProblem gap = place_gap(index, sk, rom, spec, f, q.params);
  const MethodMeasures m = run_methods(gap, q.params);
  const SourceMeasures s =
      measure_source(index, sk, rom, spec, f, m.astar.frames + 1, gap.frame_time_s);
  totals.add_gap(m, s);
  print_gap_row(gi, file_name(cx.path), file_name(cy.path), f, m, s);
  rows.push_back(gap_row_json(file_name(cx.path), file_name(cy.path), f, m, s));
}

// Times per transition: medians and maxima, wall and processor.
struct TimeSummary {
  double median, max, cpu_median, cpu_max;
};

TimeSummary time_summary(const QualityTotals& t) {
  auto median_of = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  std::vector<double> sorted = t.times_ms;
  std::sort(sorted.begin(), sorted.end());
  return {median_of(t.times_ms), sorted.back(), median_of(t.cpu_times_ms),
          *std::max_element(t.cpu_times_ms.begin(), t.cpu_times_ms.end())};
}

// The g split by term, A* against slerp.
void print_energy_split(const QualityTotals& t) {
  const double n = static_cast<double>(t.gaps);
  const auto share = [&](double part, double sum) { return 100.0 * part / sum; };
  const double ta = t.astar.energy_J, ts = t.slerp.energy_J;
  const mocap::TransitionMeasures::EnergySplit &split_a = t.astar.split, &split_s = t.slerp.split;
  std::printf(
      "g by term (mean per gap, J; %% of the method's g), A* / slerp: h %.1f / %.1f (%.0f%% / "
      "%.0f%%), "
      "adjacent %.1f / %.1f (%.0f%% / %.0f%%), contact %.1f / %.1f (%.0f%% / %.0f%%), joint %.1f "
      "/ %.1f "
      "(%.0f%% / %.0f%%), residual work %.1f / %.1f (%.0f%% / %.0f%%), residual impulse %.1f / "
      "%.1f "
      "(%.0f%% / %.0f%%).\n",
      split_a.h_J / n, split_s.h_J / n, share(split_a.h_J, ta), share(split_s.h_J, ts),
      split_a.adjacent_J / n, split_s.adjacent_J / n, share(split_a.adjacent_J, ta),
      share(split_s.adjacent_J, ts), split_a.contact_J / n, split_s.contact_J / n,
      share(split_a.contact_J, ta), share(split_s.contact_J, ts), split_a.joint_J / n,
      split_s.joint_J / n, share(split_a.joint_J, ta), share(split_s.joint_J, ts),
      split_a.residual_work_J / n, split_s.residual_work_J / n, share(split_a.residual_work_J, ta),
      share(split_s.residual_work_J, ts), split_a.residual_impulse_J / n,
      split_s.residual_impulse_J / n, share(split_a.residual_impulse_J, ta),
      share(split_s.residual_impulse_J, ts));
}

// The comparison in the search's own energy against slerp and
// inertialization with the same stepping treatment, and W with its
// unsupported part, frames without contact and peak joint speed beside the
// source clips' own over as many steps.
void print_like_for_like(const QualityTotals& t, const mocap::SupplementParams& params) {
  const double n = static_cast<double>(t.gaps);
  const bool w = params.energy == mocap::SearchEnergy::work;
  std::printf(
      "Like for like (%s, the search's energy; slerp and inertialization %s): A* lower than "
      "slerp in %zu of %zu gaps, than inertialization in %zu.\n",
      w ? "W" : "g", params.step_feet ? "with the same stepping pass" : "as they are (no stepping)",
      t.lower_like_slerp, t.gaps, t.lower_like_inert);
  const auto row = [n](const char* name, double w_J, double unsupported_J, double no_contact,
                       double peak) {
    std::printf(
        "  %-34s W %7.1f J, unsupported %7.1f J, no contact %.3f, peak joint speed %5.1f "
        "rad/s\n",
        name, w_J / n, unsupported_J / n, no_contact / n, peak / n);
  };
  std::printf("Mean per gap:\n");
  const MethodSums &a = t.astar, &s = t.slerp_stepped, &i = t.inert_stepped;
  row("A*", a.w_J, a.unsupported_J, a.no_contact_ratio, a.peak_angular_speed_radps);
  row(params.step_feet ? "slerp, stepped" : "slerp", s.w_J, s.unsupported_J, s.no_contact_ratio,
      s.peak_angular_speed_radps);
  row(params.step_feet ? "inertialization, stepped" : "inertialization", i.w_J, i.unsupported_J,
      i.no_contact_ratio, i.peak_angular_speed_radps);
  row("source clips (as many steps)", t.source.w_J, t.source.unsupported_J,
      t.source.no_contact_ratio, t.source.peak_angular_speed_radps);
}

// The summary lines after the table.
void print_quality_summary(const QualityTotals& t, const TimeSummary& time,
                           const mocap::SupplementParams& params) {
  const double n = static_cast<double>(t.gaps);
  const MethodSums &a = t.astar, &s = t.slerp, &i = t.inert;
  std::printf(
      "\nGaps: %zu. A* g lower than slerp in %zu (%.0f%%); mean g A* %.1f J, slerp %.1f J (ratio "
      "%.2f), "
      "inertialize %.1f J; the source clips' own g over as many steps %.1f J.\n",
      t.gaps, t.lower, 100.0 * static_cast<double>(t.lower) / n, a.energy_J / n, s.energy_J / n,
      a.energy_J / s.energy_J, i.energy_J / n, t.source.energy_J / n);
  if (params.step_feet)
    std::printf(
        "Slerp with the same stepping pass: A* g lower in %zu gaps; its mean g %.1f J, "
        "foot-skating ratio %.3f.\n",
        t.lower_stepped, t.slerp_stepped.energy_J / n, t.slerp_stepped.skating_ratio / n);
  print_like_for_like(t, params);
  std::printf(
      "Foot sliding (total): A* %.3f m, slerp %.3f m, inertialize %.3f m; A* <= slerp in %zu "
      "gaps. "
      "Range violations: A* %zu, slerp %zu, inertialize %zu.\n",
      a.foot_sliding_m, s.foot_sliding_m, i.foot_sliding_m, t.slide_ok, a.range_violations,
      s.range_violations, i.range_violations);
  std::printf(
      "Foot-skating ratio (mean per gap): A* %.3f, slerp %.3f, inertialize %.3f, source clips "
      "%.3f; A* <= slerp in %zu gaps. Source clips' foot sliding over as many steps: %.3f m "
      "(total).\n",
      a.skating_ratio / n, s.skating_ratio / n, i.skating_ratio / n, t.source.skating_ratio / n,
      t.skate_ok, t.source.foot_sliding_m);
  std::printf(
      "Airborne ratio (no foot on the ground; mean per gap): A* %.3f, slerp %.3f, inertialize "
      "%.3f, source clips %.3f.\n",
      a.airborne_ratio / n, s.airborne_ratio / n, i.airborne_ratio / n,
      t.source.airborne_ratio / n);
  std::printf(
      "A* time per transition (one thread): median %.1f ms, max %.1f ms wall; processor time "
      "median %.1f ms, "
      "max %.1f ms.\n",
      time.median, time.max, time.cpu_median, time.cpu_max);
  print_energy_split(t);
}

// --json: every gap's row, the summary and the parameters.
void write_quality_json(const QualityArgs& q, const nlohmann::json& rows, const QualityTotals& t,
                        const TimeSummary& time) {
  const double n = static_cast<double>(t.gaps);
  const MethodSums &a = t.astar, &s = t.slerp, &i = t.inert;
  nlohmann::json out = {
      {"gaps", rows},
      {"summary",
       {{"gaps", t.gaps},
        {"astar_lower_g", t.lower},
        {"mean_g_astar_J", a.energy_J / n},
        {"mean_g_slerp_J", s.energy_J / n},
        {"mean_g_inertialize_J", i.energy_J / n},
        {"mean_g_source_J", t.source.energy_J / n},
        {"astar_lower_g_than_stepped_slerp", t.lower_stepped},
        {"mean_g_stepped_slerp_J", t.slerp_stepped.energy_J / n},
        {"skating_ratio_stepped_slerp", t.slerp_stepped.skating_ratio / n},
        {"ratio_mean_g", a.energy_J / s.energy_J},
        {"astar_lower_like_for_like_slerp", t.lower_like_slerp},
        {"astar_lower_like_for_like_inertialize", t.lower_like_inert},
        {"mean_w_astar_J", a.w_J / n},
        {"mean_w_slerp_like_J", t.slerp_stepped.w_J / n},
        {"mean_w_inertialize_like_J", t.inert_stepped.w_J / n},
        {"mean_w_source_J", t.source.w_J / n},
        {"mean_unsupported_astar_J", a.unsupported_J / n},
        {"mean_unsupported_source_J", t.source.unsupported_J / n},
        {"no_contact_ratio_astar", a.no_contact_ratio / n},
        {"no_contact_ratio_source", t.source.no_contact_ratio / n},
        {"peak_angular_speed_astar_radps", a.peak_angular_speed_radps / n},
        {"peak_angular_speed_source_radps", t.source.peak_angular_speed_radps / n},
        {"foot_sliding_astar_m", a.foot_sliding_m},
        {"foot_sliding_slerp_m", s.foot_sliding_m},
        {"foot_sliding_inertialize_m", i.foot_sliding_m},
        {"skating_ratio_astar", a.skating_ratio / n},
        {"skating_ratio_slerp", s.skating_ratio / n},
        {"skating_ratio_inertialize", i.skating_ratio / n},
        {"skating_ratio_source", t.source.skating_ratio / n},
        {"airborne_ratio_astar", a.airborne_ratio / n},
        {"airborne_ratio_slerp", s.airborne_ratio / n},
        {"airborne_ratio_inertialize", i.airborne_ratio / n},
        {"airborne_ratio_source", t.source.airborne_ratio / n},
        {"foot_sliding_source_m", t.source.foot_sliding_m},
        {"median_ms", time.median},
        {"median_cpu_ms", time.cpu_median},
        {"max_ms", time.max}}},
      {"params", mocap::supplement_params_json(q.params)}};
  out["params"]["exact_lookahead"] = q.params.exact_lookahead;
  out["params"]["from_fraction"] = q.from_fraction;
  out["params"]["to_fraction"] = q.to_fraction;
  std::ofstream(q.json_path) << mocap::json_text(out, 2) << "\n";
}

// The job: the gaps picked, each supplemented and measured, the summary.
int run_quality(QualityArgs& q) {
  // One thread: the times are per transition on one core (the refinement's
  // gradient would otherwise use every core).
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  q.params.plant_feet = !q.no_plant;
  q.params.step_feet = q.step;
  q.params.energy = q.energy == "g" ? mocap::SearchEnergy::g : mocap::SearchEnergy::work;
  q.params.exact_lookahead = !q.h_lookahead;
  q.params.choose_length = !q.no_choose;
  q.params.refine.keep_limits = !q.refine_free;
  try {
    mocap::check_supplement_options(q.params);
    const mocap::Index index = mocap::Index::open(q.index_path);
    const std::vector<GapSpec> specs = pick_gaps(index, q);
    nlohmann::json rows = nlohmann::json::array();
    QualityTotals totals;
    totals.energy = q.params.energy;
    print_table_header();
    for (std::size_t gi = 0; gi < specs.size(); ++gi)
      run_gap(index, q, gi, specs[gi], totals, rows);
    const TimeSummary time = time_summary(totals);
    print_quality_summary(totals, time, q.params);
    if (!q.json_path.empty()) write_quality_json(q, rows, totals, time);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mocap-synth-quality: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A* supplementation vs slerp / inertialization on real gaps"};
  QualityArgs args;
  add_quality_options(app, args);
  CLI11_PARSE(app, argc, argv);
  return run_quality(args);
}
