// Query frames from another rig (docs/queries.md "Across rigs"): on an index
// of Bandai Namco and CMU clips, a frame of the other rig is retargeted
// (retarget.hpp) and compared on the shared segments only; its own rig keeps
// the exact path. Checks: resolution and the segment mask, the engine's h
// against the double-precision reference summed over the compared segments,
// exact == brute for cross-rig queries, own frames still at h = 0, and the
// `energy` command giving the search's h across rigs.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/retarget.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/search/energy_command.hpp"
#include "mocap/search/query_pose.hpp"
#include "mocap/search/search.hpp"
#include "search_fixtures.hpp"

namespace fs = std::filesystem;
using namespace mocap;

namespace {

const char* const kBandaiNamco[] = {
    "dataset-1_walk_normal_001", "dataset-1_walk_giant_001",      "dataset-1_walk-left_normal_001",
    "dataset-1_walk_happy_001",  "dataset-1_run_normal_001",      "dataset-1_bow_active_001",
    "dataset-1_walk_proud_001",  "dataset-1_walk-right_giant_001"};
const char* const kCmu[] = {"131_01", "131_02", "131_03"};

fs::path bn_file(const std::string& name) {
  return test::data_dir() / "bandai-namco-1" / "data" / (name + ".bvh");
}
fs::path cmu_file(const std::string& name) {
  return test::data_dir() / "cmu" / (name + ".bvh");
}

// An index of the given files (links in a folder named by `tag`).
fs::path index_of(const std::string& tag, const std::vector<fs::path>& files) {
  const fs::path dir = test::temp_dir(tag);
  const fs::path clips = dir / "clips";
  fs::create_directories(clips);
  for (const fs::path& f : files) fs::create_symlink(f, clips / f.filename());
  return test::build_index_with_binary(clips, dir / "index.h5", {});
}

// A few Bandai Namco clips and the CMU ones, built once per run.
const fs::path& mixed_index() {
  static const fs::path path = [] {
    std::vector<fs::path> files;
    for (const char* n : kBandaiNamco) files.push_back(bn_file(n));
    for (const char* n : kCmu) files.push_back(cmu_file(n));
    return index_of("search-cross-rig", files);
  }();
  return path;
}

std::string bvh_frame(const fs::path& file, std::size_t f, const std::string& extra = "") {
  return "{\"bvh\": \"" + file.string() + "\", \"frame\": " + std::to_string(f) + extra + "}";
}

// The index skeleton of the clip whose file name starts with `stem`.
std::size_t skeleton_of(const Index& index, const std::string& stem) {
  for (const IndexClip& c : index.clips())
    if (fs::path(c.path).filename().string().rfind(stem, 0) == 0) return c.skeleton;
  ADD_FAILURE() << "no clip " << stem;
  return 0;
}

const IndexClip& clip_named(const Index& index, const std::string& stem) {
  for (const IndexClip& c : index.clips())
    if (fs::path(c.path).filename().string() == stem + ".bvh") return c;
  throw std::logic_error("no clip " + stem);
}

// The frames of a clip file as the indexer computes them (with `model`).
ClipDynamics clip_states(const fs::path& file, const DynamicsModel& model) {
  RawClip raw = read_bvh_file(file);
  normalise_up_axis(raw, std::nullopt);
  return compute_clip_dynamics(model, clip_motion_from_raw(raw, unit_scale_m(detect_unit(raw))));
}

double masked_sum(const EnergyTerms& t, const std::vector<std::uint8_t>& compared) {
  double s = 0.0;
  for (std::size_t j = 0; j < compared.size(); ++j)
    if (compared[j]) s += t.segment_J[j] + t.joint_J[j];
  return s;
}

TEST(CrossRig, ResolvedOnAnotherRigAndComparedOnSharedSegments) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(mixed_index().empty());
  const Index index = Index::open(mixed_index());
  const SearchEngine engine(index);
  // Set 1's clips have several skeletons (other Hips offsets): one of them.
  const std::size_t bn = skeleton_of(index, "dataset-1_walk_giant_001");
  const std::size_t cmu = skeleton_of(index, "131_01");
  ASSERT_NE(bn, cmu);
  struct Case {
    fs::path file;
    std::size_t frame;
    std::size_t onto;
    std::string clip;  // a clip of skeleton `onto` to check every frame of
  };
  for (const Case& c : {Case{cmu_file("131_01"), 600, bn, "dataset-1_walk_giant_001"},
                        Case{bn_file("dataset-1_walk_normal_001"), 100, cmu, "131_02"}}) {
    const Query q = test::parse("{\"relative\": false, \"frames\": [" + bvh_frame(c.file, c.frame) +
                                ", " + bvh_frame(c.file, c.frame + 10) + "]}");
    const IndexSkeleton& sk = index.skeletons()[c.onto];
    const DynamicsModel model = build_dynamics_model(sk.skeleton, sk.body);
    QueryBvhCache cache;
    cache.use_index(index);
    // The engine's typical pose: the index's frames of the skeleton.
    const std::vector<Eigen::Quaterniond> typical =
        typical_local_rotations(index, static_cast<std::uint32_t>(c.onto));
    const ResolvedQueryPose pose = resolve_query_pose(
        q, 0, sk, model, cache, index.info().unit_option, nullptr, [&] { return &typical; });
    ASSERT_TRUE(pose.cross_rig);
    ASSERT_TRUE(pose.full);
    ASSERT_EQ(pose.compared_joints.size(), sk.skeleton.joint_count());
    EXPECT_EQ(pose.compared_classes.size(), c.onto == bn ? 21u : 16u);
    // On its own rig: not retargeted, every segment compared.
    const std::size_t own = c.onto == bn ? cmu : bn;
    const DynamicsModel own_model =
        build_dynamics_model(index.skeletons()[own].skeleton, index.skeletons()[own].body);
    const ResolvedQueryPose same = resolve_query_pose(q, 0, index.skeletons()[own], own_model,
                                                      cache, index.info().unit_option);
    EXPECT_FALSE(same.cross_rig);
    EXPECT_TRUE(same.compared_joints.empty());
    // The engine's h of every frame of a clip of the other rig: the double
    // reference summed over the compared segments, to float precision.
    const FrameBounds bounds = engine.frame_bounds(q, 0, c.onto);
    const IndexClip& clip = clip_named(index, c.clip);
    ASSERT_EQ(clip.skeleton, c.onto);
    const ClipDynamics states = clip_states(clip.path, model);
    ASSERT_EQ(states.frame_count, clip.frame_count);
    std::size_t masked_differs = 0;
    for (std::size_t f = 0; f < clip.frame_count; ++f) {
      EnergyTerms terms;
      const double all = approximate_energy(model, pose.state.view(), states.state(f),
                                            q.transition_time_s, &terms);
      const double ref = masked_sum(terms, pose.compared_joints);
      const double h = bounds.h[clip.frame_start + f];
      ASSERT_NEAR(h, ref, 1e-4 * ref + 1e-3) << c.clip << " frame " << f;
      EXPECT_EQ(bounds.engine_h[clip.frame_start + f], h);
      EXPECT_LE(bounds.lower[clip.frame_start + f] * (1.0 - 1e-4) - 1e-3, h);
      masked_differs += all > ref * (1.0 + 1e-3) + 1e-3;
    }
    // Onto CMU the head, hands and toes are left out, and they cost something.
    if (c.onto == cmu) {
      EXPECT_GT(masked_differs, clip.frame_count / 2);
    }
  }
}

// Exact == brute (same clips, frames and scores) for cross-rig queries:
// relative (the default), "position" and world placements, three frames
// mixing the rigs, partial frames ("only") of another rig, held out or not.
TEST(CrossRig, ExactEqualsBrute) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(mixed_index().empty());
  const Index index = Index::open(mixed_index());
  const SearchEngine engine(index);
  const fs::path cmu = cmu_file("131_01"), bn = bn_file("dataset-1_walk_normal_001");
  const std::vector<std::string> queries = {
      "{\"frames\": [" + bvh_frame(cmu, 560) + ", " + bvh_frame(cmu, 620) +
          "], \"filter\": {\"exclude\": [\"131_01*\"]}, \"top\": 5}",
      "{\"relative\": false, \"frames\": [" + bvh_frame(cmu, 600) + ", " + bvh_frame(cmu, 660) +
          "], \"top\": 4}",
      "{\"relative\": \"position\", \"frames\": [" + bvh_frame(cmu, 500) + ", " +
          bvh_frame(cmu, 540) + "], \"top\": 3}",
      "{\"frames\": [" + bvh_frame(bn, 100) + ", " + bvh_frame(bn, 115) +
          "], \"filter\": {\"clips\": [\"131_*\"]}, \"top\": 3}",
      "{\"frames\": [" + bvh_frame(bn, 60) + ", " + bvh_frame(cmu, 600) + ", " + bvh_frame(bn, 90) +
          "], \"top\": 2}",
      "{\"frames\": [" +
          bvh_frame(cmu, 600, ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]") + ", " +
          bvh_frame(cmu, 640, ", \"only\": [\"RightUpLeg\", \"RightLeg\"]") + "]}",
  };
  SearchOptions exact, brute;
  exact.max_length_s = brute.max_length_s = 1.0;
  brute.mode = SearchMode::brute;
  for (const std::string& text : queries) {
    const Query q = test::parse(text);
    const QueryOutcome e = engine.run(q, exact);
    const QueryOutcome b = engine.run(q, brute);
    test::expect_same_results(e, b, text, 0.0);
    EXPECT_EQ(b.stats.frames_pruned, 0u);
    for (const auto& p : e.pairs) EXPECT_FALSE(p.results.empty()) << text;
  }
}

// The same rig keeps today's exact path: a clip's own frames at h = 0, on
// both rigs of the index; a CMU walk finds Bandai Namco walks when its own
// rig is filtered out.
TEST(CrossRig, OwnRigUnchangedAndWalksFindWalks) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(mixed_index().empty());
  const Index index = Index::open(mixed_index());
  const SearchEngine engine(index);
  for (const auto& [file, f, g] : {std::tuple{cmu_file("131_01"), 600, 660},
                                   std::tuple{bn_file("dataset-1_walk_normal_001"), 100, 115}}) {
    const Query q = test::parse("{\"relative\": false, \"frames\": [" + bvh_frame(file, f) + ", " +
                                bvh_frame(file, g) + "], \"top\": 1}");
    const QueryOutcome o = engine.run(q, SearchOptions{});
    ASSERT_FALSE(o.error);
    const auto& best = o.pairs.at(0).results.at(0);
    EXPECT_EQ(fs::path(index.clips()[best.clip_index].path).filename(), file.filename());
    EXPECT_EQ(best.start_frame, static_cast<std::size_t>(f));
    EXPECT_EQ(best.end_frame, static_cast<std::size_t>(g));
    EXPECT_EQ(best.score_J, 0.0);
  }
  const Query walk = test::parse("{\"frames\": [" + bvh_frame(cmu_file("131_01"), 600) + ", " +
                                 bvh_frame(cmu_file("131_01"), 660) +
                                 "], \"filter\": {\"clips\": [\"dataset-1_*\"]}, \"top\": 3}");
  const QueryOutcome o = engine.run(walk, SearchOptions{});
  ASSERT_FALSE(o.error);
  ASSERT_EQ(o.pairs.at(0).results.size(), 3u);
  for (const auto& r : o.pairs[0].results) {
    const std::string name = fs::path(index.clips()[r.clip_index].path).filename().string();
    EXPECT_EQ(name.rfind("dataset-1_walk", 0), 0u) << name;
    // Tens of joules: the pose copied joint by joint across the rigs' rest
    // poses cost 350 J.
    EXPECT_LT(r.score_J, 100.0) << name;
  }
}

// `mocap-search energy` compares across rigs as the search does: the
// database frame as --from, the query frame of the other rig as --to gives
// the search's h of that pair (world placement), to float precision. (The
// typical pose is the --from clip's frames there, the index's frames of the
// skeleton here: an index of that one Bandai Namco clip makes them equal.)
TEST(CrossRig, EnergyCommandGivesTheSearchsH) {
  MOCAP_REQUIRE_DATA();
  const fs::path path = index_of("search-cross-rig-energy",
                                 {bn_file("dataset-1_walk_giant_001"), cmu_file("131_01")});
  ASSERT_FALSE(path.empty());
  const Index index = Index::open(path);
  const SearchEngine engine(index);
  const fs::path cmu = cmu_file("131_01");
  const Query q = test::parse("{\"relative\": false, \"frames\": [" + bvh_frame(cmu, 600) + ", " +
                              bvh_frame(cmu, 660) +
                              "], \"filter\": {\"clips\": [\"dataset-1_*\"]}, \"top\": 3}");
  const QueryOutcome o = engine.run(q, SearchOptions{});
  ASSERT_FALSE(o.error);
  ASSERT_FALSE(o.pairs.at(0).results.empty());
  for (const auto& r : o.pairs[0].results) {
    EnergyCommandOptions e;
    e.from = {index.clips()[r.clip_index].path, r.start_frame};
    e.to = {cmu, 600};
    const EnergyReport in = run_energy_command(e);
    EXPECT_TRUE(in.cross_rig);
    EXPECT_NEAR(in.h_J, r.h_in_J, 1e-4 * r.h_in_J + 1e-3);
    e.from = {index.clips()[r.clip_index].path, r.end_frame};
    e.to = {cmu, 660};
    EXPECT_NEAR(run_energy_command(e).h_J, r.h_out_J, 1e-4 * r.h_out_J + 1e-3);
  }
}

}  // namespace

// A joint name that is a joint of a rig in the index, or of the query's own
// BVH file, but is read as another body part there gets a warning naming
// both parts and the name to write (CMU 131's 3ds-max "LeftShoulder" is an
// upper arm; the name means the clavicle on every rig). Names meaning what
// they name, and body-part names no rig carries, get none.
TEST(CrossRig, NamesReadAsAnotherBodyPartAreWarned) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(mixed_index().empty());
  const Index index = Index::open(mixed_index());
  const SearchEngine engine(index);
  auto warnings_of = [&](const std::string& text) {
    const QueryOutcome o = engine.run(test::parse(text), SearchOptions{});
    EXPECT_FALSE(o.error) << text;
    return o.warnings;
  };
  const std::string up = R"({"root_position": [0, null, 0]})";
  for (const char* name : {"LeftUpperArm", "LeftArm", "RightForeArm", "LeftCollar"})
    EXPECT_TRUE(warnings_of(R"({"top": 1, "frames": [)" + up + R"(, {"joints": {")" + name +
                            R"(": {"direction": [0, 1, 0]}}}]})")
                    .empty())
        << name;
  const auto w = warnings_of(R"({"top": 1, "frames": [)" + up +
                             R"(, {"joints": {"LeftShoulder": {"direction": [0, 1, 0]}}}]})");
  ASSERT_FALSE(w.empty());  // one per CMU skeleton of the index
  for (const char* part :
       {"frames[1].joints.LeftShoulder: read as the left clavicle", "joint \"LeftCollar\"",
        "is its left upper arm", "131_0", "write \"LeftUpperArm\""})
    EXPECT_NE(w[0].find(part), std::string::npos) << part << " in: " << w[0];
  // `only` names are read on the frame's own file.
  const auto only = warnings_of(
      R"({"top": 1, "frames": [)" +
      bvh_frame(cmu_file("131_01"), 600, R"(, "only": ["root_position_xz", "LeftShoulder"])") +
      ", " + bvh_frame(cmu_file("131_01"), 620) + "]}");
  ASSERT_EQ(only.size(), 1u);
  EXPECT_NE(only[0].find("frames[0].only[1]: read as the left clavicle"), std::string::npos)
      << only[0];
  EXPECT_NE(only[0].find("131_01.bvh's joint \"LeftShoulder\""), std::string::npos) << only[0];
}
