#pragma once
// Capture collections: the inputs of the indexer.
//
// An input is a folder (searched recursively for *.bvh and *.amc,
// case-insensitive,
// symlinks followed but each folder entered once by its canonical path, so a
// link loop ends; hidden entries skipped; unreadable folders and .bvh
// entries that are not regular files reported as problems), a .bvh or .amc
// file, or a list file
// (any other extension, e.g. .txt/.lst: one path per line, '#' comments,
// blank lines ignored, relative paths resolved against the list's folder).
// `.asf` files (the skeletons of AMC takes, asf_pairing.hpp) are never clips:
// ignored in folders, as inputs and in list files.
// The result is sorted by path and de-duplicated so that a build is
// deterministic whatever the file system's order.
#include <filesystem>
#include <string>
#include <vector>

namespace mocap {

struct CollectionEntry {
  std::filesystem::path path;
};

struct CollectionProblem {
  std::string input;   // the input as given
  std::string reason;  // e.g. "no such file or directory"
};

struct Collection {
  std::vector<CollectionEntry> files;
  std::vector<CollectionProblem> problems;
};

/// Expands inputs into clip files (.bvh, .amc). Missing inputs and unreadable list files are
/// reported in `problems`, never thrown.
Collection list_collection(const std::vector<std::string>& inputs);

}  // namespace mocap
