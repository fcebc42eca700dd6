// Collection manifests (collection_manifest.hpp).
#include "mocap/common/collection_manifest.hpp"

#include <fstream>
#include <nlohmann/json.hpp>

#include "mocap/common/atomic_file.hpp"
#include "mocap/common/error.hpp"
#include "mocap/common/file.hpp"
#include "mocap/common/input_limits.hpp"
#include "mocap/common/json_text.hpp"
#include "mocap/common/xxh64.hpp"

namespace mocap {
namespace {

using json = nlohmann::json;

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
  CollectionManifest m;
  for (std::size_t i = 0; i < j["shards"].size(); ++i) {
    const json& s = j["shards"][i];
    const std::string at = "shards[" + std::to_string(i) + "]";
    if (!s.is_object()) fail(path, at, "expected an object");
    CollectionShard sh;
    if (!s.contains("path") || !s["path"].is_string() || s["path"].get<std::string>().empty())
      fail(path, at + ".path", "expected the shard's file path");
    if (!s.contains("clips") || !s["clips"].is_number_unsigned())
      fail(path, at + ".clips", "expected a count");
    if (!s.contains("frames") || !s["frames"].is_number_unsigned())
      fail(path, at + ".frames", "expected a count");
    if (!s.contains("xxh64") || !s["xxh64"].is_string() ||
        s["xxh64"].get<std::string>().size() != 16)
      fail(path, at + ".xxh64", "expected 16 hex digits");
    sh.path = s["path"].get<std::string>();
    sh.clips = s["clips"].get<std::size_t>();
    sh.frames = s["frames"].get<std::uint64_t>();
    sh.xxh64 = s["xxh64"].get<std::string>();
    m.shards.push_back(std::move(sh));
  }
  return m;
}

std::filesystem::path shard_file(const std::filesystem::path& manifest,
                                 const CollectionShard& shard) {
  const std::filesystem::path p(shard.path);
  return p.is_absolute() ? p : manifest.parent_path() / p;
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
