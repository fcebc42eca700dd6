// Tests for search/src/query/query_file.cpp: one query picked from a query file
// that holds one JSON query or a JSONL batch (mocap-synth --query, --id).
// Invalid files and picks first, then what is read.
#include "mocap/search/query_file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

const std::string kFrames =
    R"("frames": [{"root_position": [0, null, 0]}, {"root_position": [1, null, 0]}])";

std::filesystem::path write(const std::string& name, const std::string& text) {
  static const std::filesystem::path dir = test::temp_dir("query_file");
  const std::filesystem::path p = dir / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

std::string line(const std::string& id) {
  return R"({"id": ")" + id + R"(", )" + kFrames + "}\n";
}

// The message of what select_query throws for `id` on `path`.
std::string pick_error(const std::filesystem::path& path, const std::string& id) {
  try {
    select_query(read_query_file(path), id, path);
  } catch (const InputError& e) {
    return std::string("InputError: ") + e.what();
  } catch (const std::runtime_error& e) {
    return std::string("runtime_error: ") + e.what();
  }
  ADD_FAILURE() << "picked a query from " << path << " with --id '" << id << "'";
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(QueryFile, InvalidFilesAndPicks) {
  EXPECT_THROW(read_query_file(write("x", "") / "missing.jsonl"), InputError);
  const auto empty = write("empty.jsonl", "\n  \n");
  EXPECT_EQ(pick_error(empty, ""), "InputError: " + empty.string() + ": holds no query");
  // Several queries and no --id: how many, their ids, and --id.
  const auto three =
      write("three.jsonl", line("walk") + "\n" + line("bow") + "{" + kFrames + "}\n");
  EXPECT_EQ(pick_error(three, ""), "InputError: " + three.string() +
                                       ": holds 3 queries (ids \"walk\", \"bow\", \"line 4\"); "
                                       "pick one with --id ID");
  EXPECT_EQ(pick_error(three, "run"), "InputError: " + three.string() +
                                          ": no query with id \"run\" (--id); the ids it holds: "
                                          "\"walk\", \"bow\", \"line 4\"");
  // The first ten ids, then how many more.
  std::string many;
  for (int i = 0; i < 12; ++i) many += line("q" + std::to_string(i));
  const std::string m = pick_error(write("many.jsonl", many), "");
  EXPECT_TRUE(has(m, "holds 12 queries (ids \"q0\", \"q1\",")) << m;
  EXPECT_TRUE(has(m, "\"q9\", ... (2 more)")) << m;
  EXPECT_FALSE(has(m, "\"q10\"")) << m;
  // Ids must pick one query.
  const auto twice = write("twice.jsonl", line("a") + line("a") + line("b"));
  EXPECT_TRUE(has(pick_error(twice, "a"), "holds 2 queries with id \"a\""))
      << pick_error(twice, "a");
  // The picked line's own parse error, with the file and line: the query's
  // InputError itself (its source and line kept).
  const auto bad = write("bad.jsonl", line("good") + R"({"id": "bad", "frames": 3})" + "\n");
  EXPECT_EQ(pick_error(bad, "bad"),
            "InputError: " + bad.string() + ":2: frames: expected a list of query frames");
  try {
    (void)select_query(read_query_file(bad), "bad", bad.string());
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), bad.string());
    EXPECT_EQ(e.line(), 2u);
  }
  // A single query: its id must match --id.
  const auto single = write("single.json", "{\n  " + kFrames + "\n}\n");
  EXPECT_TRUE(has(pick_error(single, "walk"), "the ids it holds: \"single\""));
  // A single query spread over lines with a syntax error is that query's error,
  // not a batch of broken lines.
  const auto broken = write("broken.json", "{\n  \"id\": \"x\",\n  " + kFrames + ",\n}\n");
  const std::vector<BatchEntry> entries = read_query_file(broken);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_FALSE(entries[0].query);
  EXPECT_TRUE(has(entries[0].error, broken.string() + ": invalid JSON")) << entries[0].error;
}

TEST(QueryFile, BatchesAndSingleQueries) {
  const auto three = write("ok.jsonl", line("walk") + "\n" + line("bow") + line("run"));
  const std::vector<BatchEntry> entries = read_query_file(three);
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(select_query(entries, "bow", three).id, "bow");
  EXPECT_EQ(select_query(entries, "run", three).frames.size(), 2u);
  // The batch reader's entries, one per non-blank line.
  const std::vector<BatchEntry> batch = read_query_batch(three);
  ASSERT_EQ(batch.size(), entries.size());
  for (std::size_t i = 0; i < batch.size(); ++i) EXPECT_EQ(batch[i].id, entries[i].id);
  // One query over several lines, or on one: the file stem is its id unless it has one.
  const auto spread = write("spread.json", "{\n  " + kFrames + ",\n  \"top\": 3\n}\n");
  const Query q = select_query(read_query_file(spread), "", spread);
  EXPECT_EQ(q.id, "spread");
  EXPECT_EQ(q.top, 3u);
  EXPECT_EQ(select_query(read_query_file(spread), "spread", spread).top, 3u);
  const auto one = write("one.jsonl", line("walk") + "\n\n");
  EXPECT_EQ(read_query_file(one).size(), 1u);
  EXPECT_EQ(select_query(read_query_file(one), "", one).id, "walk");
  EXPECT_EQ(select_query(read_query_file(one), "walk", one).id, "walk");
  // Relative paths resolve against the file's folder, as for mocap-search.
  const auto rel = write(
      "rel.jsonl",
      line("a") +
          R"({"id": "b", "frames": [{"bvh": "x.bvh", "frame": 1}, {"root_position": [0, null, 0]}]})" +
          "\n");
  EXPECT_EQ(*select_query(read_query_file(rel), "b", rel).frames[0].bvh,
            rel.parent_path() / "x.bvh");
}

// Queries written over several lines in a batch (as the docs show them):
// each line's error names the lines that make one query and the fix; a valid
// line between them is untouched, and lines that make no query together get
// no hint.
TEST(QueryFile, QueriesSpreadOverLinesInABatchAreNamed) {
  const auto path = write("multi-line.jsonl", "{\"id\": \"a\",\n  " + kFrames + "}\n" + line("ok") +
                                                  "{\"id\": \"b\",\n  " + kFrames +
                                                  ",\n \"top\": 2\n}\n{\"id\": \"c\",\nnot json\n");
  const std::vector<BatchEntry> batch = read_query_batch(path);
  ASSERT_EQ(batch.size(), 9u);
  for (std::size_t i : {0u, 1u})
    EXPECT_TRUE(has(batch[i].error, "lines 1-2 are one query spread over several lines"))
        << batch[i].error;
  EXPECT_TRUE(batch[2].error.empty()) << batch[2].error;
  EXPECT_EQ(batch[2].id, "ok");
  for (std::size_t i : {3u, 4u, 5u, 6u}) {
    EXPECT_TRUE(has(batch[i].error, "lines 4-7 are one query")) << batch[i].error;
    EXPECT_TRUE(has(batch[i].error, "one query per line")) << batch[i].error;
    EXPECT_TRUE(has(batch[i].error, "--query")) << batch[i].error;
    ASSERT_TRUE(batch[i].failure.has_value());
    EXPECT_EQ(batch[i].failure->line(), batch[i].line);
  }
  for (std::size_t i : {7u, 8u}) {
    EXPECT_FALSE(batch[i].error.empty());
    EXPECT_FALSE(has(batch[i].error, "spread")) << batch[i].error;
  }
}

}  // namespace
}  // namespace mocap
