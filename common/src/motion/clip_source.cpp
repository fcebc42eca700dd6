// One index or a collection's shards, numbered as one index (clip_source.hpp).
#include "mocap/common/motion/clip_source.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

ClipSource::ClipSource(const Index& index) : path_(index.path()) {
  shards_.push_back({&index, 0, {}});
  number();
}

ClipSource::ClipSource(ClipSource&&) noexcept = default;
ClipSource& ClipSource::operator=(ClipSource&&) noexcept = default;
ClipSource::~ClipSource() = default;

ClipSource ClipSource::open(const std::filesystem::path& path) {
  ClipSource s;
  s.path_ = path;
  if (!is_collection_manifest(path)) {
    s.owned_.push_back(std::make_unique<const Index>(Index::open(path)));
    s.shards_.push_back({s.owned_.back().get(), 0, {}});
    s.number();
    return s;
  }
  // Every shard as the manifest says before any is read (the search's
  // check, collection_search.hpp), then its clip count against the manifest's:
  // the numbering depends on it.
  const CollectionManifest m = read_collection_manifest(path);
  if (const auto problems = collection_shard_problems(path, m); !problems.empty())
    throw InputError(path.string(), 0, problems.front());
  s.collection_ = true;
  for (const CollectionShard& shard : m.shards) {
    auto index = std::make_unique<const Index>(Index::open(shard_file(path, shard)));
    if (const std::string p =
            shard_count_problem(shard, index->clips().size(), index->frame_count());
        !p.empty())
      throw InputError(path.string(), 0, p);
    s.shards_.push_back({index.get(), 0, {}});
    s.owned_.push_back(std::move(index));
  }
  s.number();
  return s;
}

// Clips: consecutive over the shards. Skeletons: an index numbers its
// skeletons by first appearance over its clips in order (the writer's
// slot_for by IndexSkeleton::id), so walking the shards in order and each
// shard's skeletons in its own order, and keeping the first of each id,
// numbers them as one index of all the clips would.
void ClipSource::number() {
  std::map<std::uint64_t, std::uint32_t> by_id;
  clip_count_ = 0;
  skeletons_.clear();
  for (std::size_t k = 0; k < shards_.size(); ++k) {
    Shard& s = shards_[k];
    s.first_clip = clip_count_;
    s.skeleton_numbers.clear();
    const auto& tables = s.index->skeletons();
    for (std::uint32_t local = 0; local < tables.size(); ++local) {
      auto [it, added] =
          by_id.try_emplace(tables[local].id, static_cast<std::uint32_t>(skeletons_.size()));
      if (added) skeletons_.push_back({k, local, {}});
      s.skeleton_numbers.push_back(it->second);
    }
    const auto& clips = s.index->clips();
    for (std::size_t c = 0; c < clips.size(); ++c)
      skeletons_[s.skeleton_numbers.at(clips[c].skeleton)].clips.push_back(clip_count_ + c);
    clip_count_ += clips.size();
  }
}

ClipSource::Location ClipSource::locate(std::size_t c) const {
  if (c >= clip_count_)
    throw std::out_of_range("ClipSource: clip " + std::to_string(c) + " of " +
                            std::to_string(clip_count_));
  // The last shard whose first clip is at or before c: it holds c (an
  // empty shard before it has the same first clip as the next one).
  const auto it = std::upper_bound(shards_.begin(), shards_.end(), c,
                                   [](std::size_t v, const Shard& s) { return v < s.first_clip; });
  const auto k = static_cast<std::size_t>(std::prev(it) - shards_.begin());
  return {shards_[k].index, c - shards_[k].first_clip, k};
}

const IndexClip& ClipSource::clip(std::size_t c) const {
  const Location at = locate(c);
  return at.index->clips()[at.clip];
}

std::uint32_t ClipSource::skeleton_of(std::size_t c) const {
  const Location at = locate(c);
  return shards_[at.shard].skeleton_numbers[at.index->clips()[at.clip].skeleton];
}

const IndexSkeleton& ClipSource::skeleton(std::uint32_t k) const {
  const SourceSkeleton& s = skeletons_.at(k);
  return shards_[s.shard].index->skeletons()[s.local];
}

const std::vector<std::size_t>& ClipSource::skeleton_clips(std::uint32_t k) const {
  return skeletons_.at(k).clips;
}

DynamicsModel ClipSource::dynamics_model(std::uint32_t k) const {
  const SourceSkeleton& s = skeletons_.at(k);
  return shards_[s.shard].index->dynamics_model(s.local);
}

std::span<const float> ClipSource::clip_frames(std::size_t c, std::string_view field) const {
  const Location at = locate(c);
  return at.index->clip_frames(at.clip, field);
}

std::span<const float> ClipSource::clip_bounds_row(std::size_t c, std::string_view field) const {
  const Location at = locate(c);
  const IndexClip& clip = at.index->clips()[at.clip];
  return at.index->array(clip.skeleton, "clip_bounds", field).rows_f32(clip.row, 1);
}

}  // namespace mocap
