// Tests for search/src/query/batch_entry.cpp: one batch entry from one query's
// text, as read_query_batch makes of a line and the Python module of a query.
// Texts that are not queries first: the error names source and line, and the
// id is kept when the text gives one.
#include "mocap/search/batch_entry.hpp"

#include <gtest/gtest.h>

namespace mocap {
namespace {

const char* kFrames =
    R"("frames": [{"root_position": [0, null, 0]}, {"root_position": [0, null, 3]}])";

BatchEntry entry(const std::string& text) {
  return parse_batch_entry(text, "q.jsonl", 4, "/data", "line 4");
}

TEST(BatchEntryTest, NotJsonGetsTheDefaultId) {
  const BatchEntry e = entry("this is not json");
  EXPECT_FALSE(e.query);
  EXPECT_EQ(e.id, "line 4");
  EXPECT_EQ(e.error.rfind("q.jsonl:4: ", 0), 0u) << e.error;
  EXPECT_NE(e.error.find("invalid JSON"), std::string::npos) << e.error;
}

TEST(BatchEntryTest, InvalidQueryKeepsItsId) {
  const BatchEntry named = entry(R"({"id": "walk", "frames": []})");
  EXPECT_FALSE(named.query);
  EXPECT_EQ(named.id, "walk");
  EXPECT_NE(named.error.find("q.jsonl:4: frames"), std::string::npos) << named.error;
  EXPECT_EQ(entry(R"({"id": 12, "frames": 3})").id, "12");
  // An id of another type is not an id: the default stays.
  EXPECT_EQ(entry(R"({"id": [1], "frames": 3})").id, "line 4");
  EXPECT_EQ(entry(R"([1, 2])").id, "line 4");
}

TEST(BatchEntryTest, ValidQuery) {
  const BatchEntry e = entry(std::string("{\"id\": \"step\", ") + kFrames + "}");
  ASSERT_TRUE(e.query);
  EXPECT_EQ(e.id, "step");
  EXPECT_EQ(e.query->id, "step");
  EXPECT_TRUE(e.error.empty());
  EXPECT_EQ(e.query->frames.size(), 2u);
  const BatchEntry anonymous = entry(std::string("{") + kFrames + "}");
  ASSERT_TRUE(anonymous.query);
  EXPECT_EQ(anonymous.id, "line 4");
}

}  // namespace
}  // namespace mocap
