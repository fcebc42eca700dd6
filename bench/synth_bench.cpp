// Supplementation benchmarks on real gaps of Bandai Namco set 1 (the gaps of
// mocap-synth-quality, docs/synthesis.md): time per supplementary motion for
// A* (supplement_astar with the default parameters), slerp and
// inertialization (at the A* result's length). One gap per iteration, taken
// in turn; single-threaded. "median_ms" is the median over the gaps of the
// processor time of one motion (the issue's "median time per supplementary
// motion on one core").
//
// Data: an index of set 1 built once with this build's mocap-index into a
// temporary folder from $MOCAP_DATA_DIR/bandai-namco-1 (default
// ../shared/data), or the index file $MOCAP_SYNTH_BENCH_INDEX. Without data
// every benchmark skips with an error message.
#include <benchmark/benchmark.h>

#include <tbb/global_control.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/synth/synth.hpp"

namespace {

using namespace mocap;

std::filesystem::path data_dir() {
  if (const char* e = std::getenv("MOCAP_DATA_DIR"); e && *e) return e;
  return MOCAP_DEFAULT_DATA_DIR;
}

struct Gap {
  std::shared_ptr<const SynthSkeleton> skeleton;
  std::shared_ptr<const RangeOfMotion> range;
  GapProblem problem;
  std::size_t astar_frames = 0;
};

struct Data {
  bool ok = false;
  std::string why = "no Bandai Namco set 1 data";
  std::unique_ptr<Index> index;
  std::vector<Gap> gaps;
};

std::unique_ptr<Index> open_index(std::string& why) {
  if (const char* e = std::getenv("MOCAP_SYNTH_BENCH_INDEX"); e && *e)
    return std::make_unique<Index>(Index::open(e));
  const auto set1 = data_dir() / "bandai-namco-1";
  if (!std::filesystem::is_directory(set1 / "data")) {
    why = "no Bandai Namco set 1 data at " + set1.string();
    return nullptr;
  }
  const auto dir = std::filesystem::temp_directory_path() / "mocap-synth-bench";
  std::filesystem::create_directories(dir);
  const auto out = dir / "set1.h5";
  const std::string cmd = std::string(MOCAP_BINARY_DIR) + "/indexer/mocap-index build --out '" +
                          out.string() + "' '" + set1.string() + "' >/dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) {
    why = "mocap-index build failed";
    return nullptr;
  }
  return std::make_unique<Index>(Index::open(out));
}

// The quality tool's gaps: per content label the first pairs of clips on one
// skeleton (round robin over labels, at most 3 per label, 34 in all), frame
// |X|/3 of X to frame |Y|/2 of Y, Y placed by continuation_placement.
const Data& data() {
  static const Data d = [] {
    Data x;
    try {
      x.index = open_index(x.why);
    } catch (const std::exception& e) {
      x.why = e.what();
    }
    if (!x.index) return x;
    const Index& index = *x.index;
    std::map<std::string, std::vector<std::size_t>> by_label;
    for (std::size_t c = 0; c < index.clips().size(); ++c) {
      const std::string v = index.label(c, "content");
      if (!v.empty() && index.clips()[c].frame_count >= 20) by_label[v].push_back(c);
    }
    std::vector<std::vector<std::pair<std::size_t, std::size_t>>> per_label;
    for (const auto& [label, clips] : by_label) {
      std::vector<std::pair<std::size_t, std::size_t>> v;
      for (std::size_t i = 0; i < clips.size() && v.size() < 3; ++i)
        for (std::size_t j = i + 1; j < clips.size() && v.size() < 3; ++j)
          if (index.clips()[clips[i]].skeleton == index.clips()[clips[j]].skeleton) {
            v.emplace_back(clips[i], clips[j]);
            i = j;
            break;
          }
      per_label.push_back(std::move(v));
    }
    std::vector<std::pair<std::size_t, std::size_t>> specs;
    for (std::size_t round = 0; round < 3; ++round)
      for (const auto& v : per_label)
        if (round < v.size() && specs.size() < 34) specs.push_back(v[round]);
    std::map<std::uint32_t,
             std::pair<std::shared_ptr<const SynthSkeleton>, std::shared_ptr<const RangeOfMotion>>>
        skeletons;
    const SupplementParams params;
    for (const auto& [cx, cy] : specs) {
      const IndexClip& X = index.clips()[cx];
      const IndexClip& Y = index.clips()[cy];
      auto& s = skeletons[X.skeleton];
      if (!s.first) {
        auto sk = std::make_shared<SynthSkeleton>(make_synth_skeleton(index, X.skeleton, cx));
        s.second = std::make_shared<RangeOfMotion>(
            range_of_motion(index, *sk, index.skeletons()[X.skeleton].clips));
        s.first = std::move(sk);
      }
      Gap g;
      g.skeleton = s.first;
      g.range = s.second;
      GapProblem& gap = g.problem;
      gap.skeleton = g.skeleton.get();
      gap.range = g.range.get();
      gap.frame_time_s = X.frame_time_s;
      const auto a = std::clamp<std::size_t>(X.frame_count / 3, 1, X.frame_count - 1);
      const auto b = std::min<std::size_t>(Y.frame_count / 2, Y.frame_count - 2);
      gap.before = clip_frame(index, cx, a - 1);
      gap.start = clip_frame(index, cx, a);
      const SynthFrame g0 = clip_frame(index, cy, b), g1 = clip_frame(index, cy, b + 1);
      const double dt = gap.frame_time_s;
      const Eigen::Vector3d ve = horizontal_root_velocity(gap.before, gap.start, dt);
      const Eigen::Vector3d vf = horizontal_root_velocity(g0, g1, dt);
      Placement p = continuation_placement(*g.skeleton, gap.start, ve, g0, vf, 0.0);
      gap.goal = place_frame(*g.skeleton, g0, p);
      gap.after = place_frame(*g.skeleton, g1, p);
      const std::size_t est = estimate_transition_frames(gap, params);
      p = continuation_placement(*g.skeleton, gap.start, ve, g0, vf,
                                 static_cast<double>(est + 1) * dt);
      gap.goal = place_frame(*g.skeleton, g0, p);
      gap.after = place_frame(*g.skeleton, g1, p);
      g.astar_frames = supplement_astar(gap, params).size();
      x.gaps.push_back(std::move(g));
    }
    x.ok = !x.gaps.empty();
    return x;
  }();
  return d;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Runs `one(gap)` on the gaps in turn, one per iteration; median_ms: median
// over the gaps of the processor time per motion (best of the gap's runs).
template <class F>
void run_gaps(benchmark::State& st, F&& one) {
  const Data& d = data();
  if (!d.ok) return st.SkipWithError(d.why.c_str());
  std::vector<double> best_ms(d.gaps.size(), 1e300);
  std::size_t i = 0, frames = 0;
  for (auto _ : st) {
    const Gap& g = d.gaps[i];
    const std::clock_t c0 = std::clock();
    const std::vector<SynthFrame> out = one(g);
    const std::clock_t c1 = std::clock();
    benchmark::DoNotOptimize(out.data());
    frames += out.size();
    best_ms[i] = std::min(best_ms[i], 1000.0 * static_cast<double>(c1 - c0) / CLOCKS_PER_SEC);
    i = (i + 1) % d.gaps.size();
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
  st.counters["gaps"] = static_cast<double>(d.gaps.size());
  st.counters["frames_per_motion"] =
      static_cast<double>(frames) / static_cast<double>(std::max<std::int64_t>(1, st.iterations()));
  std::vector<double> seen;
  for (double v : best_ms)
    if (v < 1e300) seen.push_back(v);
  if (seen.size() == d.gaps.size()) st.counters["median_ms"] = median_of(seen);
}

void BM_SupplementAStar(benchmark::State& st) {
  run_gaps(st, [](const Gap& g) { return supplement_astar(g.problem, SupplementParams{}); });
}
BENCHMARK(BM_SupplementAStar)->Unit(benchmark::kMillisecond)->MinTime(3.0);

// The search followed by the refinement (mocap-synth --refine N), on one
// thread like the others (the refinement's gradient is parallel).
void BM_SupplementAStarRefined(benchmark::State& st) {
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  SupplementParams params;
  params.refine.iterations = static_cast<std::size_t>(st.range(0));
  run_gaps(st, [&](const Gap& g) { return supplement_astar(g.problem, params); });
}
BENCHMARK(BM_SupplementAStarRefined)->Arg(30)->Unit(benchmark::kMillisecond)->MinTime(10.0);

void BM_SlerpTransition(benchmark::State& st) {
  run_gaps(st, [](const Gap& g) { return slerp_transition(g.problem, g.astar_frames); });
}
BENCHMARK(BM_SlerpTransition)->Unit(benchmark::kMicrosecond);

void BM_InertializeTransition(benchmark::State& st) {
  run_gaps(st, [](const Gap& g) { return inertialize_transition(g.problem, g.astar_frames); });
}
BENCHMARK(BM_InertializeTransition)->Unit(benchmark::kMicrosecond);

// The measures of one transition (what the report adds to each motion).
void BM_MeasureTransition(benchmark::State& st) {
  run_gaps(st, [](const Gap& g) {
    const auto fs = slerp_transition(g.problem, g.astar_frames);
    benchmark::DoNotOptimize(measure_transition(g.problem, fs).energy_J);
    return fs;
  });
}
BENCHMARK(BM_MeasureTransition)->Unit(benchmark::kMicrosecond);

}  // namespace
