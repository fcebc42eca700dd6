// Batch synthesis (synth_batch.hpp, synth_batch_folder.hpp): invalid inputs
// first (file names, a query that does not parse or cannot be warped, a
// query missing from the results file, a name taken twice, a folder that is
// a file, a foreign file in the folder), then the batch against synthesize()
// run on each query alone: the same frames, whatever the thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "mocap/search/batch_entry.hpp"
#include "mocap/search/search.hpp"
#include "mocap/synth/synth_batch.hpp"
#include "mocap/synth/synth_batch_folder.hpp"
#include "mocap/synth/synth_job.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

const std::string kSet1 = "bandai-namco-1/data/dataset-1_";

const Index* shared_index() {
  return test::built_index({kSet1 + "walk_normal_001.bvh", kSet1 + "walk_active_001.bvh",
                            kSet1 + "run_normal_001.bvh", kSet1 + "bow_normal_001.bvh",
                            kSet1 + "bye_normal_001.bvh", kSet1 + "bye_active_001.bvh"});
}

// A query of frames of one set-1 file (its clip excluded); timed when
// `times` is given.
std::string file_query(const std::string& id, const std::string& stem,
                       const std::vector<std::size_t>& frames,
                       const std::vector<double>& times = {}) {
  const std::string file = (test::data_dir() / (kSet1 + stem + ".bvh")).string();
  std::string out = R"({"id": ")" + id + R"(", "top": 5, "frames": [)";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    out += std::string(i ? ", " : "") + R"({"bvh": ")" + file + R"(", "frame": )" +
           std::to_string(frames[i]);
    if (!times.empty()) out += R"(, "time_s": )" + std::to_string(times[i]);
    out += "}";
  }
  return out + R"(], "filter": {"exclude": ["dataset-1_)" + stem + R"(*"]}})";
}

std::vector<BatchEntry> entries_of(const std::vector<std::string>& texts) {
  std::vector<BatchEntry> out;
  for (std::size_t i = 0; i < texts.size(); ++i)
    out.push_back(parse_batch_entry(texts[i], "<batch>", i + 1, fs::current_path(),
                                    "line " + std::to_string(i + 1)));
  return out;
}

// The frames of each query's motion (empty for a failed one), by running
// the batch with `threads` threads.
std::vector<std::vector<SynthFrame>> batch_frames(const Index& index,
                                                  std::vector<SynthBatchQuery> queries,
                                                  const SynthOptions& options,
                                                  std::size_t threads) {
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  search_synth_batch(index, queries);
  std::vector<std::vector<SynthFrame>> out(queries.size());
  std::mutex m;
  run_synth_batch(index, queries, options, [&](SynthBatchDone& d) {
    const std::lock_guard<std::mutex> lock(m);
    if (d.motion) out[d.index] = d.motion->result.frames;
  });
  return out;
}

void expect_same_frames(const std::vector<SynthFrame>& a, const std::vector<SynthFrame>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t f = 0; f < a.size(); ++f) {
    EXPECT_EQ(a[f].root_position_m, b[f].root_position_m) << "frame " << f;
    ASSERT_EQ(a[f].local_rotations.size(), b[f].local_rotations.size());
    for (std::size_t j = 0; j < a[f].local_rotations.size(); ++j)
      EXPECT_EQ(a[f].local_rotations[j].coeffs(), b[f].local_rotations[j].coeffs())
          << "frame " << f << " joint " << j;
  }
}

TEST(SynthBatch, FileNames) {
  EXPECT_EQ(synth_batch_file_name("walk-1.a_b", 3), "walk-1.a_b");
  EXPECT_EQ(synth_batch_file_name("a/b c", 3), "a_b_c");
  EXPECT_EQ(synth_batch_file_name("../x", 3), ".._x");
  EXPECT_EQ(synth_batch_file_name("", 7), "query-7");
  EXPECT_EQ(synth_batch_file_name(".", 7), "query-7");
  EXPECT_EQ(synth_batch_file_name("..", 7), "query-7");
  EXPECT_EQ(synth_batch_file_name("é", 7), "__");  // two bytes of UTF-8
}

TEST(SynthBatch, QueriesThatFailBeforeSynthesis) {
  SynthOptions warp;
  warp.warp_required = true;
  const std::vector<SynthBatchQuery> q =
      synth_batch_queries(entries_of({R"({"id": "ok", "frames": [{"root_position": [0, 0.9, 0]},
                                             {"root_position": [1, 0.9, 0]}]})",
                                      R"({"id": "broken", "frames": 3})", "not json"}),
                          warp);
  ASSERT_EQ(q.size(), 3u);
  ASSERT_TRUE(q[0].error);  // untimed: --warp by name refuses it
  EXPECT_NE(std::string(q[0].error->what()).find("needs a timed query"), std::string::npos);
  EXPECT_EQ(q[1].id, "broken");
  EXPECT_EQ(q[1].line, 2u);
  ASSERT_TRUE(q[1].error);
  EXPECT_EQ(q[2].id, "line 3");
  ASSERT_TRUE(q[2].error);
  EXPECT_NE(std::string(q[2].error->what()).find("<batch>:3"), std::string::npos);
  // Without the warp asked for, the untimed query is made.
  EXPECT_FALSE(synth_batch_queries(entries_of({R"({"id": "ok", "frames": [
      {"root_position": [0, 0.9, 0]}, {"root_position": [1, 0.9, 0]}]})"}),
                                   SynthOptions{})[0]
                   .error);
}

TEST(SynthBatch, ResultsFileWithoutTheQuery) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path dir = test::temp_dir("synth-batch-results");
  std::ofstream(dir / "r.jsonl") << R"({"id": "other", "error": "no"})"
                                 << "\n"
                                 << R"({"id": "failed", "error": "search failed"})"
                                 << "\n";
  std::vector<SynthBatchQuery> q =
      synth_batch_queries(entries_of({file_query("absent", "walk_normal_001", {10, 40}),
                                      file_query("failed", "walk_normal_001", {10, 40})}),
                          SynthOptions{});
  synth_batch_results_file(dir / "r.jsonl", *index, q);
  ASSERT_TRUE(q[0].error);
  EXPECT_NE(std::string(q[0].error->what()).find("no results for query \"absent\""),
            std::string::npos);
  ASSERT_TRUE(q[1].error);
  EXPECT_NE(std::string(q[1].error->what()).find("the search failed"), std::string::npos);
  EXPECT_THROW(synth_batch_results_file(dir / "missing.jsonl", *index, q), InputError);
}

TEST(SynthBatch, FolderRefusals) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const fs::path dir = test::temp_dir("synth-batch-folder");
  std::ofstream(dir / "file") << "hello";
  const SynthOptions options;
  SynthBatchFolderOptions bad;
  bad.dir = dir / "file";
  EXPECT_THROW(SynthBatchFolder(*index, options, bad), InputError);
  SynthBatchFolderOptions o;
  o.dir = dir / "out" / "new";  // created with its parent
  SynthBatchFolder folder(*index, options, o);
  EXPECT_TRUE(fs::is_directory(o.dir));
  std::ofstream(o.dir / "foreign.bvh") << "hello";
  std::vector<SynthBatchQuery> q =
      synth_batch_queries(entries_of({file_query("a/b", "walk_normal_001", {10, 40}),
                                      file_query("a_b", "walk_normal_001", {10, 40}),
                                      file_query("foreign", "walk_normal_001", {10, 40})}),
                          options);
  folder.name(q);
  EXPECT_FALSE(q[0].error);
  ASSERT_TRUE(q[1].error);  // a_b.bvh is a/b's
  EXPECT_NE(std::string(q[1].error->what()).find("\"a_b\""), std::string::npos);
  EXPECT_NE(std::string(q[1].error->what()).find("\"a/b\""), std::string::npos);
  ASSERT_TRUE(q[2].error);  // a text file is not replaced without --force
  std::ifstream in(o.dir / "foreign.bvh");
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "hello");
}

TEST(SynthBatch, FramesEqualSingleRunsWhateverTheThreads) {
  MOCAP_REQUIRE_DATA();
  const Index* index = shared_index();
  ASSERT_NE(index, nullptr);
  const std::vector<std::string> texts = {
      file_query("two", "walk_normal_001", {20, 70}), "{broken",
      file_query("three", "bye_normal_001", {10, 50, 90}),
      file_query("timed", "walk_active_001", {10, 40}, {0.0, 1.0})};
  const SynthOptions options;
  const std::vector<SynthBatchQuery> queries = synth_batch_queries(entries_of(texts), options);
  const auto one = batch_frames(*index, queries, options, 1);
  const auto two = batch_frames(*index, queries, options, 2);
  EXPECT_TRUE(one[1].empty());
  for (std::size_t i : {0u, 2u, 3u}) {
    SCOPED_TRACE(texts[i].substr(0, 20));
    ASSERT_FALSE(one[i].empty());
    expect_same_frames(one[i], two[i]);
    const Query q =
        query_for_fill(parse_query_text(texts[i], "<test>", 0, fs::current_path(), "q"), options);
    const QueryOutcome found = SearchEngine(*index).run(q, SearchOptions{});
    ASSERT_FALSE(found.error);
    std::optional<SynthSkeleton> skeleton;
    const SynthResult alone = synthesize(*index, q, found.pairs, options, skeleton);
    expect_same_frames(one[i], alone.frames);
  }
}

}  // namespace
