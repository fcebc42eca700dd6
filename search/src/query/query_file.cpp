// Query files for commands that run one query (query_file.hpp).
#include "mocap/search/query_file.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"

namespace mocap {

namespace {

// A batch: the text is not one JSON value, and its first non-blank line is
// a JSON object by itself (a single query spread over lines starts with a
// line that is not).
bool looks_like_batch(std::string_view text) {
  if (nlohmann::json::accept(text)) return false;
  std::size_t at = 0;
  while (at < text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(at, end - at);
    at = end + 1;
    if (line.find_first_not_of(" \t\r") == std::string_view::npos) continue;
    const auto j = nlohmann::json::parse(line, nullptr, false);
    return !j.is_discarded() && j.is_object();
  }
  return false;
}

}  // namespace

std::vector<BatchEntry> read_query_file(const std::filesystem::path& path) {
  // The whole file under the batch limit (a larger one is refused naming that
  // limit, not read in part), in a buffer of its own size.
  const FileBytes bytes = read_input_file(path, input_limits().batch_bytes);
  if (bytes.view().find_first_not_of(" \t\r\n") == std::string_view::npos) return {};
  return looks_like_batch(bytes.view()) ? read_query_batch(path) : read_single_query(path);
}

std::string query_id_list(const std::vector<BatchEntry>& entries, std::size_t most) {
  std::string out;
  for (std::size_t i = 0; i < entries.size() && i < most; ++i)
    out += fmt::format("{}\"{}\"", out.empty() ? "" : ", ", entries[i].id);
  if (entries.size() > most) out += fmt::format(", ... ({} more)", entries.size() - most);
  return out;
}

Query select_query(const std::vector<BatchEntry>& entries, const std::string& id,
                   const std::filesystem::path& path) {
  const std::string source = path.string();
  if (entries.empty()) throw InputError(source, 0, "holds no query");
  const BatchEntry* picked = nullptr;
  if (id.empty()) {
    if (entries.size() > 1)
      throw InputError(source, 0,
                       fmt::format("holds {} queries (ids {}); pick one with --id ID",
                                   entries.size(), query_id_list(entries)));
    picked = &entries.front();
  } else {
    std::size_t matches = 0;
    for (const BatchEntry& e : entries)
      if (e.id == id) {
        if (!picked) picked = &e;
        ++matches;
      }
    if (matches == 0)
      throw InputError(source, 0,
                       fmt::format("no query with id \"{}\" (--id); the ids it holds: {}", id,
                                   query_id_list(entries)));
    if (matches > 1)
      throw InputError(source, 0,
                       fmt::format("holds {} queries with id \"{}\" (--id): give them distinct ids",
                                   matches, id));
  }
  if (!picked->query) {
    if (picked->failure) throw *picked->failure;
    throw InputError(source, 0, picked->error);
  }
  return *picked->query;
}

}  // namespace mocap
