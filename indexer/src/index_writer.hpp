#pragma once
// The index writer: one HDF5 file in the schema of mocap/common/io/index.hpp and
// mocap/common/io/index_tables.hpp, filled clip by clip (in path order) by the build's
// serial stage. Per skeleton it appends the frame, block and clip-bound rows
// as clips arrive (parsed, or copied from the previous index); finish() writes
// the skeleton tables, /clips, /skipped and the root attributes and closes
// the file. Not thread-safe: callers hold h5::library_mutex().
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/indexer/index_builder.hpp"

namespace mocap {

/// The previous index of an incremental build with its datasets opened once
/// (for copying the rows of reused clips).
class PreviousIndex {
 public:
  PreviousIndex(const std::filesystem::path& path, Index index);
  const Index& index() const { return index_; }
  /// /skeletons/<skeleton>/<group>/<field>, opened on first use.
  const h5::Dataset& dataset(std::uint32_t skeleton, const std::string& group, const char* field);

 private:
  Index index_;
  h5::File file_;
  std::unordered_map<std::string, h5::Dataset> open_;
};

struct IndexWriterSlot;

class IndexWriter {
 public:
  /// Creates (truncates) the file at `path` with the index's user block;
  /// frame arrays get deflate `deflate_level` (0 = none), bounds level 4.
  IndexWriter(const std::filesystem::path& path, int deflate_level);
  ~IndexWriter();

  /// The group number of skeleton `s` (by id), its group created on first use.
  std::uint32_t slot_for(const IndexSkeleton& s);
  /// Appends a parsed clip's rows to skeleton clip.skeleton; fills clip.row,
  /// frame_start, frame_count and the block starts. `clip_index`: the clip's
  /// row in /clips.
  void append(IndexClip& clip, std::size_t clip_index, const ClipFrameData& data);
  /// Copies a reused clip's rows (`old`, of the previous index) likewise.
  void copy(IndexClip& clip, std::size_t clip_index, PreviousIndex& previous, const IndexClip& old);
  std::size_t skeleton_count() const { return slots_.size(); }

  /// Writes the skeleton tables, /clips (with label_keys and the clips'
  /// labels parallel to them), /skipped and the root attributes: `info`'s
  /// build parameters, with build_time_utc (now) and the counts filled in
  /// here. Then closes the file.
  void finish(const std::vector<IndexClip>& clips, const std::vector<std::string>& label_keys,
              const std::vector<IndexSkippedFile>& skipped, IndexInfo info);

 private:
  IndexWriterSlot& place(IndexClip& clip, std::size_t clip_index, std::uint64_t frame_count);

  h5::File file_;
  h5::Group skeletons_;
  int deflate_ = 0;
  std::vector<std::unique_ptr<IndexWriterSlot>> slots_;
  std::unordered_map<std::uint64_t, std::uint32_t> by_id_;
};

}  // namespace mocap
