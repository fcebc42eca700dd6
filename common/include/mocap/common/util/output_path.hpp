#pragma once
// What a tool may write to (docs/cli.md "Output paths"). Before anything is
// written, an output path is checked:
//  - absent: it is created (its folder too);
//  - a regular file that is empty or of the tool's own kind (OutputKind,
//    recognised by its first bytes): it is replaced, atomically where the
//    tool writes through AtomicFile;
//  - a symbolic link: written through to the file it points to (the link
//    stays a link), under the same rules for that file;
//  - a directory, a device, a FIFO or a socket: refused;
//  - a regular file of another kind: refused unless `force`.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace mocap {

enum class OutputKind {
  index,  // HDF5 (its signature at 0, 512, 1024 ...; or the index's user block)
  bvh,    // text starting with HIERARCHY
  json,   // text starting with { or [
  jsonl,  // text starting with {
  html,   // text starting with <!DOCTYPE html or <html (any case)
};
/// "index (HDF5)", "BVH", "JSON", "JSON lines", "HTML".
const char* output_kind_name(OutputKind kind);

/// True when the first bytes `head` of a file look like `kind` (leading
/// white space skipped for the text kinds).
bool looks_like(OutputKind kind, const std::string& head);

/// The path to replace for output `path` given as `option` (e.g. "--out"):
/// `path`, or the file its symbolic links lead to. Throws
/// InputError(option, 0, ...) naming the path and what it is, for the cases
/// the policy above refuses, and for a chain of more than 40 links.
std::filesystem::path checked_output_path(const std::filesystem::path& path, OutputKind kind,
                                          bool force, const std::string& option);

/// Throws InputError(first option, 0, ...) when two of the (option, path)
/// outputs are one file (after resolving links): "--report is --out".
void check_distinct_outputs(
    const std::vector<std::pair<std::string, std::filesystem::path>>& outputs);

}  // namespace mocap
