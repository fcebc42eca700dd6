// A motion as glTF 2.0 binary (.glb): the skeleton as nodes, one skin, one
// animation (motion_glb, motion_file.hpp; the glTF 2.0 specification,
// Khronos, sections "Binary glTF Layout" and "Animations").
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/motion_poses.hpp"
#include "mocap/common/io/motion_file.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

using json = nlohmann::json;

constexpr int kFloat = 5126;                      // accessor componentType FLOAT
constexpr std::uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr std::uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kBinChunk = 0x004E4942;   // "BIN\0"

void put_u32(std::string& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFFU));
}

void put_float(std::string& out, double v) {
  const auto f = static_cast<float>(v);
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  put_u32(out, bits);
}

// The binary chunk and the JSON accessors and buffer views that describe it:
// one buffer view per accessor, floats only (so every view is 4-aligned).
class GltfBuffer {
 public:
  /// Appends `values` (count x components floats) as an accessor of `type`
  /// ("SCALAR", "VEC3", ...); returns its index. With `bounds`, the
  /// accessor gets min and max (required for animation inputs).
  int add(const std::vector<double>& values, std::size_t count, const char* type,
          bool bounds = false) {
    const std::size_t offset = bin_.size();
    for (const double v : values) put_float(bin_, v);
    views_.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bin_.size() - offset}});
    json accessor = {{"bufferView", views_.size() - 1},
                     {"componentType", kFloat},
                     {"count", count},
                     {"type", type}};
    if (bounds) {
      float lo = static_cast<float>(values.front()), hi = lo;
      for (const double v : values) {
        lo = std::min(lo, static_cast<float>(v));
        hi = std::max(hi, static_cast<float>(v));
      }
      accessor["min"] = {lo};
      accessor["max"] = {hi};
    }
    accessors_.push_back(std::move(accessor));
    return static_cast<int>(accessors_.size() - 1);
  }
  const std::string& bin() const { return bin_; }
  json& accessors() { return accessors_; }
  json& views() { return views_; }

 private:
  std::string bin_;
  json accessors_ = json::array();
  json views_ = json::array();
};

// The nodes (one per joint: name, rest OFFSET, children) and the scene's roots.
void add_nodes(const Skeleton& s, json& doc) {
  json nodes = json::array(), roots = json::array();
  for (std::size_t j = 0; j < s.joint_count(); ++j) {
    const Eigen::Vector3d& t = s.offsets_m[j];
    json node = {{"name", s.names[j]}, {"translation", {t.x(), t.y(), t.z()}}};
    const std::vector<int> kids = s.children(static_cast<int>(j));
    if (!kids.empty()) node["children"] = kids;
    nodes.push_back(std::move(node));
    if (s.parents[j] < 0) roots.push_back(j);
  }
  doc["nodes"] = std::move(nodes);
  doc["scenes"] = json::array({{{"nodes", std::move(roots)}}});
  doc["scene"] = 0;
}

// The skin over every joint (one tree): inverse bind matrices of the rest pose (each
// joint at the sum of the OFFSETs above it, unrotated), column-major.
void add_skin(const Skeleton& s, GltfBuffer& buffer, json& doc) {
  const std::size_t n = s.joint_count();
  std::vector<Eigen::Vector3d> rest(n);
  std::vector<double> matrices;
  json joints = json::array();
  for (std::size_t j = 0; j < n; ++j) {
    const int p = s.parents[j];
    rest[j] =
        s.offsets_m[j] + (p < 0 ? Eigen::Vector3d::Zero() : rest[static_cast<std::size_t>(p)]);
    matrices.insert(matrices.end(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0});
    matrices.insert(matrices.end(), {-rest[j].x(), -rest[j].y(), -rest[j].z(), 1});
    joints.push_back(j);
  }
  doc["skins"] = json::array({{{"name", "skeleton"},
                               {"joints", std::move(joints)},
                               {"inverseBindMatrices", buffer.add(matrices, n, "MAT4")}}});
}

// Joint j's local rotations over the clip, x y z w, each sign chosen nearest
// the previous one (LINEAR rotation keys are interpolated along the shorter
// arc that way in every importer).
std::vector<double> rotation_keys(const ClipMotion& m, std::size_t j) {
  std::vector<double> keys;
  keys.reserve(m.frame_count * 4);
  Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
  for (std::size_t f = 0; f < m.frame_count; ++f) {
    Eigen::Quaterniond q = m.local_rotations[f * m.joint_count() + j].normalized();
    if (f > 0 && q.dot(previous) < 0.0) q.coeffs() = -q.coeffs();
    keys.insert(keys.end(), {q.x(), q.y(), q.z(), q.w()});
    previous = q;
  }
  return keys;
}

// The animation: rotation channels for every joint, translation channels for
// the joints with position channels, all keyed at one time accessor.
void add_animation(const ClipMotion& m, GltfBuffer& buffer, json& doc) {
  std::vector<double> times(m.frame_count);
  for (std::size_t f = 0; f < m.frame_count; ++f)
    times[f] = static_cast<double>(f) * m.frame_time_s;
  const int input = buffer.add(times, m.frame_count, "SCALAR", true);
  json channels = json::array(), samplers = json::array();
  const auto channel = [&](std::size_t node, const char* path, int output) {
    samplers.push_back({{"input", input}, {"output", output}, {"interpolation", "LINEAR"}});
    channels.push_back(
        {{"sampler", samplers.size() - 1}, {"target", {{"node", node}, {"path", path}}}});
  };
  const std::size_t n = m.joint_count();
  for (std::size_t j = 0; j < n; ++j) {
    channel(j, "rotation", buffer.add(rotation_keys(m, j), m.frame_count, "VEC4"));
    if (!m.skeleton.channels[j].has_position()) continue;
    std::vector<double> keys;
    for (std::size_t f = 0; f < m.frame_count; ++f) {
      const Eigen::Vector3d& t = m.local_translations_m[f * n + j];
      keys.insert(keys.end(), {t.x(), t.y(), t.z()});
    }
    channel(j, "translation", buffer.add(keys, m.frame_count, "VEC3"));
  }
  doc["animations"] = json::array(
      {{{"name", "motion"}, {"channels", std::move(channels)}, {"samplers", std::move(samplers)}}});
}

// GLB container: the 12-byte header, then the JSON chunk (padded with
// blanks) and the binary chunk (padded with zeros), each 4-aligned.
std::string glb_container(std::string text, std::string bin) {
  text.append((4 - text.size() % 4) % 4, ' ');
  bin.append((4 - bin.size() % 4) % 4, '\0');
  std::string out;
  out.reserve(28 + text.size() + bin.size());
  put_u32(out, kGlbMagic);
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(28 + text.size() + bin.size()));
  put_u32(out, static_cast<std::uint32_t>(text.size()));
  put_u32(out, kJsonChunk);
  out += text;
  put_u32(out, static_cast<std::uint32_t>(bin.size()));
  put_u32(out, kBinChunk);
  out += bin;
  return out;
}

}  // namespace

std::string motion_glb(const RawClip& clip, double scale_m) {
  const ClipMotion m = detail::checked_motion(clip, scale_m);
  json doc = {{"asset", {{"version", "2.0"}, {"generator", "mocap (motion_glb)"}}}};
  GltfBuffer buffer;
  add_nodes(m.skeleton, doc);
  // A skin's joints must share one root (glTF 2.0, "Skins"): a clip of
  // several trees gets none (importers then make plain nodes of it).
  if (std::count(m.skeleton.parents.begin(), m.skeleton.parents.end(), -1) == 1)
    add_skin(m.skeleton, buffer, doc);
  add_animation(m, buffer, doc);
  doc["accessors"] = std::move(buffer.accessors());
  doc["bufferViews"] = std::move(buffer.views());
  doc["buffers"] = json::array({{{"byteLength", buffer.bin().size()}}});
  // Joint names that are not UTF-8 get U+FFFD where their bytes are not.
  std::string text = doc.dump(-1, ' ', false, json::error_handler_t::replace);
  if (buffer.bin().size() + text.size() > 0xFFFFFFF0U)
    throw InputError(clip.source, 0, "the motion makes a glTF binary of 4 GiB or more");
  return glb_container(std::move(text), buffer.bin());
}

}  // namespace mocap
