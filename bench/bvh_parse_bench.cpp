// BVH parsing throughput: whole files already in memory, only parse_bvh timed,
// one thread. Reports bytes/s and frames/s.
//   Set 1: ../shared/data/bandai-namco-1/data (or $MOCAP_DATA_DIR/...).
//   Set 2: $MOCAP_BN2_DIR, else unpacked once into <tmp>/mocap-bandai-namco-2.
#include <benchmark/benchmark.h>

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mocap/common/io/bvh.hpp"

namespace {

namespace fs = std::filesystem;

fs::path data_dir() {
  if (const char* env = std::getenv("MOCAP_DATA_DIR"); env && *env) return env;
  return MOCAP_DEFAULT_DATA_DIR;
}

fs::path bandai_namco_2_dir() {
  if (const char* env = std::getenv("MOCAP_BN2_DIR"); env && *env) return env;
  const fs::path archive = data_dir() / "bandai-namco-2.tar.zst";
  const fs::path cache = fs::temp_directory_path() / "mocap-bandai-namco-2";
  const fs::path data = cache / "bandai-namco-2" / "data";
  if (fs::exists(cache / ".unpacked")) return data;
  if (!fs::exists(archive)) return {};
  // Unpacked into a folder of this process's own, then renamed into place:
  // a process running at the same time (a test, another benchmark) never
  // reads a half-written cache (tests/test_support.cpp does the same).
  const fs::path mine = cache.string() + ".tmp-" + std::to_string(::getpid());
  std::error_code ec;
  fs::remove_all(mine, ec);
  fs::create_directories(mine, ec);
  const std::string cmd = "tar --zstd -xf '" + archive.string() + "' -C '" + mine.string() + "'";
  if (ec || std::system(cmd.c_str()) != 0) {
    fs::remove_all(mine, ec);
    return {};
  }
  std::ofstream(mine / ".unpacked").put('\n');
  fs::rename(mine, cache, ec);
  if (ec && !fs::exists(cache / ".unpacked")) {  // a half-written cache of an older version
    fs::remove_all(cache, ec);
    fs::rename(mine, cache, ec);
  }
  fs::remove_all(mine, ec);
  return fs::exists(cache / ".unpacked") ? data : fs::path{};
}

struct Corpus {
  std::vector<std::string> texts;
  std::size_t bytes = 0;
};

Corpus load(const fs::path& dir) {
  Corpus c;
  if (dir.empty() || !fs::is_directory(dir)) return c;
  std::vector<fs::path> paths;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".bvh") paths.push_back(e.path());
  std::sort(paths.begin(), paths.end());
  for (const auto& p : paths) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    c.texts.push_back(ss.str());
    c.bytes += c.texts.back().size();
  }
  return c;
}

void parse_corpus(benchmark::State& state, const Corpus& corpus, const char* what) {
  if (corpus.texts.empty()) {
    state.SkipWithError((std::string("no data for ") + what).c_str());
    return;
  }
  std::size_t frames = 0;
  for (auto _ : state) {
    frames = 0;
    for (const std::string& t : corpus.texts) {
      const mocap::RawClip clip = mocap::parse_bvh(t, what);
      frames += clip.frame_count;
      benchmark::DoNotOptimize(clip.values.data());
    }
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * corpus.bytes));
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["files"] = static_cast<double>(corpus.texts.size());
  state.counters["MB"] = static_cast<double>(corpus.bytes) / 1e6;
}

void BM_ParseBandaiNamco1(benchmark::State& state) {
  static const Corpus corpus = load(data_dir() / "bandai-namco-1" / "data");
  parse_corpus(state, corpus, "bandai-namco-1");
}
BENCHMARK(BM_ParseBandaiNamco1)->Unit(benchmark::kMillisecond);

void BM_ParseBandaiNamco2(benchmark::State& state) {
  static const Corpus corpus = load(bandai_namco_2_dir());
  parse_corpus(state, corpus, "bandai-namco-2");
}
BENCHMARK(BM_ParseBandaiNamco2)->Unit(benchmark::kMillisecond)->MinTime(2.0);

void BM_WriteBandaiNamco1(benchmark::State& state) {
  static const Corpus corpus = load(data_dir() / "bandai-namco-1" / "data");
  std::vector<mocap::RawClip> clips;
  for (const std::string& t : corpus.texts) clips.push_back(mocap::parse_bvh(t, "set1"));
  if (clips.empty()) {
    state.SkipWithError("no data for bandai-namco-1");
    return;
  }
  std::size_t bytes = 0;
  for (auto _ : state) {
    bytes = 0;
    for (const mocap::RawClip& c : clips) bytes += mocap::write_bvh(c).size();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
}
BENCHMARK(BM_WriteBandaiNamco1)->Unit(benchmark::kMillisecond);

}  // namespace
