// Sharded builds (sharded_build.hpp).
#include "mocap/indexer/sharded_build.hpp"

#include <fstream>
#include <numeric>
#include <string>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "mocap/indexer/collection.hpp"

namespace mocap {
namespace {

// The frame count of a BVH file's MOTION header (0 when it has none: the
// build reports such a file).
std::uint64_t header_frames(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto at = line.find("Frames:");
    if (at != std::string::npos) {
      try {
        return std::stoull(line.substr(at + 7));
      } catch (const std::exception&) {
        return 0;
      }
    }
  }
  return 0;
}

// Where each of `count` consecutive groups ends (exclusive), balanced by
// frames: group k ends at the first file whose running total reaches
// (k + 1) / count of the whole, each group keeping at least one file.
std::vector<std::size_t> split_points(const std::vector<std::uint64_t>& frames, std::size_t count) {
  const double total = static_cast<double>(std::accumulate(frames.begin(), frames.end(), 0ull));
  std::vector<std::size_t> ends;
  std::size_t i = 0;
  double sum = 0.0;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t must_leave = count - k - 1;  // files for the groups after this one
    const double target = total * static_cast<double>(k + 1) / static_cast<double>(count);
    do {
      sum += static_cast<double>(frames[i]);
      ++i;
    } while (i + must_leave < frames.size() && sum + 0.5 * static_cast<double>(frames[i]) < target);
    ends.push_back(k + 1 == count ? frames.size() : i);
  }
  return ends;
}

}  // namespace

std::vector<std::filesystem::path> shard_paths(const std::filesystem::path& manifest,
                                               std::size_t count) {
  std::vector<std::filesystem::path> out;
  for (std::size_t k = 1; k <= count; ++k)
    out.push_back(manifest.parent_path() /
                  (manifest.stem().string() + ".shard-" + std::to_string(k) + "-of-" +
                   std::to_string(count) + ".h5"));
  return out;
}

ShardedBuildSummary build_sharded(const IndexBuildOptions& options, std::size_t count) {
  const std::string out = options.out.string();
  if (count == 0) throw InputError("--shards", 0, "must be at least 1");
  if (count > kMaxCollectionShards)
    throw InputError("--shards", 0,
                     "at most " + std::to_string(kMaxCollectionShards) + " shards in a collection");
  if (options.out.empty()) throw InputError("--out", 0, "empty output path");
  // The manifest: written through a symbolic link to the file it leads to
  // (the link stays a link, as for an index), its shards beside that file.
  std::error_code ec;
  if (std::filesystem::is_regular_file(options.out, ec) && !options.force &&
      !is_collection_manifest(options.out))
    throw InputError(out, 0,
                     "exists and is not a collection manifest (--force replaces it; docs/cli.md "
                     "\"Output paths\")");
  const std::filesystem::path manifest_file =
      checked_output_path(options.out, OutputKind::json, true, "--out");
  // One build per manifest at a time, whatever its shard count: a second
  // build fails here, before any work (shards are locked by build_index).
  if (!manifest_file.parent_path().empty())
    std::filesystem::create_directories(manifest_file.parent_path(), ec);
  const OutputLock lock(manifest_file);
  const std::vector<std::filesystem::path> paths = shard_paths(manifest_file, count);
  // Every shard's path checked before any shard is built (docs/cli.md
  // "Output paths"): a FIFO at the last one is refused before the first.
  for (const std::filesystem::path& p : paths)
    (void)checked_output_path(p, OutputKind::index, options.force, "--out");
  const Collection collection = list_collection(options.inputs);
  if (options.strict && !collection.problems.empty())
    throw InputError(collection.problems.front().input, 0, collection.problems.front().reason);
  if (collection.files.size() < count)
    throw InputError(out, 0,
                     std::to_string(count) +
                         " shards need at least as many files; the inputs hold " +
                         std::to_string(collection.files.size()));
  {
    // No output (the manifest, a shard) is a file the build reads.
    std::vector<std::pair<std::string, std::filesystem::path>> outputs{{"--out", manifest_file}};
    for (const std::filesystem::path& p : paths) outputs.emplace_back("--out (a shard)", p);
    std::vector<std::pair<std::string, std::filesystem::path>> inputs;
    for (const CollectionEntry& e : collection.files) inputs.emplace_back("an input", e.path);
    if (options.character) inputs.emplace_back("--character", *options.character);
    check_outputs_and_inputs(outputs, inputs);
  }
  std::vector<std::uint64_t> frames;
  for (const CollectionEntry& e : collection.files) frames.push_back(header_frames(e.path));
  const std::vector<std::size_t> ends = split_points(frames, count);
  ShardedBuildSummary sum;
  sum.manifest = options.out;
  CollectionManifest manifest;
  std::size_t first = 0;
  for (std::size_t k = 0; k < count; ++k) {
    IndexBuildOptions o = options;
    o.out = paths[k];
    o.inputs.clear();
    for (std::size_t i = first; i < ends[k]; ++i)
      o.inputs.push_back(collection.files[i].path.string());
    first = ends[k];
    sum.shards.push_back(build_index(o));
    const IndexBuildSummary& s = sum.shards.back();
    manifest.shards.push_back(
        {paths[k].filename().string(), s.clips, s.frames, hex64(hash_file(paths[k]))});
  }
  // Inputs that named nothing readable are reported with the first shard.
  for (const CollectionProblem& p : collection.problems)
    sum.shards.front().skipped.push_back({p.input, p.reason});
  write_collection_manifest(manifest_file, manifest);
  return sum;
}

}  // namespace mocap
