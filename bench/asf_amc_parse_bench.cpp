// AMC parsing throughput: the CMU takes of ../shared/data/cmu-asf-amc (or
// $MOCAP_DATA_DIR/cmu-asf-amc, as bvh_parse_bench) read into memory once with
// their skeletons parsed; parse_amc (+ asf_amc_to_raw_clip) timed, one thread.
// Reports bytes/s of AMC text and frames/s; skips without the data.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/util/error.hpp"

namespace {

namespace fs = std::filesystem;

fs::path data_dir() {
  if (const char* env = std::getenv("MOCAP_DATA_DIR"); env && *env) return env;
  return MOCAP_DEFAULT_DATA_DIR;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// One AMC take with the skeleton it belongs to (charleston1.amc ->
// charleston.asf: the longest .asf stem that prefixes the take's stem).
struct Take {
  std::string name;
  std::string amc;
  const mocap::AsfSkeleton* skeleton = nullptr;
};

struct Corpus {
  std::vector<mocap::AsfSkeleton> skeletons;
  std::vector<Take> takes;
  std::size_t bytes = 0;
};

Corpus load(const fs::path& dir) {
  Corpus c;
  if (!fs::is_directory(dir)) return c;
  std::vector<fs::path> asfs, amcs;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".asf") asfs.push_back(e.path());
    if (e.path().extension() == ".amc") amcs.push_back(e.path());
  }
  std::sort(asfs.begin(), asfs.end());
  std::sort(amcs.begin(), amcs.end());
  try {
    for (const auto& p : asfs) c.skeletons.push_back(mocap::read_asf_file(p));
  } catch (const mocap::InputError&) {
    return {};
  }
  for (const auto& p : amcs) {
    const std::string stem = p.stem().string();
    std::size_t best = asfs.size(), best_len = 0;
    for (std::size_t i = 0; i < asfs.size(); ++i) {
      const std::string s = asfs[i].stem().string();
      if (stem.starts_with(s) && s.size() > best_len) {
        best = i;
        best_len = s.size();
      }
    }
    if (best == asfs.size()) continue;
    c.takes.push_back({p.filename().string(), read_all(p), &c.skeletons[best]});
    c.bytes += c.takes.back().amc.size();
  }
  return c;
}

const Corpus& cmu() {
  static const Corpus corpus = load(data_dir() / "cmu-asf-amc");
  return corpus;
}

void report(benchmark::State& state, const Corpus& corpus, std::size_t frames) {
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * corpus.bytes));
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["files"] = static_cast<double>(corpus.takes.size());
  state.counters["MB"] = static_cast<double>(corpus.bytes) / 1e6;
}

// Every take parsed (parse_amc), and with `to_clip` converted to a RawClip
// too (asf_amc_to_raw_clip: what read_asf_amc_files costs per take).
void parse_takes(benchmark::State& state, bool to_clip) {
  const Corpus& corpus = cmu();
  if (corpus.takes.empty()) {
    state.SkipWithError("no data for cmu-asf-amc");
    return;
  }
  std::size_t frames = 0;
  for (auto _ : state) {
    frames = 0;
    for (const Take& t : corpus.takes) {
      const mocap::AmcMotion m = mocap::parse_amc(t.amc, t.name, *t.skeleton);
      frames += m.frame_count;
      if (to_clip) {
        const mocap::RawClip clip = mocap::asf_amc_to_raw_clip(*t.skeleton, m);
        benchmark::DoNotOptimize(clip.values.data());
      } else {
        benchmark::DoNotOptimize(m.values.data());
      }
    }
  }
  report(state, corpus, frames);
}

void BM_ParseAmcCmu(benchmark::State& state) {
  parse_takes(state, false);
}
BENCHMARK(BM_ParseAmcCmu)->Unit(benchmark::kMillisecond);

void BM_ParseAmcToRawClipCmu(benchmark::State& state) {
  parse_takes(state, true);
}
BENCHMARK(BM_ParseAmcToRawClipCmu)->Unit(benchmark::kMillisecond);

}  // namespace
