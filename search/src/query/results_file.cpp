// Reading mocap-search's results files (mocap/search/results_file.hpp).
#include "mocap/search/results_file.hpp"

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/json_text.hpp"

namespace mocap {
namespace {

std::string base_name(const std::string& path) {
  const auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

// Calls `line(j, n)` for each non-blank line in order (n: 1-based line
// number) until it returns false. Throws InputError(path, ...) for an
// unreadable file (or one over the batch size limit), invalid JSON, or a
// line that is not an object with a string "id".
void read_results_lines(const std::filesystem::path& path,
                        const std::function<bool(const nlohmann::json&, std::size_t)>& line) {
  std::optional<FileBytes> bytes;
  try {
    bytes = read_input_file(path, input_limits().batch_bytes);
  } catch (const InputError& e) {
    throw InputError(path.string(), 0, "cannot read the search results: " + e.detail());
  }
  for_each_line(bytes->view(), [&](std::string_view text, std::size_t n) {
    if (text.find_first_not_of(" \t\r") == std::string_view::npos) return true;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string(), n, std::string("invalid JSON: ") + e.what());
    }
    if (!j.is_object() || !j.contains("id") || !j["id"].is_string())
      throw InputError(path.string(), n, "expected an object with a string \"id\"");
    return line(j, n);
  });
}

// A result's "verdicts" (docs/queries.md "Residuals and verdicts") back
// into its residuals, tolerances and units; json exceptions for a malformed one.
void read_verdicts(const nlohmann::json& v, SearchResult& r) {
  for (const char* side : {"from", "to"}) {
    if (!v.contains(side)) continue;
    for (const auto& [name, c] : v.at(side).items())
      (side[0] == 'f' ? r.residuals_from : r.residuals_to)
          .push_back({name, c.at("residual").get<double>(), c.at("tolerance").get<double>(),
                      c.at("unit").get<std::string>() == "m"});
  }
}

// The "pairs" of results line `j` (line n of `path`), checked against
// `clips`: every clip_index names a clip of that path (or base name) and
// start < end < its frame count; InputError(path, n, ...) otherwise.
std::vector<PairResults> parse_result_pairs(const nlohmann::json& j, const std::string& path,
                                            std::size_t n, const ClipSource& clips) {
  if (!j.contains("pairs") || !j["pairs"].is_array())
    throw InputError(path, n, "pairs: expected an array");
  std::vector<PairResults> pairs;
  try {
    for (const auto& jp : j["pairs"]) {
      PairResults p;
      p.from = jp.at("from").get<std::size_t>();
      p.to = jp.at("to").get<std::size_t>();
      for (const auto& jr : jp.at("results")) {
        SearchResult r;
        r.rank = jr.at("rank").get<std::size_t>();
        r.clip_index = jr.at("clip_index").get<std::size_t>();
        r.clip = jr.at("clip").get<std::string>();
        r.start_frame = jr.at("start_frame").get<std::size_t>();
        r.end_frame = jr.at("end_frame").get<std::size_t>();
        r.score_J = jr.value("score_J", 0.0);
        r.h_in_J = jr.value("h_in_J", 0.0);
        r.h_out_J = jr.value("h_out_J", 0.0);
        r.path_cost_J = jr.value("path_cost_J", 0.0);
        r.context = jr.contains("context_in_J") || jr.contains("context_out_J");
        r.context_in_J = jr.value("context_in_J", 0.0);
        r.context_out_J = jr.value("context_out_J", 0.0);
        r.style = jr.contains("style_J");
        r.style_J = jr.value("style_J", 0.0);
        if (jr.contains("verdicts")) read_verdicts(jr.at("verdicts"), r);
        if (r.clip_index >= clips.clip_count() ||
            (clips.clip(r.clip_index).path != r.clip &&
             base_name(clips.clip(r.clip_index).path) != base_name(r.clip)))
          throw InputError(path, n,
                           "unknown clip \"" + r.clip + "\" (clip_index " +
                               std::to_string(r.clip_index) + ") in " +
                               (clips.is_collection() ? "collection " : "index ") +
                               clips.path().string());
        const std::size_t fc = clips.clip(r.clip_index).frame_count;
        if (!(r.start_frame < r.end_frame && r.end_frame < fc))
          throw InputError(path, n,
                           "frames " + std::to_string(r.start_frame) + ".." +
                               std::to_string(r.end_frame) + " out of range for \"" + r.clip +
                               "\" (" + std::to_string(fc) + " frames)");
        p.results.push_back(std::move(r));
      }
      pairs.push_back(std::move(p));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, n, std::string("pairs: ") + e.what());
  }
  return pairs;
}

}  // namespace

std::vector<PairResults> read_search_results(const std::filesystem::path& path,
                                             const std::string& query_id, const ClipSource& clips) {
  return read_search_results_line(path, query_id, clips).pairs;
}

SearchResultsLine read_search_results_line(const std::filesystem::path& path,
                                           const std::string& query_id, const ClipSource& clips) {
  std::vector<std::string> ids;
  std::optional<SearchResultsLine> found;
  read_results_lines(path, [&](const nlohmann::json& j, std::size_t n) {
    const std::string id = j["id"].get<std::string>();
    ids.push_back(id);
    if (id != query_id) return true;
    if (j.contains("error"))
      throw InputError(path.string(), n,
                       "the search failed for this query: " + json_text(j["error"]));
    found = SearchResultsLine{n, parse_result_pairs(j, path.string(), n, clips)};
    return false;
  });
  if (found) return std::move(*found);
  std::string known;
  for (const auto& i : ids) known += (known.empty() ? "" : ", ") + i;
  throw InputError(path.string(), 0,
                   "no results for query \"" + query_id +
                       "\" (ids in the file: " + (known.empty() ? "none" : known) + ")");
}

std::vector<ResultsLine> read_results_file(const std::filesystem::path& path,
                                           const ClipSource& clips) {
  std::vector<ResultsLine> out;
  read_results_lines(path, [&](const nlohmann::json& j, std::size_t n) {
    ResultsLine r;
    r.id = j["id"].get<std::string>();
    if (j.contains("error"))
      r.error = j["error"].is_string() ? j["error"].get<std::string>() : json_text(j["error"]);
    else
      r.pairs = parse_result_pairs(j, path.string(), n, clips);
    out.push_back(std::move(r));
    return true;
  });
  return out;
}

}  // namespace mocap
