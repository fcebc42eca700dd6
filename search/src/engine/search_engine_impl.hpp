#pragma once
// Internal to mocap_search: the state of a SearchEngine (search.hpp), shared
// read-only by its queries (the caches inside are thread-safe).
#include <tbb/enumerable_thread_specific.h>
#include <map>
#include <mutex>

#include <memory>
#include <vector>

#include "bounds/character_tables.hpp"
#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/search.hpp"
#include "query/resolved_frame.hpp"

namespace mocap {

struct SearchEngine::Impl {
  explicit Impl(const Index& engine_index) : index(&engine_index), characters(engine_index) {}
  const Index* index = nullptr;
  double t_index = 0.5;  // the index's transition time (s): kd features
  // The index character's tables, one per index skeleton.
  std::vector<std::unique_ptr<search_detail::SkeletonData>> skeletons;
  // Label columns of Index::label_keys() for query filters, -1 if absent.
  int content_key = -1, style_key = -1;
  // The label values filters are checked against (the index's, or its
  // collection's) and what messages call their holder.
  LabelValues filter_labels;
  std::string filter_labels_of = "the index";
  mutable search_detail::BvhCache bvh_cache;
  search_detail::CharacterTableCache characters;
  // Per-thread scratch, used only between blocking points (no task of
  // another query can run on the thread while a reference to it is held).
  mutable tbb::enumerable_thread_specific<search_detail::Scratch> scratch;
  // Per style model (SearchOptions::style_model): every clip's style
  // probabilities (clip_style_probabilities), computed on the first query
  // that asks for a style, then shared.
  mutable std::mutex style_mutex;
  // (The model is kept with its probabilities: the key stays its own.)
  struct ClipStyles {
    std::shared_ptr<const StyleModel> model;
    std::shared_ptr<const std::vector<std::vector<double>>> probabilities;
  };
  mutable std::map<const StyleModel*, ClipStyles> clip_styles;
};

}  // namespace mocap
