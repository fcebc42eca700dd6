// common/src/io/motion_file.cpp and gltf_writer.cpp: a motion as .glb, .npz
// or BVH by its path. Invalid inputs first, then the formats' structure on a
// tiny hand-written clip, then round trips: the glTF's own forward kinematics
// and the npz's arrays against the engine's (clip_motion_from_raw).
#include "mocap/common/io/motion_file.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/npz.hpp"
#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using mocap::InputError;
using mocap::MotionFormat;

namespace {

// Centimetres; a root with position channels under a non-zero OFFSET (they
// replace it), a joint with a partial rotation set, End Sites.
const char* kClip = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 12 -1
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 30 0
    }
  }
  JOINT LeftLeg
  {
    OFFSET 9 -4 0
    CHANNELS 2 Xrotation Zrotation
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
1 91 2 10 20 30 -40 50 170 15 -25
2 92 4 -170 10 175 -40 60 -170 -90 80
3 93 6 100 -80 20 5 5 5 45 -45
)";

mocap::RawClip tiny_clip() {
  return mocap::parse_bvh(kClip, "tiny.bvh");
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::uint32_t u32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);  // the test host is little-endian
  return v;
}

// A .glb split into its JSON and its binary chunk (checking the container).
struct Glb {
  json doc;
  std::string bin;
  // Accessor k's floats.
  std::vector<float> floats(int k) const {
    const json& a = doc["accessors"][k];
    const json& v = doc["bufferViews"][a["bufferView"].get<int>()];
    std::vector<float> out(v["byteLength"].get<std::size_t>() / 4);
    std::memcpy(out.data(), bin.data() + v["byteOffset"].get<std::size_t>(), out.size() * 4);
    return out;
  }
};

Glb split_glb(const std::string& b) {
  EXPECT_EQ(b.substr(0, 4), "glTF");
  EXPECT_EQ(u32(b, 4), 2U);
  EXPECT_EQ(u32(b, 8), b.size());
  const std::uint32_t text_size = u32(b, 12);
  EXPECT_EQ(text_size % 4, 0U);
  EXPECT_EQ(b.substr(16, 4), "JSON");
  Glb g{json::parse(b.substr(20, text_size)), {}};
  const std::size_t bin_at = 20 + text_size;
  EXPECT_EQ(b.substr(bin_at + 4, 4), std::string("BIN\0", 4));
  g.bin = b.substr(bin_at + 8, u32(b, bin_at));
  return g;
}

// World joint positions of frame f by glTF's rules: node local transform
// T(translation) * R(rotation), animated values replacing the node's own.
std::vector<Eigen::Vector3d> glb_world_positions(const Glb& g, std::size_t f) {
  const json& nodes = g.doc["nodes"];
  std::vector<Eigen::Vector3d> t(nodes.size());
  std::vector<Eigen::Quaterniond> r(nodes.size(), Eigen::Quaterniond::Identity());
  std::vector<int> parent(nodes.size(), -1);
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    const auto v = nodes[n]["translation"].get<std::vector<double>>();
    t[n] = Eigen::Vector3d(v[0], v[1], v[2]);
    for (int c : nodes[n].value("children", std::vector<int>{}))
      parent[static_cast<std::size_t>(c)] = static_cast<int>(n);
  }
  const json& anim = g.doc["animations"][0];
  for (const json& ch : anim["channels"]) {
    const json& s = anim["samplers"][ch["sampler"].get<int>()];
    const std::vector<float> k = g.floats(s["output"].get<int>());
    const auto n = ch["target"]["node"].get<std::size_t>();
    if (ch["target"]["path"] == "rotation")
      r[n] = Eigen::Quaterniond(k[4 * f + 3], k[4 * f], k[4 * f + 1], k[4 * f + 2]);
    else
      t[n] = Eigen::Vector3d(k[3 * f], k[3 * f + 1], k[3 * f + 2]);
  }
  std::vector<Eigen::Vector3d> pos(nodes.size());
  std::vector<Eigen::Quaterniond> rot(nodes.size());
  for (std::size_t n = 0; n < nodes.size(); ++n) {  // parents come first here
    const int p = parent[n];
    pos[n] =
        p < 0 ? t[n] : pos[static_cast<std::size_t>(p)] + rot[static_cast<std::size_t>(p)] * t[n];
    rot[n] = p < 0 ? r[n] : rot[static_cast<std::size_t>(p)] * r[n];
  }
  return pos;
}

std::map<std::string, mocap::NpyArray> npz_arrays(const std::string& bytes) {
  std::map<std::string, mocap::NpyArray> out;
  for (const auto& [name, member] : mocap::read_zip_stored(bytes, "m.npz"))
    out[name] = mocap::parse_npy(member, name);
  return out;
}

std::vector<double> doubles(const mocap::NpyArray& a) {
  std::vector<double> v(a.data.size() / 8);
  std::memcpy(v.data(), a.data.data(), a.data.size());
  return v;
}

}  // namespace

TEST(MotionFile, RefusesInvalidInputs) {
  mocap::RawClip empty = tiny_clip();
  empty.frame_count = 0;
  empty.values.clear();
  EXPECT_THROW(mocap::motion_glb(empty, 0.01), InputError);
  EXPECT_THROW(mocap::motion_npz(empty, 0.01), InputError);
  mocap::RawClip nan = tiny_clip();
  nan.values[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(mocap::motion_glb(nan, 0.01), InputError);
  EXPECT_THROW(mocap::motion_npz(nan, 0.01), InputError);
  EXPECT_THROW(mocap::motion_glb(tiny_clip(), 0.0), std::invalid_argument);
  EXPECT_THROW(mocap::motion_npz(tiny_clip(), std::nan("")), std::invalid_argument);
  mocap::RawClip no_joints;
  no_joints.frame_time_s = 0.01;
  EXPECT_THROW(mocap::motion_glb(no_joints, 1.0), std::invalid_argument);

  // A path under a regular file cannot be written (nor its folder made).
  const fs::path dir = mocap::test::temp_dir("motion-file");
  std::ofstream(dir / "plain") << "x";
  for (const char* name : {"m.glb", "m.npz", "m.bvh"})
    EXPECT_THROW(mocap::write_motion_file(tiny_clip(), 0.01, dir / "plain" / name), InputError)
        << name;
  EXPECT_THROW(mocap::write_motion_file(empty, 0.01, dir / "empty.glb"), InputError);
  EXPECT_FALSE(fs::exists(dir / "empty.glb"));
}

TEST(MotionFile, FormatByExtension) {
  EXPECT_EQ(mocap::motion_format("a/m.glb"), MotionFormat::glb);
  EXPECT_EQ(mocap::motion_format("M.GLB"), MotionFormat::glb);
  EXPECT_EQ(mocap::motion_format("m.npz"), MotionFormat::npz);
  EXPECT_EQ(mocap::motion_format("m.Npz"), MotionFormat::npz);
  EXPECT_EQ(mocap::motion_format("m.bvh"), MotionFormat::bvh);
  EXPECT_EQ(mocap::motion_format("motion"), MotionFormat::bvh);
  EXPECT_EQ(mocap::motion_format("m.glb.bvh"), MotionFormat::bvh);
  EXPECT_EQ(mocap::motion_output_kind(MotionFormat::glb), mocap::OutputKind::glb);
  EXPECT_STREQ(mocap::motion_format_name(MotionFormat::npz), "NumPy .npz");
  EXPECT_TRUE(mocap::looks_like(mocap::OutputKind::glb, mocap::motion_glb(tiny_clip(), 0.01)));
  EXPECT_TRUE(mocap::looks_like(mocap::OutputKind::npz, mocap::motion_npz(tiny_clip(), 0.01)));
  EXPECT_FALSE(mocap::looks_like(mocap::OutputKind::glb, "HIERARCHY"));
}

TEST(MotionFile, GlbHoldsTheSkeletonAndOneAnimation) {
  const Glb g = split_glb(mocap::motion_glb(tiny_clip(), 0.01));
  EXPECT_EQ(g.doc["asset"]["version"], "2.0");
  const json& nodes = g.doc["nodes"];
  ASSERT_EQ(nodes.size(), 3U);
  EXPECT_EQ(nodes[0]["name"], "Hips");
  EXPECT_EQ(nodes[0]["children"], json::array({1, 2}));
  EXPECT_EQ(nodes[2]["translation"], json::array({0.09, -0.04, 0.0}));  // metres
  EXPECT_EQ(g.doc["scenes"][0]["nodes"], json::array({0}));
  EXPECT_EQ(g.doc["skins"][0]["joints"], json::array({0, 1, 2}));
  const json& anim = g.doc["animations"][0];
  ASSERT_EQ(anim["channels"].size(), 4U);  // 3 rotations, the root's translation
  int translations = 0;
  for (const json& ch : anim["channels"]) translations += ch["target"]["path"] == "translation";
  EXPECT_EQ(translations, 1);
  for (const json& s : anim["samplers"]) EXPECT_EQ(s["interpolation"], "LINEAR");
  const json& times = g.doc["accessors"][anim["samplers"][0]["input"].get<int>()];
  EXPECT_EQ(times["count"], 3);
  EXPECT_FLOAT_EQ(times["max"][0].get<float>(), 2 * 0.0333333F);
  EXPECT_EQ(g.doc["buffers"][0]["byteLength"], g.bin.size());
}

TEST(MotionFile, GlbPosesAreTheEnginesForwardKinematics) {
  const mocap::RawClip clip = tiny_clip();
  const mocap::ClipMotion m = mocap::clip_motion_from_raw(clip, 0.01);
  const Glb g = split_glb(mocap::motion_glb(clip, 0.01));
  for (std::size_t f = 0; f < m.frame_count; ++f) {
    const std::vector<Eigen::Vector3d> p = glb_world_positions(g, f);
    for (std::size_t j = 0; j < m.joint_count(); ++j)
      EXPECT_LT((p[j] - m.position(f, j)).norm(), 1e-6) << "frame " << f << " joint " << j;
  }
}

TEST(MotionFile, NpzRoundTrips) {
  const mocap::RawClip clip = tiny_clip();
  const mocap::ClipMotion m = mocap::clip_motion_from_raw(clip, 0.01);
  auto arrays = npz_arrays(mocap::motion_npz(clip, 0.01));
  ASSERT_EQ(arrays.size(), 6U);
  EXPECT_EQ(arrays["positions.npy"].shape, (std::vector<std::size_t>{3, 3, 3}));
  EXPECT_EQ(arrays["rotations.npy"].shape, (std::vector<std::size_t>{3, 3, 4}));
  EXPECT_EQ(arrays["translations.npy"].shape, (std::vector<std::size_t>{3, 3, 3}));
  EXPECT_EQ(arrays["fps.npy"].shape, std::vector<std::size_t>{});
  EXPECT_NEAR(doubles(arrays["fps.npy"])[0], 1.0 / 0.0333333, 1e-9);
  EXPECT_EQ(arrays["parents.npy"].data, mocap::npy_int32({-1, 0, 0}).data);
  EXPECT_EQ(arrays["names.npy"].data, mocap::npy_strings({"Hips", "Spine", "LeftLeg"}).data);
  const std::vector<double> p = doubles(arrays["positions.npy"]);
  const std::vector<double> q = doubles(arrays["rotations.npy"]);
  for (std::size_t k = 0; k < 9; ++k) {
    for (int a = 0; a < 3; ++a)
      EXPECT_EQ(p[3 * k + static_cast<std::size_t>(a)], m.world_positions_m[k][a]);
    const Eigen::Quaterniond& r = m.local_rotations[k];
    EXPECT_EQ(q[4 * k + 3], r.w());  // w last
    EXPECT_EQ(q[4 * k], r.x());
  }
}

TEST(MotionFile, WritesTheFormatItsPathNames) {
  const fs::path dir = mocap::test::temp_dir("motion-file");
  const mocap::RawClip clip = tiny_clip();
  mocap::write_motion_file(clip, 0.01, dir / "sub" / "m.glb");
  mocap::write_motion_file(clip, 0.01, dir / "m.NPZ");
  mocap::write_motion_file(clip, 0.01, dir / "m.bvh");
  EXPECT_EQ(read_file(dir / "sub" / "m.glb"), mocap::motion_glb(clip, 0.01));
  EXPECT_EQ(read_file(dir / "m.NPZ"), mocap::motion_npz(clip, 0.01));
  EXPECT_EQ(read_file(dir / "m.bvh"), mocap::write_bvh(clip));
  // Replaced in place, with no temporary file left beside it.
  mocap::write_motion_file(clip, 0.01, dir / "m.NPZ");
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 3U);  // sub/, m.NPZ and m.bvh: no temporary file
}

TEST(MotionFile, GlbOfSeveralTreesHasNoSkin) {
  const mocap::RawClip clip = mocap::parse_bvh(R"(HIERARCHY
ROOT A
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
}
ROOT B
{
  OFFSET 1 0 0
  CHANNELS 3 Zrotation Xrotation Yrotation
  JOINT C
  {
    OFFSET 0 1 0
    CHANNELS 0
  }
}
MOTION
Frames: 2
Frame Time: 0.5
0 1 0 0 0 0 10 20 30
1 1 0 90 0 0 -10 -20 -30
)",
                                               "two.bvh");
  const mocap::ClipMotion m = mocap::clip_motion_from_raw(clip, 1.0);
  const Glb g = split_glb(mocap::motion_glb(clip, 1.0));
  EXPECT_FALSE(g.doc.contains("skins"));
  EXPECT_EQ(g.doc["scenes"][0]["nodes"], json::array({0, 1}));
  for (std::size_t f = 0; f < 2; ++f) {
    const std::vector<Eigen::Vector3d> p = glb_world_positions(g, f);
    for (std::size_t j = 0; j < 3; ++j) EXPECT_LT((p[j] - m.position(f, j)).norm(), 1e-6);
  }
}
