// Collection manifests (collection_manifest.hpp).
#include "mocap/common/io/collection_manifest.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {
namespace {

// K and N, as written, of a file named STEM.shard-K-of-N.h5 (1 to 9 digits
// each: mocap-index build --shards names its shards so); nullopt otherwise.
std::optional<std::pair<std::string, std::string>> shard_place(const std::string& name) {
  constexpr std::string_view kTag = ".shard-", kOf = "-of-", kExt = ".h5";
  if (!name.ends_with(kExt)) return std::nullopt;
  const std::string_view body(name.data(), name.size() - kExt.size());
  const auto tag = body.rfind(kTag);
  if (tag == std::string_view::npos) return std::nullopt;
  const std::string_view rest = body.substr(tag + kTag.size());
  const auto of = rest.find(kOf);
  if (of == std::string_view::npos) return std::nullopt;
  const std::string_view k = rest.substr(0, of), n = rest.substr(of + kOf.size());
  const auto number = [](std::string_view d) {
    return !d.empty() && d.size() <= 9 &&
           std::all_of(d.begin(), d.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!number(k) || !number(n)) return std::nullopt;
  return std::pair{std::string(k), std::string(n)};
}

using json = nlohmann::json;

bool is_hex64(const std::string& s) {
  return s.size() == 16 &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isxdigit(c) != 0; });
}

std::string to_lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& field,
                       const std::string& what) {
  throw InputError(path.string(), 0, field + ": " + what);
}

}  // namespace

bool is_collection_manifest(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char c = 0;
  while (in.get(c))
    if (c != ' ' && c != '\t' && c != '\n' && c != '\r') return c == '{';
  return false;
}

CollectionManifest read_collection_manifest(const std::filesystem::path& path) {
  const FileBytes bytes = read_input_file(path, input_limits().json_file_bytes);
  const json j = json::parse(bytes.view(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) fail(path, "manifest", "not a JSON object");
  if (!j.contains("format") || j["format"] != kCollectionFormat)
    fail(path, "format", std::string("expected \"") + kCollectionFormat + "\"");
  if (!j.contains("version") || j["version"] != kCollectionVersion)
    fail(path, "version", "expected " + std::to_string(kCollectionVersion));
  if (!j.contains("shards") || !j["shards"].is_array() || j["shards"].empty())
    fail(path, "shards", "expected a non-empty list");
  const std::size_t count = j["shards"].size();
  if (count > kMaxCollectionShards)
    fail(path, "shards",
         std::to_string(count) + " shards: more than the limit of " +
             std::to_string(kMaxCollectionShards) + " (mocap-index build --shards)");
  CollectionManifest m;
  std::uint64_t clips_before = 0;
  // Each shard's file once (links followed): a shard listed twice would
  // number its clips twice.
  std::map<std::filesystem::path, std::size_t> files;
  for (std::size_t i = 0; i < count; ++i) {
    const json& s = j["shards"][i];
    const std::string at = "shards[" + std::to_string(i) + "]";
    if (!s.is_object()) fail(path, at, "expected an object");
    CollectionShard sh;
    if (!s.contains("path") || !s["path"].is_string() || s["path"].get<std::string>().empty())
      fail(path, at + ".path", "expected the shard's file path");
    if (s["path"].get<std::string>().find('\0') != std::string::npos)
      fail(path, at + ".path", "holds a NUL byte (\\u0000): not a file path");
    if (!s.contains("clips") || !s["clips"].is_number_unsigned())
      fail(path, at + ".clips", "expected a count");
    if (!s.contains("frames") || !s["frames"].is_number_unsigned())
      fail(path, at + ".frames", "expected a count");
    if (!s.contains("xxh64") || !s["xxh64"].is_string() || !is_hex64(s["xxh64"].get<std::string>()))
      fail(path, at + ".xxh64", "expected 16 hex digits");
    sh.path = s["path"].get<std::string>();
    sh.clips = s["clips"].get<std::size_t>();
    sh.frames = s["frames"].get<std::uint64_t>();
    sh.xxh64 = to_lower(s["xxh64"].get<std::string>());
    if (sh.clips > ~std::uint64_t{0} - clips_before)
      fail(path, at + ".clips", "the shards' clip counts add up past 2^64");
    clips_before += sh.clips;
    // A shard built by mocap-index build --shards names its place:
    // STEM.shard-K-of-N.h5 must be entry K of N.
    const std::string name = std::filesystem::path(sh.path).filename().string();
    const auto place = shard_place(name);
    if (place && (std::stoul(place->first) != i + 1 || std::stoul(place->second) != count))
      fail(path, at + ".path",
           name + " is shard " + place->first + " of " + place->second + ", listed as shard " +
               std::to_string(i + 1) + " of " + std::to_string(count) +
               ": the manifest's shards are reordered, repeated or missing (rebuild it with "
               "mocap-index build --shards)");
    std::error_code ec;
    std::filesystem::path file = shard_file(path, sh);
    const std::filesystem::path real = std::filesystem::weakly_canonical(file, ec);
    if (!ec) file = real;
    const auto [it, added] = files.emplace(file, i);
    if (!added)
      fail(path, at + ".path",
           sh.path + " is the file of shards[" + std::to_string(it->second) +
               "] again: each shard is listed once");
    m.shards.push_back(std::move(sh));
  }
  return m;
}

std::filesystem::path shard_file(const std::filesystem::path& manifest,
                                 const CollectionShard& shard) {
  const std::filesystem::path p(shard.path);
  if (p.is_absolute()) return p;
  // A manifest reached through a symbolic link: its shards lie beside the
  // file the link leads to (where mocap-index build --shards writes them).
  std::error_code ec;
  if (std::filesystem::is_symlink(manifest, ec)) {
    const std::filesystem::path real = std::filesystem::canonical(manifest, ec);
    if (!ec) return real.parent_path() / p;
  }
  return manifest.parent_path() / p;
}

std::string shard_count_problem(const CollectionShard& shard, std::size_t clips,
                                std::uint64_t frames) {
  if (clips != shard.clips)
    return "shard " + shard.path + ": holds " + std::to_string(clips) +
           " clips, the manifest says " + std::to_string(shard.clips);
  if (frames != shard.frames)
    return "shard " + shard.path + ": holds " + std::to_string(frames) +
           " frames, the manifest says " + std::to_string(shard.frames);
  return {};
}

std::vector<std::string> collection_shard_problems(const std::filesystem::path& manifest,
                                                   const CollectionManifest& m) {
  std::vector<std::string> problems;
  for (const CollectionShard& s : m.shards) {
    const std::filesystem::path f = shard_file(manifest, s);
    try {
      (void)check_input_file(f, ~std::uint64_t{0});
      if (hex64(hash_file(f)) != s.xxh64)
        problems.push_back("shard " + s.path +
                           ": changed since the manifest was written (its bytes no longer hash "
                           "to " +
                           s.xxh64 + ")");
    } catch (const InputError& e) {
      problems.push_back("shard " + s.path + ": " + e.detail());
    }
  }
  return problems;
}

void write_collection_manifest(const std::filesystem::path& path, const CollectionManifest& m) {
  json shards = json::array();
  for (const CollectionShard& s : m.shards)
    shards.push_back(
        {{"path", s.path}, {"clips", s.clips}, {"frames", s.frames}, {"xxh64", s.xxh64}});
  const json j{{"format", kCollectionFormat}, {"version", kCollectionVersion}, {"shards", shards}};
  AtomicFile out(path);
  {
    std::ofstream f(out.temporary_path(), std::ios::binary);
    f << json_text(j, 2) << '\n';
    if (!f) throw InputError(path.string(), 0, "cannot write the manifest");
  }
  out.commit();
}

}  // namespace mocap
