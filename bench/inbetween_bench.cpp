// Time per in-between in a warm process (docs/inbetweening.md "Time"): the
// held-out 30-frame in-betweens of scripts/inbetween-benchmark (every k-th
// clip of a set, a gap at 30% of the take, the clip excluded), each searched
// (SearchEngine::run) and synthesised (synthesize) by one process that has
// the index open, on one thread. One untimed query first loads what every
// query reads (the index's arrays, checked against their checksums).
//   inbetween_bench INDEX.h5 DATA_FOLDER [CLIPS] [GAP]
// Prints one JSON object: queries, median and max milliseconds of the
// search, of the synthesis and of both.
#include <tbb/global_control.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_job.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty()      ? 0.0
         : v.size() % 2 ? v[v.size() / 2]
                        : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: inbetween_bench INDEX.h5 DATA_FOLDER [CLIPS] [GAP]\n");
    return 2;
  }
  const std::size_t clips = argc > 3 ? std::stoul(argv[3]) : 30;
  const std::size_t gap = argc > 4 ? std::stoul(argv[4]) : 30;
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  try {
    const Index index = Index::open(argv[1]);
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(argv[2]))
      if (e.path().extension() == ".bvh") files.push_back(fs::absolute(e.path()));
    std::sort(files.begin(), files.end());
    const std::size_t step =
        std::max<std::size_t>(1, files.size() / std::max<std::size_t>(1, clips));
    std::vector<Query> queries;
    for (std::size_t i = 0; i < files.size() && queries.size() < clips; i += step) {
      const std::size_t frames = read_bvh_file(files[i].string()).frame_count;
      const auto a = static_cast<std::size_t>(std::llround(0.3 * static_cast<double>(frames - 1)));
      if (a + gap + 1 >= frames) continue;
      const std::string f = files[i].string(), stem = files[i].stem().string();
      const double t = static_cast<double>(gap + 1) / 30.0;
      const std::string text = R"({"id": ")" + stem + R"(", "top": 1, "frames": [{"bvh": ")" + f +
                               R"(", "frame": )" + std::to_string(a) +
                               R"(, "time_s": 0}, {"bvh": ")" + f + R"(", "frame": )" +
                               std::to_string(a + gap + 1) + R"(, "time_s": )" + std::to_string(t) +
                               R"(}], "filter": {"exclude": [")" + stem + R"(*"]}})";
      queries.push_back(parse_query_text(text, "<bench>", 0, fs::current_path(), stem));
    }
    const SearchEngine engine(index);
    std::vector<double> search_ms, synth_ms, total_ms;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      const QueryOutcome found = engine.run(queries[i], SearchOptions{});
      const double s = ms_since(t0);
      if (found.error) continue;
      const auto t1 = std::chrono::steady_clock::now();
      std::optional<SynthSkeleton> sk;
      (void)synthesize(index, queries[i], found.pairs, SynthOptions{}, sk);
      const double y = ms_since(t1);
      if (i == 0) continue;  // the warm-up
      search_ms.push_back(s);
      synth_ms.push_back(y);
      total_ms.push_back(s + y);
    }
    auto top = [](const std::vector<double>& v) {
      return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
    };
    std::printf(
        "{\"queries\": %zu, \"gap_frames\": %zu, \"search_median_ms\": %.2f, \"search_max_ms\": "
        "%.2f, \"synth_median_ms\": %.2f, \"synth_max_ms\": %.2f, \"total_median_ms\": %.2f, "
        "\"total_max_ms\": %.2f}\n",
        total_ms.size(), gap, median(search_ms), top(search_ms), median(synth_ms), top(synth_ms),
        median(total_ms), top(total_ms));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "inbetween_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
