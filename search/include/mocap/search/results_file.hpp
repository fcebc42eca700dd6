#pragma once
// Reading mocap-search's results files (JSON lines; docs/cli.md
// "mocap-search"): one query's line (what mocap-synth --results reads), or
// every line (the player page of mocap-search --html and view). Results are
// checked against the clips they name: a collection's results number clips
// as one index of its files would (mocap/common/motion/clip_source.hpp).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

/// The pairs of the line whose "id" is `query_id` (the results as
/// SearchEngine::run gives them; their labels are not read). InputError
/// (file:line) for unreadable files (or one over the batch size limit), bad
/// JSON, a missing id, an error line, or results that do not fit `clips`
/// (unknown clip, frames out of range).
std::vector<PairResults> read_search_results(const std::filesystem::path& path,
                                             const std::string& query_id, const ClipSource& clips);
/// The same, with the 1-based line of the file that holds them (for messages
/// about a pair or a rank of that line).
struct SearchResultsLine {
  std::size_t line = 0;
  std::vector<PairResults> pairs;
};
SearchResultsLine read_search_results_line(const std::filesystem::path& path,
                                           const std::string& query_id, const ClipSource& clips);

/// The results of every line of a results file, checked against `clips` as
/// read_search_results checks one line. Lines with "error" are kept with
/// their message and no pairs.
struct ResultsLine {
  std::string id;
  std::string error;
  std::vector<PairResults> pairs;
};
std::vector<ResultsLine> read_results_file(const std::filesystem::path& path,
                                           const ClipSource& clips);

}  // namespace mocap
