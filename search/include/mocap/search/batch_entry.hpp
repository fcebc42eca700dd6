#pragma once
// One entry of a query batch from the text of one query: what
// read_query_batch (search.hpp) makes of each line of a JSONL batch, and the
// Python module of each query it is given.
#include <cstddef>
#include <filesystem>
#include <string>

#include "mocap/search/search.hpp"

namespace mocap {

/// Parses `text` (one JSON query object) into a batch entry: the query and
/// its id (`default_id` when the query has none), or, when the text is not a
/// valid query, the InputError's message (source:line: what) in `error` and
/// the id the text gives when it is a JSON object with a string or integer
/// "id" (else `default_id`). `base_dir` resolves relative "bvh" and
/// "character" paths. Never throws InputError.
BatchEntry parse_batch_entry(const std::string& text, const std::string& source, std::size_t line,
                             const std::filesystem::path& base_dir, const std::string& default_id);

}  // namespace mocap
