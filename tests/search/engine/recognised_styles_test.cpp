// search/src/engine/recognised_styles.cpp and a query's "style"
// (docs/style.md "Asking for a style"): invalid fields and a style the
// model lacks are named; a query with "style" needs a model; the style
// distance is a cross-entropy (>= 0, log K for a clip with nothing known);
// exact equals brute with a style term, relative and world, over a middle
// key pose; each result's style_J is its weight x its clip's distance, and
// asking for "old" ranks set 1's old takes first where h alone ranks others;
// results labelled with their recognised style.
#include "mocap/search/recognised_styles.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "mocap/common/io/index.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"
#include "search_fixtures.hpp"
#include "test_support.hpp"

using namespace mocap;

namespace {

const std::filesystem::path& set1_index() {
  return test::set1_index("style-set1");
}

std::string old_walk() {
  return (test::data_dir() / "bandai-namco-1/data/dataset-1_walk_old_001.bvh").string();
}

std::string query(const std::string& style, const std::string& relative = "true", int frames = 2) {
  const std::string w = old_walk();
  std::string f = R"({"bvh": ")" + w + R"(", "frame": 20}, {"bvh": ")" + w + R"(", "frame": 60})";
  if (frames == 3) f += R"(, {"bvh": ")" + w + R"(", "frame": 100})";
  return R"({"id": "q", "top": 10, "relative": )" + relative + R"(, "frames": [)" + f +
         R"(], "filter": {"exclude": ["dataset-1_walk_old_001*"]})" +
         (style.empty() ? "" : R"(, "style": )" + style) + "}";
}

std::shared_ptr<const StyleModel> set1_model(const Index& index) {
  std::vector<std::string> joints;
  const std::vector<StyleSample> samples = index_style_samples(index, joints);
  return std::make_shared<const StyleModel>(learn_style_model(samples, joints));
}

TEST(QueryStyle, InvalidFieldsAreNamed) {
  test::expect_parse_error(query(R"("old")"), "style: expected an object");
  test::expect_parse_error(query(R"({})"), "give either");
  test::expect_parse_error(query(R"({"label": "old", "like": {"bvh": "x.bvh"}})"), "give either");
  test::expect_parse_error(query(R"({"label": ""})"), "style.label");
  test::expect_parse_error(query(R"({"label": "old", "weight": 0})"), "style.weight");
  test::expect_parse_error(query(R"({"lable": "old"})"), "lable");
  test::expect_parse_error(query(R"({"like": {"frames": "1-5"}})"), "style.like.bvh");
  test::expect_parse_error(query(R"({"like": {"bvh": "x.bvh", "frames": "9-5"}})"),
                           "style.like.frames");
  const Query q = test::parse(query(R"({"like": {"bvh": "x.bvh", "frames": "5-9"}, "weight": 3})"));
  ASSERT_TRUE(q.style);
  EXPECT_EQ(q.style->like_first, 5u);
  EXPECT_EQ(q.style->like_last, 9u);
  EXPECT_FALSE(q.style->like_whole);
  EXPECT_EQ(q.style->weight, 3.0);
}

TEST(QueryStyle, NeedsAModelThatKnowsTheStyle) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  const auto error_of = [&](const std::string& text, const SearchOptions& o) -> std::string {
    try {
      const QueryOutcome out = engine.run(test::parse(text), o);
      return out.error ? *out.error : "";
    } catch (const InputError& e) {
      return e.what();
    }
  };
  SearchOptions o;
  EXPECT_NE(error_of(query(R"({"label": "old"})"), o).find("needs a style model"),
            std::string::npos);
  o.style_model = set1_model(index);
  EXPECT_NE(
      error_of(query(R"({"label": "ancient"})"), o).find("no style \"ancient\" (it has active,"),
      std::string::npos);
  EXPECT_NE(error_of(query(R"({"like": {"bvh": "/nonexistent.bvh"}})"), o).find("nonexistent.bvh"),
            std::string::npos);
  EXPECT_EQ(style_distance({0.0, 1.0}, {0.5, 0.5}), std::log(2.0));
  EXPECT_EQ(style_distance({0.0, 1.0, 0.0}, {}), std::log(3.0));
  EXPECT_EQ(style_distance({1.0, 0.0}, {1.0, 0.0}), 0.0);
}

TEST(QueryStyle, ExactEqualsBruteAndTheAskedStyleRanksFirst) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  SearchOptions exact, brute;
  exact.style_model = brute.style_model = set1_model(index);
  brute.mode = SearchMode::brute;
  const std::vector<std::vector<double>> probs =
      clip_style_probabilities(*exact.style_model, index);
  const auto& styles = exact.style_model->style.classes;
  const auto old =
      static_cast<std::size_t>(std::find(styles.begin(), styles.end(), "old") - styles.begin());
  for (const char* relative : {"true", "false"}) {
    const Query q = test::parse(query(R"({"label": "old", "weight": 20})", relative, 3));
    const QueryOutcome e = engine.run(q, exact);
    const QueryOutcome b = engine.run(q, brute);
    ASSERT_FALSE(e.error) << *e.error;
    test::expect_same_results(e, b, std::string("relative ") + relative, 0.0);
    for (const PairResults& pair : e.pairs)
      for (const SearchResult& r : pair.results) {
        EXPECT_TRUE(r.style);
        EXPECT_NEAR(r.style_J, 20.0 * -std::log(std::max(probs[r.clip_index][old], 1e-12)), 1e-9);
        EXPECT_NEAR(r.score_J, r.h_in_J + r.h_out_J + r.style_J, 1e-6 * (1.0 + r.score_J));
      }
  }
  // Asking for "old": set 1's old takes first; h alone ranks others first.
  const auto olds = [](const QueryOutcome& o) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < 3 && i < o.pairs[0].results.size(); ++i)
      for (const auto& [k, v] : o.pairs[0].results[i].labels) n += k == "style" && v == "old";
    return n;
  };
  const QueryOutcome asked =
      engine.run(test::parse(query(R"({"label": "old", "weight": 20})")), exact);
  const QueryOutcome plain = engine.run(test::parse(query("")), exact);
  EXPECT_EQ(olds(asked), 3u);
  EXPECT_LT(olds(plain), 3u);
  EXPECT_FALSE(plain.pairs[0].results[0].style);
  // Like a file: the old walk's own frames ask for what it is.
  const QueryOutcome like = engine.run(test::parse(query(R"({"like": {"bvh": ")" + old_walk() +
                                                         R"(", "frames": "0-80"}, "weight": 20})")),
                                       exact);
  ASSERT_FALSE(like.error) << *like.error;
  EXPECT_GE(olds(like), 2u);
}

TEST(QueryStyle, ResultsCarryTheirRecognisedStyle) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(set1_index().empty());
  const Index index = Index::open(set1_index());
  const SearchEngine engine(index);
  std::vector<QueryOutcome> out{engine.run(test::parse(query("")), SearchOptions{})};
  const std::shared_ptr<const StyleModel> model = set1_model(index);
  add_recognised_styles(*model, ClipSource(index), out);
  std::size_t own = 0;
  for (const SearchResult& r : out[0].pairs[0].results) {
    ASSERT_FALSE(r.recognised_style.empty());
    EXPECT_GT(r.recognised_style_p, 0.0);
    EXPECT_LE(r.recognised_style_p, 1.0);
    for (const auto& [k, v] : r.labels) own += k == "style" && v == r.recognised_style;
  }
  EXPECT_GE(own, 8u) << "the model learned these clips";
  EXPECT_THROW(read_style_model("/nonexistent/style.json"), InputError);
}

}  // namespace
