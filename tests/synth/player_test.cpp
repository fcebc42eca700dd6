// Tests for the 3D player (common/player/src), its scenes of a synthesis
// (synth/src/player_scene.cpp) and of search results (search/src
// results_page.cpp, results_file.cpp):
// refusals first (a player folder without three.js, no scene, bad results
// lines), then the motions' BVH read back by our reader against the
// synthesis's own forward kinematics, the foot states against a slow
// per-frame reference on those positions, and the page's inlined modules
// inflated back to the files they came from.
#include "mocap/player/player.hpp"
#include "mocap/search/results_file.hpp"
#include "mocap/search/results_page.hpp"
#include "mocap/synth/player_scene.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"
#include "synth_fixtures.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

void write_file(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// A player folder with small stand-ins for the three.js files.
fs::path fake_player_dir(const std::string& tag) {
  const fs::path d = test::temp_dir(tag);
  write_file(d / "node_modules/three/package.json", R"({"name": "three", "version": "9.9.9"})");
  write_file(d / "node_modules/three/build/three.core.js", "export const core = 1;\n");
  write_file(d / "node_modules/three/build/three.module.js",
             "import { core } from './three.core.js';\nexport { core };\n");
  write_file(d / "node_modules/three/examples/jsm/loaders/BVHLoader.js",
             "import { core } from 'three';\nexport class BVHLoader {}\n");
  write_file(d / "node_modules/three/examples/jsm/controls/OrbitControls.js",
             "import { core } from 'three';\nexport class OrbitControls {}\n");
  write_file(d / "player.js", "import * as THREE from 'three';\nexport function start() {}\n");
  write_file(d / "player.css", ".mocap-player { color: red; }\n");
  return d;
}

std::string base64_decode(const std::string& s) {
  static const std::string abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned acc = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    const auto v = abc.find(c);
    if (v == std::string::npos) ADD_FAILURE() << "not base64: " << c;
    acc = (acc << 6) | static_cast<unsigned>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xff);
    }
  }
  return out;
}

std::string gunzip(const std::string& gz) {
  z_stream z{};
  EXPECT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  std::string out(1 << 20, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(gz.data()));
  z.avail_in = static_cast<uInt>(gz.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  inflateEnd(&z);
  return out;
}

// The text of the <script ... id="ID"> element of a page.
std::string script_text(const std::string& page, const std::string& id) {
  const auto at = page.find("id=\"" + id + "\">");
  if (at == std::string::npos) {
    ADD_FAILURE() << "no script " << id;
    return "";
  }
  const auto start = page.find('>', at) + 1;
  return page.substr(start, page.find("</script>", start) - start);
}

PlayerScene tiny_scene() {
  PlayerScene s;
  s.id = "q</script><b>";
  s.title = "t";
  s.duration_s = 1.0;
  PlayerMotion m;
  m.id = "m";
  m.label = "a <label> & \"quotes\"";
  m.bvh = "HIERARCHY\n";
  s.motions.push_back(m);
  return s;
}

TEST(Player, RefusesAFolderWithoutThree) {
  const fs::path empty = test::temp_dir("player-empty");
  try {
    (void)load_player_library(empty);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node_modules/three/package.json"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("scripts/setup"), std::string::npos) << e.what();
  }
  const fs::path d = fake_player_dir("player-no-css");
  fs::remove(d / "player.css");
  EXPECT_THROW((void)load_player_library(d), InputError);
}

TEST(Player, RefusesNoScene) {
  const PlayerLibrary lib = load_player_library(fake_player_dir("player-lib"));
  EXPECT_THROW((void)player_html({}, lib), std::invalid_argument);
}

TEST(Player, DirectoryFromEnvironment) {
  ASSERT_EQ(setenv("MOCAP_PLAYER_DIR", "/some/where", 1), 0);
  EXPECT_EQ(player_dir(), fs::path("/some/where"));
  ASSERT_EQ(setenv("MOCAP_PLAYER_DIR", "", 1), 0);  // empty: the build's folder
  EXPECT_TRUE(player_dir().string().ends_with("common/player/web")) << player_dir();
  ASSERT_EQ(unsetenv("MOCAP_PLAYER_DIR"), 0);
}

TEST(Player, PageInlinesTheModulesAndEscapesTheData) {
  const fs::path dir = fake_player_dir("player-page");
  const PlayerLibrary lib = load_player_library(dir);
  EXPECT_EQ(lib.three_version, "9.9.9");
  const std::string page = player_page("T", {tiny_scene()}, lib);
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.find("data-figure=\"player\""), std::string::npos);
  const std::pair<const char*, const char*> modules[] = {
      {"mp-three-core", "node_modules/three/build/three.core.js"},
      {"mp-three-module", "node_modules/three/build/three.module.js"},
      {"mp-bvh-loader", "node_modules/three/examples/jsm/loaders/BVHLoader.js"},
      {"mp-orbit-controls", "node_modules/three/examples/jsm/controls/OrbitControls.js"},
      {"mp-app", "player.js"}};
  for (const auto& [id, file] : modules) {
    std::ifstream in(dir / file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    const std::string want = text.str();
    EXPECT_EQ(gunzip(base64_decode(script_text(page, id))), want) << id;
  }
  // The data: one script element, '<' escaped, the same values parsed back.
  const std::string data = script_text(page, "mp-data");
  EXPECT_EQ(data.find('<'), std::string::npos);
  const auto j = nlohmann::json::parse(data);
  EXPECT_EQ(j["three_version"], "9.9.9");
  EXPECT_EQ(j["scenes"][0]["id"], "q</script><b>");
  EXPECT_EQ(j["scenes"][0]["motions"][0]["label"], "a <label> & \"quotes\"");
  EXPECT_EQ(page.find("<b>"), std::string::npos);
  // No external reference: the page works offline.
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);
  EXPECT_EQ(page.find("href=\"http"), std::string::npos);
}

TEST(Player, ResultsFileErrorsNameTheLine) {
  MOCAP_REQUIRE_DATA();
  const Index* index = test::built_index({"cmu"});
  ASSERT_NE(index, nullptr);
  const ClipSource clips(*index);
  const fs::path d = test::temp_dir("player-results");
  write_file(d / "bad.jsonl", "{\"id\": \"a\", \"error\": \"no\"}\n\nnot json\n");
  try {
    (void)read_results_file(d / "bad.jsonl", clips);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 3u) << e.what();
  }
  const std::string clip = index->clips()[0].path;
  write_file(d / "range.jsonl",
             "{\"id\": \"a\", \"pairs\": [{\"from\": 0, \"to\": 1, \"results\": [{\"rank\": 1, "
             "\"clip\": \"" +
                 clip + "\", \"clip_index\": 0, \"start_frame\": 5, \"end_frame\": 999999}]}]}\n");
  EXPECT_THROW((void)read_results_file(d / "range.jsonl", clips), InputError);
  write_file(d / "ok.jsonl",
             "{\"id\": \"failed\", \"error\": \"no pose\"}\n{\"id\": \"a\", \"pairs\": [{\"from\": "
             "0, \"to\": 1, \"results\": [{\"rank\": 1, \"clip\": \"" +
                 clip + "\", \"clip_index\": 0, \"start_frame\": 5, \"end_frame\": 40}]}]}\n");
  const auto lines = read_results_file(d / "ok.jsonl", clips);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].error, "no pose");
  EXPECT_TRUE(lines[0].pairs.empty());
  ASSERT_EQ(lines[1].pairs.size(), 1u);
  EXPECT_EQ(lines[1].pairs[0].results[0].end_frame, 40u);
  const PlayerLibrary lib = load_player_library(fake_player_dir("player-results-lib"));
  EXPECT_THROW((void)results_player_page(clips, lines, {"nope"}, "ok.jsonl", lib), InputError);
  EXPECT_THROW((void)results_player_page(clips, {lines[0]}, {}, "ok.jsonl", lib), InputError);
  const std::string page = results_player_page(clips, lines, {}, "ok.jsonl", lib);
  const auto j = nlohmann::json::parse(script_text(page, "mp-data"));
  ASSERT_EQ(j["scenes"].size(), 1u);  // the failed query is left out
  EXPECT_EQ(j["scenes"][0]["motions"][0]["frames"], 36);
  EXPECT_EQ(j["scenes"][0]["motions"][0]["first_frame"], 5);
}

// The motion's BVH, read by our reader (OFFSET replaced by position
// channels, as three.js reads the export layout: its root's OFFSET is 0 and
// no other joint has position channels), gives the synthesis's world
// positions; the foot states follow from those positions frame by frame.
void check_motion(const Index& index, const std::string& name, std::size_t a, std::size_t b) {
  const std::size_t clip = test::clip_named(index, name);
  const ClipSource clips(index);
  const PlayerMotion m = player_clip_motion(clips, clip, a, b);
  const SynthSkeleton sk = make_synth_skeleton(index, index.clips()[clip].skeleton, clip);
  ASSERT_EQ(m.frames, b - a + 1);
  EXPECT_EQ(m.first_frame, a);
  const RawClip raw = parse_bvh(m.bvh, name);
  ASSERT_EQ(raw.frame_count, m.frames);
  EXPECT_EQ(raw.joints[0].offset.norm(), 0.0);
  for (std::size_t j = 1; j < raw.joints.size(); ++j)
    for (Channel c : raw.joints[j].channels) EXPECT_TRUE(channel_is_rotation(c)) << name;
  const ClipMotion read = clip_motion_from_raw(raw, m.unit_m);
  double worst = 0.0;
  std::vector<WorldPose> world(m.frames);
  for (std::size_t f = 0; f < m.frames; ++f) {
    synth_world_pose(sk, clip_frame(index, clip, a + f), world[f]);
    for (std::size_t j = 0; j < sk.joint_count(); ++j) {
      if (sk.is_root_chain[j] && static_cast<int>(j) != sk.root_joint) continue;  // hidden
      const int k = read.skeleton.find(sk.skeleton.names[j]);
      ASSERT_GE(k, 0) << sk.skeleton.names[j];
      worst = std::max(
          worst, (read.position(f, static_cast<std::size_t>(k)) - world[f].positions_m[j]).norm());
    }
  }
  EXPECT_LT(worst, 2e-5) << name;  // 6 significant digits
  // Root path box and hidden joints.
  for (std::size_t f = 0; f < m.frames; ++f) {
    const Eigen::Vector3d& p = world[f].positions_m[static_cast<std::size_t>(sk.root_joint)];
    EXPECT_GE(p.x(), m.box[0] - 1e-9);
    EXPECT_LE(p.x(), m.box[1] + 1e-9);
    EXPECT_GE(p.z(), m.box[2] - 1e-9);
    EXPECT_LE(p.z(), m.box[3] + 1e-9);
  }
  for (const std::string& h : m.hidden_joints) {
    const int j = sk.skeleton.find(h);
    ASSERT_GE(j, 0);
    EXPECT_TRUE(sk.is_root_chain[static_cast<std::size_t>(j)] && j != sk.root_joint);
  }
  // Foot states: the reference recomputes each frame's test on its own.
  ASSERT_EQ(m.foot_joints.size(), sk.foot_joints.size());
  ASSERT_FALSE(m.foot_joints.empty());
  std::size_t contact = 0, air = 0;
  for (std::size_t i = 0; i < sk.foot_joints.size(); ++i) {
    const auto j = static_cast<std::size_t>(sk.foot_joints[i]);
    EXPECT_EQ(m.foot_joints[i], sk.skeleton.names[j]);
    ASSERT_EQ(m.contacts[i].size(), m.frames);
    for (std::size_t f = 0; f < m.frames; ++f) {
      const std::size_t p = f == 0 ? 0 : f - 1, n = std::min(f + 1, m.frames - 1);
      const Eigen::Vector3d d = world[n].positions_m[j] - world[p].positions_m[j];
      const double speed =
          std::sqrt(d.x() * d.x() + d.z() * d.z()) / (static_cast<double>(n - p) * m.frame_time_s);
      const bool low = world[f].positions_m[j].y() - m.ground_m < 0.05;
      const char want = !low ? kFootAir : speed > 0.5 ? kFootSkating : kFootContact;
      EXPECT_EQ(m.contacts[i][f], want) << name << " " << m.foot_joints[i] << " frame " << f;
      contact += want == kFootContact;
      air += want == kFootAir;
    }
  }
  EXPECT_GT(contact, 0u) << name;  // a walk has feet on the ground and in the air
  EXPECT_GT(air, 0u) << name;
}

TEST(Player, BandaiMotionReadsBackAsSynthesised) {
  MOCAP_REQUIRE_DATA();
  const Index* index = test::built_index({"bandai-namco-1"});
  ASSERT_NE(index, nullptr);
  check_motion(*index, "dataset-1_walk_normal_001.bvh", 10, 70);
}

TEST(Player, CmuMotionReadsBackAsSynthesised) {
  MOCAP_REQUIRE_DATA();
  const Index* index = test::built_index({"cmu"});
  ASSERT_NE(index, nullptr);
  check_motion(*index, "131_01.bvh", 100, 400);
}

}  // namespace
}  // namespace mocap
