#pragma once
// Query files for commands that run one query (mocap-synth --query): a file
// holding one JSON query (read_single_query), or a JSONL batch
// (read_query_batch) from which one query is picked by its id.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

/// Reads `path` as a batch (read_query_batch) when its whole text is not one
/// JSON value and its first non-blank line is a JSON object by itself, else
/// as one query (read_single_query; a JSON syntax error is then that
/// query's). A file of blanks holds no query (no entry). Throws InputError
/// when the file cannot be read at all, exceeds the batch size limit
/// (--max-batch-mib), or holds one query over the --max-json-mib limit.
std::vector<BatchEntry> read_query_file(const std::filesystem::path& path);

/// The query of `entries` (read from `path`) with id `id`, or the only one
/// when `id` is empty. Throws InputError(path, 0, ...) when the file holds
/// no query, several and no `id` is given (the message says how many, lists
/// the first ids and suggests --id), or none or several with `id` (listing
/// the ids it holds); std::runtime_error with the picked entry's own parse
/// error (an InputError's text, naming the file and line) when that query
/// could not be parsed.
Query select_query(const std::vector<BatchEntry>& entries, const std::string& id,
                   const std::filesystem::path& path);

/// The ids of `entries`, quoted, comma-separated, the first `most` of them
/// and then how many more.
std::string query_id_list(const std::vector<BatchEntry>& entries, std::size_t most = 10);

}  // namespace mocap
