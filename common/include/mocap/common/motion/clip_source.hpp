#pragma once
// Where synthesis reads its clips: one index, or the shards of a collection
// (docs/index-format.md "Collections") numbered as one index of the same
// files would number them. Synthesis addresses clips and skeletons by those
// numbers only (the search's clip_index, REPORT.json's skeleton), so the
// same query over a collection and over one index of its files gives the
// same motion (docs/synthesis.md "Collections").
//
// Numbering:
//   clip c of shard k          -> clip (clips of shards 0..k-1) + c
//   skeleton of a clip         -> order of first appearance of its
//                                 IndexSkeleton::id over the clips in order
//                                 (the index writer's rule: IndexWriter::slot_for)
// For one index both are the identity.
//
// Every shard is opened (metadata only: the clip and skeleton tables); a
// shard's per-frame arrays are read only when a clip of it is read (Index
// loads arrays on first use), so only the shards that hold the chosen clips
// load frames. The range of motion reads every shard's clip_bounds of the
// target skeleton (small: one row per clip).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "mocap/common/io/index.hpp"

namespace mocap {

class ClipSource {
 public:
  /// A clip's place: its index (a shard, or the one index), its number
  /// there, and the index's position among index(k).
  struct Location {
    const Index* index = nullptr;
    std::size_t clip = 0;
    std::size_t shard = 0;
  };

  /// One open index (not owned: it must outlive the source). Implicit: a
  /// function taking a ClipSource takes an Index as it is.
  ClipSource(const Index& index);

  /// Opens an index file, or every shard of a collection manifest (its first
  /// non-blank byte is '{'). A collection's shards are checked first: a
  /// missing, unreadable or changed shard (collection_shard_problems), or one
  /// holding another number of clips than the manifest says, throws
  /// InputError(manifest, 0, "shard PATH: ...") naming it.
  static ClipSource open(const std::filesystem::path& path);

  ClipSource(ClipSource&&) noexcept;
  ClipSource& operator=(ClipSource&&) noexcept;
  ~ClipSource();

  /// The index file or the manifest, as given.
  const std::filesystem::path& path() const { return path_; }
  /// True when the source is a collection manifest's shards.
  bool is_collection() const { return collection_; }
  /// The indexes in order (one for an index file; the shards of a collection).
  std::size_t index_count() const { return shards_.size(); }
  const Index& index(std::size_t k) const { return *shards_.at(k).index; }

  std::size_t clip_count() const { return clip_count_; }
  /// Where clip c is. std::out_of_range for c >= clip_count().
  Location locate(std::size_t c) const;
  /// Clip c's record in its own index: path, frames, frame time, labels;
  /// its `skeleton`, `row` and frame / block starts are that index's
  /// (skeleton_of gives the source's skeleton number).
  const IndexClip& clip(std::size_t c) const;
  /// The source's number of clip c's skeleton.
  std::uint32_t skeleton_of(std::size_t c) const;

  std::size_t skeleton_count() const { return skeletons_.size(); }
  /// Skeleton k's table, as the first index holding it stores it (the same
  /// skeleton, body and segments in every index: one IndexSkeleton::id);
  /// its `clips` and frame / block counts are that index's own, see
  /// skeleton_clips for the source's.
  const IndexSkeleton& skeleton(std::uint32_t k) const;
  /// The clips of skeleton k (source numbers, ascending).
  const std::vector<std::size_t>& skeleton_clips(std::uint32_t k) const;
  /// Skeleton k's dynamics model for the index's character
  /// (Index::dynamics_model of the first index holding it).
  DynamicsModel dynamics_model(std::uint32_t k) const;

  /// Clip c's rows of a per-frame f32 field (Index::clip_frames in its own
  /// index; the first read loads that index's array).
  std::span<const float> clip_frames(std::size_t c, std::string_view field) const;
  /// Clip c's row of a clip_bounds f32 field (one row, row_elements values).
  std::span<const float> clip_bounds_row(std::size_t c, std::string_view field) const;

 private:
  struct Shard {
    const Index* index = nullptr;
    std::size_t first_clip = 0;
    /// The source's skeleton number of each of the index's skeletons.
    std::vector<std::uint32_t> skeleton_numbers;
  };
  struct SourceSkeleton {
    std::size_t shard = 0;  // first index holding it
    std::uint32_t local = 0;
    std::vector<std::size_t> clips;
  };

  ClipSource() = default;
  /// Numbers the clips and skeletons of shards_ (their `index` set).
  void number();

  std::filesystem::path path_;
  bool collection_ = false;
  std::vector<std::unique_ptr<const Index>> owned_;
  std::vector<Shard> shards_;
  std::vector<SourceSkeleton> skeletons_;
  std::size_t clip_count_ = 0;
};

}  // namespace mocap
