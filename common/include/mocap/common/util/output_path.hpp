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
//  - a regular file of another kind: refused unless `force`;
//  - a file the command reads (an index, a collection's manifest or any of
//    its shards, a query or results file): refused, even with `force`.
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
  glb,    // glTF 2.0 binary: bytes starting with "glTF"
  npz,    // NumPy .npz, a zip archive: bytes starting with "PK\3\4" (or "PK\5\6", empty)
};
/// "index (HDF5)", "BVH", "JSON", "JSON lines", "HTML", "glTF binary", "NumPy .npz".
const char* output_kind_name(OutputKind kind);

/// True when the first bytes `head` of a file look like `kind` (leading
/// white space skipped for the text kinds, not for glb and npz).
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

/// check_distinct_outputs of `outputs`, then: no output is a file the command
/// reads, whatever --force says. `inputs` are (option, path) pairs (empty
/// paths skipped); an input that is a collection manifest stands for itself
/// and each of its shards. Throws InputError(output's option, 0, "PATH is the
/// file --index (shard 2 of 3 of col.json) reads: ..."). Call it before any
/// work (docs/cli.md "Output paths").
void check_outputs_and_inputs(
    const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
    const std::vector<std::pair<std::string, std::filesystem::path>>& inputs);

}  // namespace mocap
