#pragma once
// Shared by the search tests: the golden and set-1 indexes, query parsing
// against the golden data folder, and result comparison.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "test_support.hpp"

namespace mocap::test {

inline std::filesystem::path golden_index() {
  return std::filesystem::path(MOCAP_SOURCE_DIR) / "tests/data/index/index-v3.h5";
}

// A query from JSON text; relative paths resolve against the golden data folder.
inline Query parse(const std::string& text) {
  return parse_query_text(text, "<test>", 0,
                          std::filesystem::path(MOCAP_SOURCE_DIR) / "tests/data/index", "q");
}

// parse(text) fails with a message holding `part`.
inline void expect_parse_error(const std::string& text, const std::string& part) {
  try {
    (void)parse(text);
    ADD_FAILURE() << "no error for " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

// A set-1 index (with `character` when not empty) in a folder named by
// `tag`; empty path on failure.
inline std::filesystem::path build_set1_index(const std::string& tag,
                                              const std::filesystem::path& character) {
  return build_index_with_binary(data_dir() / "bandai-namco-1/data", temp_dir(tag) / "set1.h5",
                                 character);
}

// A set-1 index built once per test executable run, in a folder named by `tag`.
inline const std::filesystem::path& set1_index(const std::string& tag) {
  static const std::filesystem::path path = build_set1_index(tag, {});
  return path;
}

// Same clips, frames and scores (within `rel` of max(1, |score|); 0: equal),
// pair by pair.
inline void expect_same_results(const QueryOutcome& x, const QueryOutcome& y,
                                const std::string& what, double rel = 1e-6) {
  ASSERT_FALSE(x.error) << what << ": " << *x.error;
  ASSERT_FALSE(y.error) << what << ": " << *y.error;
  ASSERT_EQ(x.pairs.size(), y.pairs.size()) << what;
  for (std::size_t p = 0; p < x.pairs.size(); ++p) {
    const auto& a = x.pairs[p].results;
    const auto& b = y.pairs[p].results;
    ASSERT_EQ(a.size(), b.size()) << what << " pair " << p;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].clip_index, b[i].clip_index) << what << " pair " << p << " rank " << i + 1;
      EXPECT_EQ(a[i].start_frame, b[i].start_frame) << what << " rank " << i + 1;
      EXPECT_EQ(a[i].end_frame, b[i].end_frame) << what << " rank " << i + 1;
      EXPECT_NEAR(a[i].score_J, b[i].score_J, rel * std::max(1.0, std::abs(a[i].score_J)))
          << what << " pair " << p << " rank " << i + 1;
    }
  }
}

}  // namespace mocap::test
