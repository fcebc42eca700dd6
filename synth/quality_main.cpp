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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A* supplementation vs slerp / inertialization on real gaps"};
  std::string index_path, json_path, label_key = "content";
  std::size_t max_gaps = 34, pairs_per_label = 3;
  double from_fraction = 1.0 / 3.0, to_fraction = 0.5;
  mocap::SupplementParams params;
  app.add_option("--index", index_path, "index file (mocap-index build)")->required();
  app.add_option("--gaps", max_gaps, "at most this many gaps")->capture_default_str();
  app.add_option("--pairs-per-label", pairs_per_label, "gaps per content label")
      ->capture_default_str();
  app.add_option("--from-fraction", from_fraction, "gap start: this fraction of X's frames")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--to-fraction", to_fraction, "gap goal: this fraction of Y's frames")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--label", label_key, "label key whose equal values make a gap")
      ->capture_default_str();
  app.add_option("--max-states", params.max_states, "T_n")->capture_default_str();
  app.add_option("--cost-threshold", params.cost_threshold_J, "T_c, joules")->capture_default_str();
  bool h_lookahead = false;
  app.add_flag("--h-lookahead", h_lookahead,
               "cost the middle of a candidate's completion with h instead of g");
  bool no_plant = false, no_choose = false;
  app.add_flag("--no-choose-length", no_choose,
               "plan with the length estimate instead of choosing the length");
  app.add_flag("--no-plant-feet", no_plant, "no contact-aware (foot planting) proposals");
  bool no_step = false;
  app.add_flag("--no-step-feet", no_step, "no stepping pass after the search");
  mocap::add_refine_options(app, params);
  bool refine_free = false;
  app.add_flag("--refine-free", refine_free,
               "let the refinement slide the feet, turn joints faster and leave the range of "
               "motion (how low g can go)");
  app.add_option("--json", json_path, "write all measures as JSON");
  CLI11_PARSE(app, argc, argv);
  // One thread: the times are per transition on one core (the refinement's
  // gradient would otherwise use every core).
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  params.plant_feet = !no_plant;
  params.step_feet = !no_step;
  params.exact_lookahead = !h_lookahead;
  params.choose_length = !no_choose;
  params.refine.keep_limits = !refine_free;
  try {
    mocap::check_supplement_options(params);
    const mocap::Index index = mocap::Index::open(index_path);
    // Clips by label value (index order), skeleton of the first.
    std::map<std::string, std::vector<std::size_t>> by_label;
    for (std::size_t c = 0; c < index.clips().size(); ++c) {
      const std::string v = index.label(c, label_key);
      if (!v.empty() && index.clips()[c].frame_count >= 20) by_label[v].push_back(c);
    }
    struct GapSpec {
      std::size_t x, y;
    };
    std::vector<GapSpec> specs;
    // Per label: the first pairs (i < j, index order) of clips on one skeleton,
    // taken round-robin over the labels.
    std::vector<std::vector<GapSpec>> per_label;
    for (const auto& [label, clips] : by_label) {
      std::vector<GapSpec> v;
      for (std::size_t i = 0; i < clips.size() && v.size() < pairs_per_label; ++i)
        for (std::size_t j = i + 1; j < clips.size() && v.size() < pairs_per_label; ++j)
          if (index.clips()[clips[i]].skeleton == index.clips()[clips[j]].skeleton) {
            v.push_back({clips[i], clips[j]});
            i = j;
            break;
          }
      per_label.push_back(std::move(v));
    }
    for (std::size_t round = 0; round < pairs_per_label; ++round)
      for (const auto& v : per_label)
        if (round < v.size()) specs.push_back(v[round]);
    if (specs.size() > max_gaps) specs.resize(max_gaps);
    if (specs.empty())
      throw mocap::InputError(index_path, 0, "no clips with label '" + label_key + "'");

    nlohmann::json rows = nlohmann::json::array();
    std::vector<double> times_ms, cpu_times_ms;
    std::size_t lower = 0, slide_ok = 0;
    double sum_a = 0, sum_s = 0, sum_i = 0, slide_a = 0, slide_s = 0, slide_i = 0;
    // Foot-skating ratios summed over gaps: A*, slerp, inertialize, the source clips.
    double skate_a = 0, skate_s = 0, skate_i = 0, skate_src = 0, slide_src = 0, g_src = 0;
    double sum_ss = 0, skate_ss = 0, air_a = 0, air_s = 0, air_i = 0, air_src = 0;
    std::size_t lower_stepped = 0;
    std::size_t skate_ok = 0;
    std::size_t viol_a = 0, viol_s = 0, viol_i = 0;
    // Sums of the g terms over the gaps (A*, slerp).
    mocap::TransitionMeasures::EnergySplit split_a, split_s;
    std::printf(
        "| # | from (frame) | to (frame) | frames | g A* (J) | g slerp (J) | g inert. (J) | "
        "A*/slerp | slide A* (m) | slide slerp (m) | skating A* / slerp / inert. / source | "
        "viol. A*/slerp | peak ω A* (rad/s) | time A* (ms) |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (std::size_t gi = 0; gi < specs.size(); ++gi) {
      const auto [x, y] = specs[gi];
      const mocap::IndexClip& cx = index.clips()[x];
      const mocap::IndexClip& cy = index.clips()[y];
      const mocap::SynthSkeleton sk = mocap::make_synth_skeleton(index, cx.skeleton, x);
      const mocap::RangeOfMotion rom =
          mocap::range_of_motion(index, sk, index.skeletons()[cx.skeleton].clips);
      const auto frame_at = [](std::size_t count, double fraction) {
        return static_cast<std::size_t>(std::floor(fraction * static_cast<double>(count) + 1e-9));
      };
      const std::size_t a =
          std::clamp<std::size_t>(frame_at(cx.frame_count, from_fraction), 1, cx.frame_count - 1);
      const std::size_t b =
          std::min<std::size_t>(frame_at(cy.frame_count, to_fraction), cy.frame_count - 2);
      mocap::GapProblem gap;
      gap.skeleton = &sk;
      gap.range = &rom;
      gap.frame_time_s = cx.frame_time_s;
      gap.before = mocap::clip_frame(index, x, a - 1);
      gap.start = mocap::clip_frame(index, x, a);
      const mocap::SynthFrame g0 = mocap::clip_frame(index, y, b);
      const mocap::SynthFrame g1 = mocap::clip_frame(index, y, b + 1);
      const double dt = gap.frame_time_s;
      const Eigen::Vector3d ve = mocap::horizontal_root_velocity(gap.before, gap.start, dt);
      const Eigen::Vector3d vf = mocap::horizontal_root_velocity(g0, g1, dt);
      // Estimate the length with the goal on the spot, then place it.
      mocap::Placement p = mocap::continuation_placement(sk, gap.start, ve, g0, vf, 0.0);
      gap.goal = mocap::place_frame(sk, g0, p);
      gap.after = mocap::place_frame(sk, g1, p);
      const std::size_t est = mocap::estimate_transition_frames(gap, params);
      p = mocap::continuation_placement(sk, gap.start, ve, g0, vf,
                                        static_cast<double>(est + 1) * dt);
      gap.goal = mocap::place_frame(sk, g0, p);
      gap.after = mocap::place_frame(sk, g1, p);

      mocap::SupplementStats stats;
      const std::clock_t c0 = std::clock();
      const auto t0 = std::chrono::steady_clock::now();
      const auto astar = mocap::supplement_astar(gap, params, &stats);
      const auto t1 = std::chrono::steady_clock::now();
      const std::clock_t c1 = std::clock();
      const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
      // Processor time of this (single-threaded) process: unaffected by
      // other processes sharing the core.
      const double cpu_ms = 1000.0 * static_cast<double>(c1 - c0) / CLOCKS_PER_SEC;
      times_ms.push_back(ms);
      cpu_times_ms.push_back(cpu_ms);
      const auto slerp = mocap::slerp_transition(gap, astar.size());
      const auto inert = mocap::inertialize_transition(gap, astar.size());
      const auto ma = mocap::measure_transition(gap, astar);
      const auto ms_ = mocap::measure_transition(gap, slerp);
      const auto mi = mocap::measure_transition(gap, inert);
      if (ma.energy_J < ms_.energy_J) ++lower;
      // Slerp with the same stepping pass as A*'s (when it has one).
      auto slerp_stepped = slerp;
      if (params.step_feet) mocap::step_transition_feet(gap, slerp_stepped);
      const auto mss = mocap::measure_transition(gap, slerp_stepped);
      if (ma.energy_J < mss.energy_J) ++lower_stepped;
      sum_ss += mss.energy_J;
      skate_ss += mss.skating_ratio;
      if (ma.foot_sliding_m <= ms_.foot_sliding_m + 1e-9) ++slide_ok;
      // The source clips' own skating around the gap: as many captured steps
      // before frame a of X and from frame b of Y as the transition has.
      const std::size_t steps = ma.frames + 1;
      std::vector<mocap::SynthFrame> before_gap, after_gap;
      for (std::size_t f = a > steps ? a - steps : 0; f <= a; ++f)
        before_gap.push_back(mocap::clip_frame(index, x, f));
      for (std::size_t f = b; f <= std::min(cy.frame_count - 1, b + steps); ++f)
        after_gap.push_back(mocap::clip_frame(index, y, f));
      const mocap::MotionMeasures src_x = mocap::measure_motion(sk, before_gap, dt);
      const mocap::MotionMeasures src_y = mocap::measure_motion(sk, after_gap, dt);
      const double n_x = static_cast<double>(before_gap.size() - 1);
      const double n_y = static_cast<double>(after_gap.size() - 1);
      // A ratio over both windows' steps together.
      const auto over_both = [&](double mocap::MotionMeasures::*ratio) {
        return n_x + n_y > 0 ? (src_x.*ratio * n_x + src_y.*ratio * n_y) / (n_x + n_y) : 0.0;
      };
      const double src_ratio = over_both(&mocap::MotionMeasures::skating_ratio);
      skate_a += ma.skating_ratio;
      skate_s += ms_.skating_ratio;
      skate_i += mi.skating_ratio;
      skate_src += src_ratio;
      air_a += ma.airborne_ratio;
      air_s += ms_.airborne_ratio;
      air_i += mi.airborne_ratio;
      air_src += over_both(&mocap::MotionMeasures::airborne_ratio);
      // Their contact-based sliding per as many steps as the transition has
      // (the mean of the two windows).
      const double src_slide = 0.5 * (src_x.foot_sliding_m + src_y.foot_sliding_m);
      slide_src += src_slide;
      // Their g over as many steps (the mean of the two windows).
      double src_g = 0.0;
      for (const auto* window : {&before_gap, &after_gap})
        for (double e : mocap::motion_step_energies(sk, *window, dt)) src_g += 0.5 * e;
      g_src += src_g;
      if (ma.skating_ratio <= ms_.skating_ratio + 1e-12) ++skate_ok;
      sum_a += ma.energy_J;
      sum_s += ms_.energy_J;
      sum_i += mi.energy_J;
      slide_a += ma.foot_sliding_m;
      slide_s += ms_.foot_sliding_m;
      slide_i += mi.foot_sliding_m;
      viol_a += ma.range_violations;
      viol_s += ms_.range_violations;
      viol_i += mi.range_violations;
      split_a += ma.energy_split;
      split_s += ms_.energy_split;
      std::printf(
          "| %zu | %s (%zu) | %s (%zu) | %zu | %.1f | %.1f | %.1f | %.2f | %.3f | %.3f | "
          "%.2f / %.2f / %.2f / %.2f | %zu/%zu | %.1f | %.1f |\n",
          gi + 1, file_name(cx.path).c_str(), a, file_name(cy.path).c_str(), b, ma.frames,
          ma.energy_J, ms_.energy_J, mi.energy_J, ma.energy_J / ms_.energy_J, ma.foot_sliding_m,
          ms_.foot_sliding_m, ma.skating_ratio, ms_.skating_ratio, mi.skating_ratio, src_ratio,
          ma.range_violations, ms_.range_violations, ma.peak_angular_speed_radps, ms);
      rows.push_back({{"from", file_name(cx.path)},
                      {"from_frame", a},
                      {"to", file_name(cy.path)},
                      {"to_frame", b},
                      {"astar", mocap::measures_json(ma)},
                      {"slerp", mocap::measures_json(ms_)},
                      {"inertialize", mocap::measures_json(mi)},
                      {"source_foot_skating_ratio", src_ratio},
                      {"source_foot_sliding_m", src_slide},
                      {"source_energy_J", src_g},
                      {"astar_ms", ms},
                      {"astar_cpu_ms", cpu_ms},
                      {"stop_reason", stats.stop_reason},
                      {"estimated_frames", stats.estimated_frames},
                      {"energy_evaluations", stats.energy_evaluations},
                      {"refine_steps", stats.refine_steps},
                      {"refine_gain_J", stats.refine_gain_J}});
    }
    auto median_of = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
    };
    std::vector<double> sorted = times_ms;
    std::sort(sorted.begin(), sorted.end());
    const double median = median_of(times_ms);
    const double cpu_median = median_of(cpu_times_ms);
    const double cpu_max = *std::max_element(cpu_times_ms.begin(), cpu_times_ms.end());
    const double n = static_cast<double>(specs.size());
    std::printf(
        "\nGaps: %zu. A* g lower than slerp in %zu (%.0f%%); mean g A* %.1f J, slerp %.1f J (ratio "
        "%.2f), "
        "inertialize %.1f J; the source clips' own g over as many steps %.1f J.\n",
        specs.size(), lower, 100.0 * static_cast<double>(lower) / n, sum_a / n, sum_s / n,
        sum_a / sum_s, sum_i / n, g_src / n);
    if (params.step_feet)
      std::printf(
          "Slerp with the same stepping pass: A* g lower in %zu gaps; its mean g %.1f J, "
          "foot-skating ratio %.3f.\n",
          lower_stepped, sum_ss / n, skate_ss / n);
    std::printf(
        "Foot sliding (total): A* %.3f m, slerp %.3f m, inertialize %.3f m; A* <= slerp in %zu "
        "gaps. "
        "Range violations: A* %zu, slerp %zu, inertialize %zu.\n",
        slide_a, slide_s, slide_i, slide_ok, viol_a, viol_s, viol_i);
    std::printf(
        "Foot-skating ratio (mean per gap): A* %.3f, slerp %.3f, inertialize %.3f, source clips "
        "%.3f; A* <= slerp in %zu gaps. Source clips' foot sliding over as many steps: %.3f m "
        "(total).\n",
        skate_a / n, skate_s / n, skate_i / n, skate_src / n, skate_ok, slide_src);
    std::printf(
        "Airborne ratio (no foot on the ground; mean per gap): A* %.3f, slerp %.3f, inertialize "
        "%.3f, source clips %.3f.\n",
        air_a / n, air_s / n, air_i / n, air_src / n);
    std::printf(
        "A* time per transition (one thread): median %.1f ms, max %.1f ms wall; processor time "
        "median %.1f ms, "
        "max %.1f ms.\n",
        median, sorted.back(), cpu_median, cpu_max);
    const auto share = [&](double part, double sum) { return 100.0 * part / sum; };
    const double ta = sum_a, ts = sum_s;
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
        split_a.residual_work_J / n, split_s.residual_work_J / n,
        share(split_a.residual_work_J, ta), share(split_s.residual_work_J, ts),
        split_a.residual_impulse_J / n, split_s.residual_impulse_J / n,
        share(split_a.residual_impulse_J, ta), share(split_s.residual_impulse_J, ts));
    if (!json_path.empty()) {
      nlohmann::json out = {{"gaps", rows},
                            {"summary",
                             {{"gaps", specs.size()},
                              {"astar_lower_g", lower},
                              {"mean_g_astar_J", sum_a / n},
                              {"mean_g_slerp_J", sum_s / n},
                              {"mean_g_inertialize_J", sum_i / n},
                              {"mean_g_source_J", g_src / n},
                              {"astar_lower_g_than_stepped_slerp", lower_stepped},
                              {"mean_g_stepped_slerp_J", sum_ss / n},
                              {"skating_ratio_stepped_slerp", skate_ss / n},
                              {"ratio_mean_g", sum_a / sum_s},
                              {"foot_sliding_astar_m", slide_a},
                              {"foot_sliding_slerp_m", slide_s},
                              {"foot_sliding_inertialize_m", slide_i},
                              {"skating_ratio_astar", skate_a / n},
                              {"skating_ratio_slerp", skate_s / n},
                              {"skating_ratio_inertialize", skate_i / n},
                              {"skating_ratio_source", skate_src / n},
                              {"airborne_ratio_astar", air_a / n},
                              {"airborne_ratio_slerp", air_s / n},
                              {"airborne_ratio_inertialize", air_i / n},
                              {"airborne_ratio_source", air_src / n},
                              {"foot_sliding_source_m", slide_src},
                              {"median_ms", median},
                              {"median_cpu_ms", cpu_median},
                              {"max_ms", sorted.back()}}},
                            {"params", mocap::supplement_params_json(params)}};
      out["params"]["exact_lookahead"] = params.exact_lookahead;
      out["params"]["from_fraction"] = from_fraction;
      out["params"]["to_fraction"] = to_fraction;
      std::ofstream(json_path) << mocap::json_text(out, 2) << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "mocap-synth-quality: " << e.what() << "\n";
    return 1;
  }
}
