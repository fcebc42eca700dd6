// Tests for search/src/query/query_validation.cpp: label values of filters
// against an index and a collection, `only` names against the file's own
// skeleton, and the order of the checks (an unknown joint before its missing
// order). Invalid queries first, then that valid ones still run.
#include "mocap/search/query_validation.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/collection_search.hpp"
#include "mocap/search/query_pose.hpp"
#include "mocap/search/search.hpp"
#include "search_fixtures.hpp"

namespace mocap {
namespace {

using test::golden_index;
using test::parse;

const char* kTwoRoots = R"([{"root_position": [0, null, 0]}, {"root_position": [0.1, null, 0]}])";

Query with_filter(const std::string& filter) {
  return parse(std::string(R"({"frames": )") + kTwoRoots + R"(, "filter": )" + filter + "}");
}

// The message of the InputError that `f` throws ("" and a failure when none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const LabelValues kLabels = {{"content", {"run", "walk"}}, {"style", {"angry", "happy", "sad"}}};

TEST(FilterLabels, UnknownValuesListTheValuesHeld) {
  EXPECT_EQ(error_of([] { check_filter_labels(with_filter(R"({"style": "happpy"})"), kLabels); }),
            "query q: filter.style: unknown value \"happpy\"; the index has: angry, happy, sad");
  // The first unknown value of a list, content before style.
  EXPECT_EQ(error_of([] {
              check_filter_labels(
                  with_filter(R"({"style": ["x"], "content": ["walk", "wlak", "rnu"]})"), kLabels,
                  "the collection");
            }),
            "query q: filter.content: unknown value \"wlak\"; the collection has: run, walk");
  // A key no clip carries a value for.
  EXPECT_EQ(error_of([] {
              check_filter_labels(with_filter(R"({"content": ["walk"]})"),
                                  LabelValues{{"style", {"happy"}}});
            }),
            "query q: filter.content: unknown value \"walk\"; the index has no content labels");
  // Case matters (labels are exact).
  EXPECT_TRUE(
      has(error_of([] { check_filter_labels(with_filter(R"({"content": ["Walk"]})"), kLabels); }),
          "unknown value \"Walk\""));
}

TEST(FilterLabels, KnownValuesAndGlobsPass) {
  EXPECT_NO_THROW(check_filter_labels(with_filter(R"({"content": ["walk", "run"]})"), kLabels));
  EXPECT_NO_THROW(
      check_filter_labels(with_filter(R"({"style": "sad", "content": "run"})"), kLabels));
  // Globs are patterns: one matching no file is a valid, empty filter.
  EXPECT_NO_THROW(check_filter_labels(with_filter(R"({"clips": ["*nothing*"], "exclude": ["*"]})"),
                                      LabelValues{}));
  EXPECT_NO_THROW(
      check_filter_labels(parse(std::string(R"({"frames": )") + kTwoRoots + "}"), LabelValues{}));
}

// label_values against the index's own label() of every clip.
TEST(FilterLabels, LabelValuesOfAnIndex) {
  const Index index = Index::open(golden_index());
  LabelValues expected;
  for (std::size_t c = 0; c < index.clips().size(); ++c)
    for (const std::string& key : index.label_keys())
      if (const std::string v = index.label(c, key); !v.empty()) expected[key].insert(v);
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(label_values(index), expected);
  LabelValues twice = label_values(index);
  add_label_values(twice, index);
  EXPECT_EQ(twice, expected);
}

TEST(FilterLabels, TheEngineChecksItsIndexsValues) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  SearchOptions opt;
  opt.min_length_s = 0.05;  // the golden clips are 3 frames of 0.05 s
  const LabelValues held = label_values(index);
  const std::string content = *held.at("content").begin();
  std::string list;
  for (const std::string& v : held.at("content")) list += (list.empty() ? "" : ", ") + v;
  const std::string m =
      error_of([&] { engine.run(with_filter(R"({"content": ["nosuchcontent"]})"), opt); });
  EXPECT_EQ(m, "query q: filter.content: unknown value \"nosuchcontent\"; the index has: " + list);
  // A known value runs, and keeps only its clips.
  const QueryOutcome o = engine.run(with_filter(R"({"content": [")" + content + R"("]})"), opt);
  ASSERT_FALSE(o.error);
  ASSERT_FALSE(o.pairs[0].results.empty());
  for (const SearchResult& r : o.pairs[0].results)
    EXPECT_EQ(index.label(r.clip_index, "content"), content);
  // run_query_batch: the failing query gets its error line, the batch goes on.
  std::vector<BatchEntry> batch;
  for (const std::string f : {R"({"style": ["happpy"]})", R"({"clips": ["*"]})"}) {
    Query q = with_filter(f);
    batch.push_back({q.id, q, ""});
  }
  const std::vector<QueryOutcome> out = run_query_batch(engine, batch, opt);
  ASSERT_EQ(out.size(), 2u);
  ASSERT_TRUE(out[0].error);
  EXPECT_TRUE(has(*out[0].error, "filter.style: unknown value \"happpy\"")) << *out[0].error;
  EXPECT_FALSE(out[1].error);
}

// Two one-clip shards with different labels: a shard's engine checks the
// collection's values, so a label that only the other shard holds is valid.
TEST(FilterLabels, ACollectionChecksTheUnionOfItsShards) {
  const std::filesystem::path dir = test::temp_dir("query_validation_shards");
  const std::filesystem::path src = std::filesystem::path(MOCAP_SOURCE_DIR) / "tests/data/index";
  std::vector<ShardSource> shards;
  std::size_t offset = 0;
  for (const char* stem : {"golden_jump_happy_002", "golden_walk_normal_001"}) {
    const std::filesystem::path in = dir / stem;
    std::filesystem::create_directories(in);
    for (const char* ext : {".bvh", ".json"})
      if (std::filesystem::exists(src / (std::string(stem) + ext)))
        std::filesystem::copy_file(src / (std::string(stem) + ext), in / (std::string(stem) + ext),
                                   std::filesystem::copy_options::overwrite_existing);
    const std::filesystem::path out =
        test::build_index_with_binary(in, dir / (std::string(stem) + ".h5"), {});
    if (out.empty()) GTEST_SKIP() << "mocap-index not built";
    const std::size_t clips = Index::open(out).clips().size();
    shards.push_back({out, stem, clips, offset});
    offset += clips;
  }
  const LabelValues a = label_values(Index::open(shards[0].file));
  const LabelValues b = label_values(Index::open(shards[1].file));
  LabelValues both = a;
  for (const auto& [key, values] : b) both[key].insert(values.begin(), values.end());
  EXPECT_EQ(shard_label_values(shards), both);
  // The shards hold different contents (file names: jump, walk).
  ASSERT_NE(a.at("content"), b.at("content"));
  const std::string only_b = *b.at("content").begin();
  ASSERT_FALSE(a.at("content").count(only_b));

  SearchOptions opt;
  opt.min_length_s = 0.05;
  const Query q = with_filter(R"({"content": [")" + only_b + R"("]})");
  const Query typo = with_filter(R"({"content": ["nosuchcontent"]})");
  const std::vector<BatchEntry> batch = {{"known", q, ""}, {"typo", typo, ""}};
  // Shard a's own engine refuses b's label; as a shard of the collection it does not.
  const Index first = Index::open(shards[0].file);
  EXPECT_TRUE(has(error_of([&] { SearchEngine(first).run(q, opt); }), "the index has:"));
  EXPECT_FALSE(SearchEngine(first, both).run(q, opt).error);
  const std::vector<QueryOutcome> out = search_shards(shards, batch, opt);
  ASSERT_EQ(out.size(), 2u);
  ASSERT_FALSE(out[0].error) << *out[0].error;
  ASSERT_FALSE(out[0].pairs[0].results.empty());
  for (const SearchResult& r : out[0].pairs[0].results)
    EXPECT_GE(r.clip_index, shards[1].clip_offset);
  ASSERT_TRUE(out[1].error);
  std::string list;
  for (const std::string& v : both.at("content")) list += (list.empty() ? "" : ", ") + v;
  EXPECT_EQ(
      *out[1].error,
      "query q: filter.content: unknown value \"nosuchcontent\"; the collection has: " + list);
  // Labels given for the whole collection (another rank's shards) are used.
  ShardHooks hooks;
  const LabelValues more = {{"content", {"nosuchcontent"}}};
  hooks.labels = &more;
  const std::vector<QueryOutcome> given = search_shards(shards, batch, opt, hooks);
  ASSERT_TRUE(given[0].error);  // only_b is not among the given values
  EXPECT_FALSE(given[1].error);
}

// `only` names are read on the file's skeleton: a CMU file on the golden
// (Bandai Namco-like) index lists the CMU joints and the root fields.
TEST(OnlyNames, UnknownNamesListTheFilesJointsAndTheRootFields) {
  MOCAP_REQUIRE_DATA();
  const std::filesystem::path cmu = test::data_dir() / "cmu/131_01.bvh";
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  SearchOptions opt;
  opt.min_length_s = 0.05;
  auto only = [&](const std::string& file, const std::string& names, int frame = 30) {
    return parse(R"({"frames": [{"bvh": ")" + file + R"(", "frame": )" + std::to_string(frame) +
                 R"(, "only": )" + names + R"(}, {"root_position": [0, null, 0]}]})");
  };
  const std::string m =
      error_of([&] { engine.run(only(cmu.string(), R"(["root_heading", "Tail"])"), opt); });
  EXPECT_TRUE(has(m, "query q: frames[0].only[1]: unknown name \"Tail\"")) << m;
  EXPECT_TRUE(has(m, cmu.string())) << m;
  for (const char* listed : {"root_position, root_position_xz, root_heading", "LHipJoint",
                             "lowerback", "LeftKnee", "RThumb"})
    EXPECT_TRUE(has(m, listed)) << listed << " missing in: " << m;
  // The index skeleton's joints are not the file's.
  EXPECT_FALSE(has(m, "Spine")) << m;
  EXPECT_FALSE(has(m, "LeftUpLeg")) << m;
  // A joint of the file that the index skeleton (legs, no arms) lacks.
  const std::string arm =
      error_of([&] { engine.run(only(cmu.string(), R"(["LeftElbow"])"), opt); });
  EXPECT_TRUE(has(arm, "frames[0].only[0]: joint \"LeftElbow\"")) << arm;
  EXPECT_TRUE(has(arm, "no counterpart on the index skeleton (joints: Hips, Spine")) << arm;
  // The golden file's own names on its own skeleton.
  const std::string own =
      (std::filesystem::path(MOCAP_SOURCE_DIR) / "tests/data/index/golden_walk_normal_001.bvh")
          .string();
  const std::string g = error_of([&] { engine.run(only(own, R"(["LThumb"])", 1), opt); });
  EXPECT_TRUE(has(g, "unknown name \"LThumb\"")) << g;
  EXPECT_TRUE(has(g, "root_heading, Hips, Spine, Neck")) << g;
}

TEST(OnlyNames, FileNamesAndAliasesMeanTheSameJoint) {
  MOCAP_REQUIRE_DATA();
  const std::string cmu = (test::data_dir() / "cmu/131_01.bvh").string();
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  SearchOptions opt;
  opt.min_length_s = 0.05;
  auto run = [&](const std::string& names) {
    return engine.run(parse(R"({"frames": [{"bvh": ")" + cmu + R"(", "frame": 30, "only": )" +
                            names + R"(}, {"root_position": [0, null, 0]}]})"),
                      opt);
  };
  // CMU's own name (LeftHip), the index's (LeftUpLeg) and a canonical one
  // (LeftThigh) all read the CMU thigh.
  const QueryOutcome file_name = run(R"(["LeftHip", "LeftKnee", "root_position_xz"])");
  ASSERT_FALSE(file_name.error) << *file_name.error;
  ASSERT_FALSE(file_name.pairs[0].results.empty());
  test::expect_same_results(file_name, run(R"(["LeftUpLeg", "LeftLeg", "root_position_xz"])"),
                            "index names");
  test::expect_same_results(file_name, run(R"(["LeftThigh", "LeftShin", "root_position_xz"])"),
                            "canonical names");
}

// `only` names are read on the file's skeleton, and keep the rotation the
// whole frame gives the joint they mean on the index skeleton: copied on the
// same rig, retargeted across rigs (a Bandai Namco frame on a CMU skeleton).
TEST(OnlyNames, OnlyKeepsTheWholeFramesRotations) {
  MOCAP_REQUIRE_DATA();
  const std::filesystem::path dir = test::temp_dir("query_validation_cmu");
  std::filesystem::create_directories(dir / "cmu");
  std::filesystem::copy_file(test::data_dir() / "cmu/131_01.bvh", dir / "cmu/131_01.bvh");
  const std::filesystem::path out = test::build_index_with_binary(dir / "cmu", dir / "cmu.h5", {});
  if (out.empty()) GTEST_SKIP() << "mocap-index not built";
  const Index index = Index::open(out);
  const IndexSkeleton& sk = index.skeletons().front();
  const DynamicsModel model = index.dynamics_model(0);
  QueryBvhCache cache;
  auto frame = [&](const std::filesystem::path& file, const std::string& only) {
    return parse(R"({"frames": [{"bvh": ")" + file.string() + R"(", "frame": 30)" + only +
                 R"(}, {"root_position": [0, null, 0]}]})");
  };
  const std::filesystem::path bn =
      test::data_dir() / "bandai-namco-1/data/dataset-1_byebye_normal_001.bvh";
  const std::filesystem::path cmu = test::data_dir() / "cmu/131_02.bvh";
  const std::pair<std::filesystem::path, const char*> cases[] = {
      {bn, "UpperArm_R"},     {bn, "LowerArm_R"}, {bn, "UpperLeg_L"}, {bn, "RightForeArm"},
      {cmu, "RightShoulder"}, {cmu, "LeftHip"},   {cmu, "LeftThigh"}, {cmu, "lowerback"}};
  for (const auto& [file, name] : cases) {
    const ResolvedQueryPose whole = resolve_query_pose(frame(file, ""), 0, sk, model, cache);
    const ResolvedQueryPose only = resolve_query_pose(
        frame(file, std::string(R"(, "only": [")") + name + R"("])"), 0, sk, model, cache);
    ASSERT_EQ(only.given.joint_rotations.size(), 1u) << name;
    const int j = only.given.joint_rotations[0].first;
    EXPECT_EQ(j, find_joint_by_alias(sk.skeleton, name)) << name;
    EXPECT_TRUE(only.given.joint_rotations[0].second.isApprox(
        whole.local_rotations[static_cast<std::size_t>(j)], 0.0))
        << file << " " << name;
  }
  // A name of the index's rig that the file's skeleton lacks is refused.
  const std::string m = error_of(
      [&] { resolve_query_pose(frame(bn, R"(, "only": ["LThumb"])"), 0, sk, model, cache); });
  EXPECT_TRUE(has(m, "unknown name \"LThumb\"")) << m;
  EXPECT_TRUE(has(m, "joint_Root, Hips, Spine")) << m;
}

// An unknown joint is reported as unknown, whatever is wrong with its value;
// a known joint's invalid value is reported with the query file and line.
TEST(CheckOrder, UnknownJointBeforeItsMissingOrder) {
  const Index index = Index::open(golden_index());
  const SearchEngine engine(index);
  SearchOptions opt;
  opt.min_length_s = 0.05;
  auto joints = [](const std::string& j) {
    return parse_query_text(
        R"({"frames": [{"joints": )" + j + R"(}, {"root_position": [0, null, 0]}]})", "q.jsonl", 4,
        std::filesystem::path(MOCAP_SOURCE_DIR), "q");
  };
  const std::string unknown =
      error_of([&] { engine.run(joints(R"({"RightUpLegg": {"euler_deg": [0, 40, 0]}})"), opt); });
  EXPECT_TRUE(has(unknown, "query q: frames[0].joints.RightUpLegg: unknown joint")) << unknown;
  EXPECT_TRUE(has(unknown, "did you mean \"RightUpLeg\"?")) << unknown;
  EXPECT_FALSE(has(unknown, "order")) << unknown;
  // Also when the unknown joint comes after the invalid value.
  const std::string second = error_of([&] {
    engine.run(
        joints(R"({"RightUpLeg": {"euler_deg": [0, 40, 0]}, "Tail": {"quat": [1, 0, 0, 0]}})"),
        opt);
  });
  EXPECT_TRUE(has(second, "joints.Tail: unknown joint")) << second;
  EXPECT_FALSE(has(second, "did you mean")) << second;  // nothing within 2 edits
  // A misspelt direction joint, or effector, of the frame comes first too.
  const std::string direction = error_of([&] {
    engine.run(
        joints(
            R"({"RightUpLeg": {"euler_deg": [0, 40, 0]}, "LeftUpLegg": {"direction": [0, -1, 0]}})"),
        opt);
  });
  EXPECT_TRUE(has(direction, "joints.LeftUpLegg: unknown joint")) << direction;
  const std::string effector = error_of([&] {
    engine.run(parse_query_text(
                   R"({"frames": [{"joints": {"RightUpLeg": {"euler_deg": [0, 40, 0]}},
                                   "effectors": {"LeftFooot": {"position_m": [0.1, 0.1, 0]}}},
                                  {"root_position": [0, null, 0]}]})",
                   "q.jsonl", 4, std::filesystem::path(MOCAP_SOURCE_DIR), "q"),
               opt);
  });
  EXPECT_TRUE(has(effector, "effectors.LeftFooot: unknown joint")) << effector;
  EXPECT_TRUE(has(effector, "did you mean \"LeftFoot\"?")) << effector;
  const std::string order =
      error_of([&] { engine.run(joints(R"({"RightUpLeg": {"euler_deg": [0, 40, 0]}})"), opt); });
  EXPECT_TRUE(has(order, "q.jsonl:4: frames[0].joints.RightUpLeg.order: expected a string"))
      << order;
  // resolve_query_pose (what synthesis reads query frames through) checks alike.
  QueryBvhCache cache;
  const IndexSkeleton& sk = index.skeletons().front();
  const DynamicsModel model = index.dynamics_model(0);
  EXPECT_TRUE(has(error_of([&] {
                    resolve_query_pose(joints(R"({"RightUpLegg": {"euler_deg": [0, 40, 0]}})"), 0,
                                       sk, model, cache);
                  }),
                  "unknown joint"));
  EXPECT_TRUE(has(error_of([&] {
                    resolve_query_pose(joints(R"({"RightUpLeg": {"euler_deg": [0, 40, 0]}})"), 0,
                                       sk, model, cache);
                  }),
                  "RightUpLeg.order"));
  // Valid values run.
  const QueryOutcome ok =
      engine.run(joints(R"({"RightUpLeg": {"euler_deg": [0, 40, 0], "order": "ZXY"}})"), opt);
  EXPECT_FALSE(ok.error);
}

}  // namespace
}  // namespace mocap
