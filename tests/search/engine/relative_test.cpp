// Relative placements (docs/queries.md "Placement"): invalid queries first,
// then invariance of "relative": true under a turn and move of the query's
// clip (written as a BVH file), the body-frame meaning of hand-written
// offsets, "position" keeping headings absolute, and exact == brute on
// random held-out relative queries over set 1.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "mocap/common/body/ground_pose.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "search_fixtures.hpp"

namespace fs = std::filesystem;
using namespace mocap;
using test::parse;

namespace {

const fs::path& index_path() {
  return test::set1_index("search-relative-set1");
}

// The clip turned by `yaw_deg` about the vertical and moved by (dx, dz)
// (file units) on the ground: the ROOT joint's channels changed, everything
// below follows.
RawClip turned_clip(const RawClip& in, double yaw_deg, double dx, double dz) {
  RawClip out = in;
  const RawJoint& root = out.joints.at(0);
  const Eigen::Quaterniond turn(
      Eigen::AngleAxisd(yaw_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()));
  std::array<int, 3> pos{-1, -1, -1};
  std::array<std::uint8_t, 3> axes{};
  std::array<int, 3> rot{-1, -1, -1};
  int r = 0;
  for (std::size_t c = 0; c < root.channels.size(); ++c) {
    const int col = static_cast<int>(root.first_column + c);
    const int axis = channel_axis(root.channels[c]);
    if (channel_is_rotation(root.channels[c])) {
      axes[static_cast<std::size_t>(r)] = static_cast<std::uint8_t>(axis);
      rot[static_cast<std::size_t>(r++)] = col;
    } else {
      pos[static_cast<std::size_t>(axis)] = col;
    }
  }
  EXPECT_EQ(r, 3) << "the test turns a ROOT with three rotation channels";
  for (std::size_t f = 0; f < out.frame_count; ++f) {
    double* row = out.values.data() + f * out.channel_count;
    Eigen::Vector3d p(pos[0] >= 0 ? row[pos[0]] : 0.0, pos[1] >= 0 ? row[pos[1]] : 0.0,
                      pos[2] >= 0 ? row[pos[2]] : 0.0);
    p = turn * p + Eigen::Vector3d(dx, 0.0, dz);
    for (int a = 0; a < 3; ++a)
      if (pos[static_cast<std::size_t>(a)] >= 0) row[pos[static_cast<std::size_t>(a)]] = p[a];
    const double deg[3] = {row[rot[0]], row[rot[1]], row[rot[2]]};
    const Eigen::Quaterniond q = turn * euler_to_quaternion(axes, deg);
    const Eigen::Vector3d e = quaternion_to_euler(q, axes);
    for (int k = 0; k < 3; ++k) row[rot[static_cast<std::size_t>(k)]] = e[k];
  }
  return out;
}

std::string frame(const fs::path& bvh, std::size_t f, const std::string& extra = "") {
  return "{\"bvh\": \"" + bvh.string() + "\", \"frame\": " + std::to_string(f) + extra + "}";
}

}  // namespace

TEST(RelativeQuery, OneOfRootXAndZIsAnErrorWhenHeadingsAreFree) {
  const Index index = Index::open(test::golden_index());
  const SearchEngine engine(index);
  const Query q =
      parse(R"({"frames": [{"root_position": [0, null, 0]}, {"root_position": [1, null, null]}]})");
  EXPECT_THROW(
      {
        try {
          engine.run(q, SearchOptions{});
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("frames[1].root_position"), std::string::npos)
              << e.what();
          throw;
        }
      },
      InputError);
  // With "position" (no turn) one axis is fine.
  const Query p = parse(
      R"({"relative": "position", "frames": [{"root_position": [0, null, 0]}, {"root_position": [1, null, null]}]})");
  SearchOptions opt;
  opt.min_length_s = 0.05;
  EXPECT_FALSE(engine.run(p, opt).error);
}

TEST(RelativeQuery, TurnedAndMovedQueryClipGivesTheSameResults) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty()) << "could not build the set-1 index";
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const fs::path dir = test::temp_dir("search-relative-turned");
  const fs::path original = test::data_dir() / "bandai-namco-1/data/dataset-1_walk_normal_001.bvh";
  const RawClip clip = read_bvh_file(original);
  ASSERT_GT(clip.frame_count, 60u);
  const std::size_t f0 = clip.frame_count / 5, f1 = f0 + 30, f2 = f0 + 45;
  // Under the sanitizers (test_support.hpp) over the walks alone, one turn,
  // without the brute runs (exact == brute on relative queries runs there in
  // ExactEqualsBruteOnHeldOutQueriesSet1).
  const std::string clips = test::kSanitizerBuild ? "\"clips\": [\"*walk*\"], " : "";
  auto query = [&](const fs::path& bvh, const std::string& relative) {
    return parse("{\"id\": \"turned\", \"relative\": " + relative + ", \"frames\": [" +
                 frame(bvh, f0) + ", " + frame(bvh, f1) + ", " +
                 frame(bvh, f2, ", \"only\": [\"root_position_xz\", \"RightUpperArm\"]") +
                 "], \"filter\": {" + clips + "\"exclude\": [\"" + original.filename().string() +
                 "\"]}, \"top\": 5}");
  };
  SearchOptions opt;
  const QueryOutcome base = engine.run(query(original, "true"), opt);
  ASSERT_FALSE(base.error) << *base.error;
  ASSERT_EQ(base.pairs.size(), 2u);
  ASSERT_EQ(base.pairs[0].results.size(), 5u);
  const QueryOutcome base_position = engine.run(query(original, "\"position\""), opt);
  bool position_changed = false;
  const std::vector<double> yaws = test::kSanitizerBuild
                                       ? std::vector<double>{-137.5}
                                       : std::vector<double>{90.0, -137.5, 180.0, 23.0};
  for (const double yaw : yaws) {
    const fs::path turned = dir / ("turned_" + std::to_string(static_cast<int>(yaw)) + ".bvh");
    write_bvh_file(turned_clip(clip, yaw, 312.0, -871.0), turned);
    const std::string what = "turned by " + std::to_string(yaw) + " deg";
    // Scores to 5e-5 relative: the query is posed through float32 rows as the
    // index stores them, and 900 m from the origin a float32 position is
    // rounded to 6e-5 m, which the velocities' differences amplify.
    test::expect_same_results(base, engine.run(query(turned, "true"), opt), what, 5e-5);
    if (!test::kSanitizerBuild) {
      SearchOptions brute = opt;
      brute.mode = SearchMode::brute;
      test::expect_same_results(base, engine.run(query(turned, "true"), brute), what + " brute",
                                5e-5);
    }
    // "position" keeps headings absolute: a turned query scores otherwise.
    const QueryOutcome pos = engine.run(query(turned, "\"position\""), opt);
    ASSERT_FALSE(pos.error) << *pos.error;
    position_changed |=
        std::abs(pos.pairs[0].results[0].score_J - base_position.pairs[0].results[0].score_J) > 1.0;
  }
  EXPECT_TRUE(position_changed);
}

TEST(RelativeQuery, HandWrittenOffsetsAreInTheBodyFrame) {
  // A root path one metre forward (+z in the body frame) finds partial
  // motions whose root ends about one metre ahead of where it started,
  // whichever way their clip faces.
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty());
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const QueryOutcome r = engine.run(
      parse(
          R"({"frames": [{"root_position": [0, null, 0], "root_heading_deg": 0}, {"root_position": [0, null, 1.2], "root_heading_deg": 0}], "top": 5, "max_length_s": 2})"),
      SearchOptions{});
  ASSERT_FALSE(r.error) << *r.error;
  ASSERT_EQ(r.pairs[0].results.size(), 5u);
  for (const SearchResult& m : r.pairs[0].results) {
    const IndexClip& c = index.clips()[m.clip_index];
    const IndexArray& roots = index.array(c.skeleton, "frames", "root_position_m");
    const IndexArray& rotations = index.array(c.skeleton, "frames", "world_rotations");
    const std::size_t nj = index.skeletons()[c.skeleton].skeleton.joint_count();
    const int root = index.dynamics_model(c.skeleton).root();
    const std::size_t g0 = c.frame_start + m.start_frame, g1 = c.frame_start + m.end_frame;
    auto v3 = [&](std::size_t g) {
      return Eigen::Vector3d(roots.f32[g * 3], roots.f32[g * 3 + 1], roots.f32[g * 3 + 2]);
    };
    const float* q = rotations.f32.data() + (g0 * nj + static_cast<std::size_t>(root)) * 4;
    const GroundPose start =
        ground_pose_of(v3(g0), Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized());
    const Eigen::Vector3d moved = start.inverse().apply(v3(g1));
    EXPECT_NEAR(moved.z(), 1.2, 0.4) << m.clip << " " << m.start_frame << "-" << m.end_frame;
    EXPECT_NEAR(moved.x(), 0.0, 0.4) << m.clip << " " << m.start_frame << "-" << m.end_frame;
  }
}

TEST(RelativeQuery, HandWrittenPairIsMeasuredFromItsFirstFrame) {
  // A path 0 -> 1.2 m -> 2.4 m forward: its second pair is the first one
  // moved 1.2 m (the same offsets from the pair's first frame), so it ranks
  // the same partial motions with the same scores; and a pair turned by 90
  // degrees with its offset turned along gives them too.
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty());
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const QueryOutcome path = engine.run(
      parse(
          R"({"frames": [{"root_position": [0, null, 0], "root_heading_deg": 0}, {"root_position": [0, null, 1.2], "root_heading_deg": 0}, {"root_position": [0, null, 2.4], "root_heading_deg": 0}], "top": 5})"),
      SearchOptions{});
  const QueryOutcome turned = engine.run(
      parse(
          R"({"frames": [{"root_position": [3, null, -1], "root_heading_deg": 90}, {"root_position": [4.2, null, -1], "root_heading_deg": 90}], "top": 5})"),
      SearchOptions{});
  ASSERT_FALSE(path.error) << *path.error;
  ASSERT_EQ(path.pairs.size(), 2u);
  QueryOutcome first, second;
  first.pairs = {path.pairs[0]};
  second.pairs = {path.pairs[1]};
  test::expect_same_results(first, second, "second pair", 1e-9);
  test::expect_same_results(first, turned, "turned pair", 1e-5);
}

namespace {

// Held-out relative queries over set 1 ("relative": true; the query's clip
// excluded): 2 or 3 frames in time order from one clip, a window of up to
// 1.5 s; in turn full BVH frames (two in five), the root's ground position
// of BVH frames ("only") with an arm (every other one with the heading too) or alone (every other
// of those alone under "position"), a hand-written root path (every other one with headings; one in
// four of the others headings alone), and a hand-written first frame before BVH frames.
std::vector<Query> held_out_queries(const Index& index, std::size_t count) {
  std::mt19937 rng(2026);
  std::vector<Query> out;
  const auto& clips = index.clips();
  for (std::size_t i = 0; i < count; ++i) {
    const IndexClip& c = clips[rng() % clips.size()];
    const std::size_t nframes = 2 + (i % 3 == 2 ? 1 : 0);
    const auto span = static_cast<std::size_t>(1.5 / c.frame_time_s);
    const std::size_t first = rng() % c.frame_count;
    std::string frames;
    for (std::size_t f = 0; f < nframes; ++f) {
      const std::size_t fr = std::min<std::size_t>(c.frame_count - 1, first + f * (span / 2));
      const std::string bvh = "\"bvh\": \"" + c.path + "\", \"frame\": " + std::to_string(fr);
      std::string one;
      switch (i % 5) {
        case 0:
        case 1:
          one = "{" + bvh + "}";
          break;
        case 2:  // the root's ground position (and heading) with an arm, or alone (root bounds)
          one = "{" + bvh +
                (i % 20 == 12
                     ? ", \"only\": [\"root_position_xz\", \"root_heading\", \"LeftUpperArm\"]}"
                 : i % 10 == 2 ? ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]}"
                               : ", \"only\": [\"root_position_xz\"]}");
          break;
        case 3:  // a root path, every other one with headings (turning bounds), or headings alone
          if (i % 20 == 18)
            one = "{\"root_heading_deg\": " + std::to_string(static_cast<int>(rng() % 360) - 180) +
                  "}";
          else
            one = "{\"root_position\": [" + std::to_string(0.1 * (rng() % 5)) + ", null, " +
                  std::to_string(0.4 * f) + "]" +
                  (i % 10 == 3 ? ", \"root_heading_deg\": " + std::to_string(rng() % 120) : "") +
                  "}";
          break;
        default:
          one = f == 0 ? "{\"root_position\": [0, null, 0]}" : "{" + bvh + "}";
      }
      frames += (f ? ", " : "") + one;
    }
    const std::string name = fs::path(c.path).filename().string();
    out.push_back(
        parse("{\"id\": \"h" + std::to_string(i) + "\", \"frames\": [" + frames +
              "], \"filter\": {\"exclude\": [\"" + name + "\"]}, \"top\": " +
              std::to_string(1 + rng() % 10) + (i % 5 == 0 ? ", \"path_weight\": 0.01" : "") +
              (i % 20 == 17 || i % 40 == 13 ? ", \"relative\": \"position\"" : "") + "}"));
  }
  return out;
}

}  // namespace

TEST(RelativeQuery, ExactEqualsBruteOnHeldOutQueriesSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty());
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const char* v = std::getenv("MOCAP_SEARCH_TEST_QUERIES");
  const std::size_t count = v != nullptr && std::atoi(v) > 0 ? std::stoul(v) : 200;
  SearchOptions exact, brute;
  exact.max_length_s = brute.max_length_s = 0.4;
  brute.mode = SearchMode::brute;
  std::size_t pruned = 0;
  for (const Query& q : held_out_queries(index, count)) {
    ASSERT_NE(q.placement, FramePlacement::world);
    const QueryOutcome e = engine.run(q, exact);
    const QueryOutcome b = engine.run(q, brute);
    test::expect_same_results(e, b, q.id);
    EXPECT_EQ(b.stats.frames_pruned, 0u);
    EXPECT_LE(e.stats.frames_evaluated, b.stats.frames_evaluated) << q.id;
    pruned += e.stats.frames_pruned > 0;
  }
  EXPECT_GE(pruned, count / 2) << "exact mode should prune";
}

// Root frames get per-frame bounds in relative placements
// (relative_bounds.hpp): root-only frames; frames giving a heading and no
// joint rotations (the whole body turned about the vertical through its
// root, then moved); frames giving root position components and joint
// rotations, or a heading and joint rotations (the segments outside the
// given subtrees moved). Each never exceeds h, with the slack the engine
// compares with, on every frame of set 1: headings all round, with and
// without root positions and a given height, BVH frames with the root's
// ground position (and heading) and an arm, a hand-written heading or root
// position with a forearm, T = 0.25..1 s; and the turning bound recovers
// most of h.
TEST(RelativeQuery, RootBoundsNeverExceedHSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty());
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  std::mt19937 rng(404);
  const std::size_t count = test::kSanitizerBuild ? 6 : 18;
  double turn_lb = 0.0, turn_h = 0.0, joint_lb = 0.0, joint_h = 0.0;
  std::size_t checked = 0;
  const auto& clips = index.clips();
  for (std::size_t i = 0; i < count; ++i) {
    const int heading = static_cast<int>(rng() % 360) - 180;
    const double x = static_cast<double>(rng() % 600) / 100.0 - 3.0;
    const IndexClip& c = clips[rng() % clips.size()];
    const std::size_t fr = rng() % c.frame_count;
    const std::string h = "\"root_heading_deg\": " + std::to_string(heading);
    std::string f;
    switch (i % 6) {
      case 0:  // the heading alone
        f = "{" + h + "}";
        break;
      case 1:
        f = "{\"root_position\": [" + std::to_string(x) + ", null, -1.0], " + h + "}";
        break;
      case 2:
        f = "{\"root_position\": [" + std::to_string(x) + ", 0.9, 0.4], " + h + "}";
        break;
      case 3:  // a BVH frame's root ground position (and heading) and an arm
        f = "{\"bvh\": \"" + c.path + "\", \"frame\": " + std::to_string(fr) +
            (i % 12 == 3
                 ? ", \"only\": [\"root_position_xz\", \"LeftUpperArm\"]}"
                 : ", \"only\": [\"root_position_xz\", \"root_heading\", \"LeftUpperArm\"]}");
        break;
      case 4:  // a heading and a forearm
        f = "{" + h + ", \"joints\": {\"LeftForeArm\": {\"euler_deg\": [20, 40, 0], " +
            "\"order\": \"ZXY\"}}}";
        break;
      default:  // a root position and a forearm
        f = "{\"root_position\": [" + std::to_string(x) +
            ", 0.95, 0.2], \"joints\": {\"RightForeArm\": {\"euler_deg\": [" +
            std::to_string(heading) + ", 30, 0], \"order\": \"ZXY\"}}}";
    }
    const double t = i % 3 == 0 ? 0.25 : (i % 3 == 1 ? 0.5 : 1.0);
    const Query q = parse(
        "{\"relative\": false, \"frames\": [" + f +
        ", {\"root_position\": [0, null, 0]}], \"transition_time\": " + std::to_string(t) + "}");
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds bounds = engine.frame_bounds(q, 0, k);
      ASSERT_EQ(bounds.root_lower.size(), bounds.h.size());
      for (std::size_t g = 0; g < bounds.h.size(); ++g) {
        const double lb = bounds.root_lower[g], hv = bounds.h[g];
        ASSERT_TRUE(std::isfinite(lb) && std::isfinite(hv)) << f << " frame " << g;
        ASSERT_LE(lb * (1.0 - 1e-4) - 1e-3, hv) << f << " T " << t << " frame " << g;
        (i % 6 < 3 ? turn_lb : joint_lb) += lb;
        (i % 6 < 3 ? turn_h : joint_h) += hv;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100000u);
  EXPECT_GT(turn_lb, 0.9 * turn_h) << "the turning bound should recover most of h";
  EXPECT_GT(joint_lb, 0.0) << "the root-and-joints bound should not be the zero bound";
  std::printf("root bounds: turning %.3f, root and joints %.3f of h on average over %zu frames\n",
              turn_lb / turn_h, joint_lb / joint_h, checked);
}

// A placement-free second frame (body-frame constraints, joint rotations)
// after a full BVH frame: the relative scan evaluates its h once per end
// frame of a clip and reuses it for every start frame. Each result's h_out
// is that frame's h against F^e as the world scan computes it
// (FrameBounds::engine_h), and exact equals brute.
TEST(RelativeQuery, PlacementFreeSecondFrameIsEvaluatedOncePerEndFrameSet1) {
  MOCAP_REQUIRE_DATA();
  ASSERT_FALSE(index_path().empty());
  const Index index = Index::open(index_path());
  const SearchEngine engine(index);
  const std::string walk =
      (test::data_dir() / "bandai-namco-1/data/dataset-1_walk_normal_001.bvh").string();
  const std::string seconds[] = {
      R"({"effectors": {"RightHand": {"position_m": [-0.25, 1.29, 0.2], "tolerance_m": 0.05}}})",
      R"({"joints": {"RightForeArm": {"euler_deg": [0, 0, 60], "order": "ZXY"}}})",
  };
  const std::string filter =
      test::kSanitizerBuild
          ? R"("filter": {"clips": ["*_normal_*"], "exclude": ["*walk_normal_001*"]})"
          : R"("filter": {"exclude": ["*walk_normal_001*"]})";
  for (const std::string& second : seconds) {
    const std::string frames = "[" + frame(walk, 40) + ", " + second + "]";
    const Query q =
        parse(R"({"top": 5, "max_length_s": 1.5, "frames": )" + frames + ", " + filter + "}");
    SearchOptions exact, brute;
    brute.mode = SearchMode::brute;
    const QueryOutcome e = engine.run(q, exact);
    ASSERT_FALSE(e.error) << *e.error;
    ASSERT_EQ(e.pairs[0].results.size(), 5u) << second;
    test::expect_same_results(e, engine.run(q, brute), second, 0.0);
    const Query world = parse(R"({"relative": false, "frames": )" + frames + "}");
    for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
      const FrameBounds fb = engine.frame_bounds(world, 1, k);
      for (const SearchResult& r : e.pairs[0].results) {
        const IndexClip& c = index.clips()[r.clip_index];
        if (c.skeleton != k) continue;
        EXPECT_NEAR(r.h_out_J, fb.engine_h[c.frame_start + r.end_frame], 1e-9 * (1.0 + r.h_out_J))
            << second << " " << r.clip << " " << r.end_frame;
      }
    }
  }
}
