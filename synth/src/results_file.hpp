// Reading mocap-search's results files (JSON lines; docs/cli.md
// "mocap-search"), private to synth/src: read_search_results (one query's
// line, synth_job.hpp) and read_results_file (every line, player.hpp).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mocap/search/search.hpp"
#include "mocap/synth/clip_source.hpp"

namespace mocap::synth_detail {

/// Calls `line(j, n)` for each non-blank line in order (n: 1-based line
/// number) until it returns false. Throws InputError(path, ...) for an
/// unreadable file (or one over the batch size limit), invalid JSON, or a
/// line that is not an object with a string "id".
void read_results_lines(const std::filesystem::path& path,
                        const std::function<bool(const nlohmann::json&, std::size_t)>& line);

/// The "pairs" of results line `j` (line n of `path`), checked against
/// `clips`: every clip_index names a clip of that path (or base name) and
/// start < end < its frame count; InputError(path, n, ...) otherwise.
std::vector<PairResults> parse_result_pairs(const nlohmann::json& j, const std::string& path,
                                            std::size_t n, const ClipSource& clips);

}  // namespace mocap::synth_detail
