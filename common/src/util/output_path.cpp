// The output-path policy (output_path.hpp).
#include "mocap/common/util/output_path.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <system_error>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace fs = std::filesystem;

const char* output_kind_name(OutputKind kind) {
  switch (kind) {
    case OutputKind::index:
      return "index (HDF5)";
    case OutputKind::bvh:
      return "BVH";
    case OutputKind::json:
      return "JSON";
    case OutputKind::jsonl:
      return "JSON lines";
    case OutputKind::html:
      return "HTML";
    case OutputKind::glb:
      return "glTF binary";
    case OutputKind::npz:
      return "NumPy .npz";
  }
  return "?";
}

bool looks_like(OutputKind kind, const std::string& head) {
  if (kind == OutputKind::index) {
    // HDF5 looks for its signature at 0, 512, 1024, 2048 ... (after a user
    // block, such as the index's "MOCAP-INDEX-USER-BLOCK").
    static const std::string sig("\x89HDF\r\n\x1a\n", 8);
    if (head.rfind("MOCAP-INDEX-USER-BLOCK", 0) == 0) return true;
    for (std::size_t at = 0; at + sig.size() <= head.size(); at = at == 0 ? 512 : 2 * at)
      if (head.compare(at, sig.size(), sig) == 0) return true;
    return false;
  }
  if (kind == OutputKind::glb) return head.rfind("glTF", 0) == 0;
  if (kind == OutputKind::npz)
    return head.rfind(std::string("PK\3\4", 4), 0) == 0 ||
           head.rfind(std::string("PK\5\6", 4), 0) == 0;
  std::size_t i = 0;
  if (head.rfind("\xEF\xBB\xBF", 0) == 0) i = 3;  // a UTF-8 byte order mark
  while (i < head.size() && std::isspace(static_cast<unsigned char>(head[i]))) ++i;
  std::string rest = head.substr(i);
  switch (kind) {
    case OutputKind::bvh:
      return rest.rfind("HIERARCHY", 0) == 0;
    case OutputKind::json:
      return !rest.empty() && (rest[0] == '{' || rest[0] == '[');
    case OutputKind::jsonl:
      return !rest.empty() && rest[0] == '{';
    case OutputKind::html: {
      std::transform(rest.begin(), rest.end(), rest.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      return rest.rfind("<!doctype html", 0) == 0 || rest.rfind("<html", 0) == 0;
    }
    case OutputKind::index:
    case OutputKind::glb:
    case OutputKind::npz:
      break;
  }
  return false;
}

namespace {

// `path` with its symbolic links followed (the last one may dangle).
fs::path follow_links(const fs::path& path, const std::string& option) {
  fs::path p = path;
  for (int hops = 0; hops <= 40; ++hops) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (ec || st.type() != fs::file_type::symlink) return p;
    const fs::path to = fs::read_symlink(p, ec);
    if (ec) throw InputError(option, 0, "cannot read the link " + p.string() + ": " + ec.message());
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  throw InputError(option, 0, path.string() + ": more than 40 symbolic links");
}

const char* what_it_is(fs::file_type t) {
  switch (t) {
    case fs::file_type::directory:
      return "a directory";
    case fs::file_type::block:
      return "a block device";
    case fs::file_type::character:
      return "a character device";
    case fs::file_type::fifo:
      return "a FIFO";
    case fs::file_type::socket:
      return "a socket";
    default:
      return "not a regular file";
  }
}

}  // namespace

fs::path checked_output_path(const fs::path& path, OutputKind kind, bool force,
                             const std::string& option) {
  if (path.empty()) throw InputError(option, 0, "empty output path");
  const fs::path target = follow_links(path, option);
  const std::string shown =
      target == path ? path.string() : path.string() + " (a link to " + target.string() + ")";
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  if (ec && ec != std::errc::no_such_file_or_directory)
    throw InputError(option, 0, "cannot check " + shown + ": " + ec.message());
  if (!fs::exists(st)) return target;
  if (st.type() != fs::file_type::regular)
    throw InputError(option, 0,
                     shown + " is " + what_it_is(st.type()) + ": give the path of " +
                         (kind == OutputKind::index ? "an " : "a ") + output_kind_name(kind) +
                         " file to write");
  if (force) return target;
  std::ifstream in(target, std::ios::binary);
  if (!in) throw InputError(option, 0, "cannot read " + shown + " to check what it holds");
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  if (head.empty() || looks_like(kind, head)) return target;
  throw InputError(option, 0,
                   shown + " exists and is not " + (kind == OutputKind::index ? "an " : "a ") +
                       output_kind_name(kind) +
                       " file; not replacing it (choose another path, or --force)");
}

void check_distinct_outputs(const std::vector<std::pair<std::string, fs::path>>& outputs) {
  std::vector<fs::path> resolved;
  for (const auto& [option, path] : outputs)
    resolved.push_back(path.empty() ? fs::path()
                                    : fs::weakly_canonical(follow_links(path, option)));
  for (std::size_t i = 0; i < outputs.size(); ++i)
    for (std::size_t j = i + 1; j < outputs.size(); ++j)
      if (!resolved[i].empty() && resolved[i] == resolved[j])
        throw InputError(outputs[j].first, 0,
                         outputs[j].second.string() + " is the file " + outputs[i].first +
                             " writes: give each output its own path");
}

void check_outputs_and_inputs(const std::vector<std::pair<std::string, fs::path>>& outputs,
                              const std::vector<std::pair<std::string, fs::path>>& inputs) {
  check_distinct_outputs(outputs);
  // Every file the command reads: a collection manifest's shards too.
  std::vector<std::pair<std::string, fs::path>> read;
  for (const auto& [option, path] : inputs) {
    if (path.empty()) continue;
    read.emplace_back(option, path);
    std::error_code ec;
    if (!fs::is_regular_file(path, ec) || !is_collection_manifest(path)) continue;
    try {
      const CollectionManifest m = read_collection_manifest(path);
      for (std::size_t k = 0; k < m.shards.size(); ++k)
        read.emplace_back(option + " (shard " + std::to_string(k + 1) + " of " +
                              std::to_string(m.shards.size()) + " of " + path.string() + ")",
                          shard_file(path, m.shards[k]));
    } catch (const InputError&) {
      // A manifest that cannot be read is the command's error, reported when
      // it reads its inputs (no output is written before).
    }
  }
  const auto resolve = [](const fs::path& path, const std::string& option) {
    std::error_code ec;
    const fs::path real = fs::weakly_canonical(follow_links(path, option), ec);
    return ec ? fs::absolute(path).lexically_normal() : real;
  };
  std::vector<fs::path> read_files;
  for (const auto& [option, path] : read) read_files.push_back(resolve(path, option));
  for (const auto& [option, path] : outputs) {
    if (path.empty()) continue;
    const fs::path target = resolve(path, option);
    for (std::size_t i = 0; i < read.size(); ++i)
      if (read_files[i] == target)
        throw InputError(option, 0,
                         path.string() + " is the file " + read[i].first +
                             " reads: an output never replaces an input, even with --force "
                             "(give the output another path)");
  }
}

}  // namespace mocap
