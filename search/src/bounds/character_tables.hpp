#pragma once
// Internal to mocap_search: per-skeleton tables for a query character other
// than the index's (Query::character). The engine's tables hold the index's
// character; a query naming another one gets tables recomputed from the
// stored world poses with the character's bone lengths and body (the same
// arithmetic as the indexer's), built once per engine and character (at most
// 4 characters kept) and shared by the queries that name it.
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "bounds/skeleton_tables.hpp"
#include "mocap/common/body/body.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/search/query.hpp"

namespace mocap::search_detail {

// The tables of one query character, one SkeletonData per index skeleton.
struct CharacterTables {
  std::once_flag once;
  std::vector<std::unique_ptr<SkeletonData>> skeletons;
  // Set when the tables could not be built (every query naming the
  // character fails with it).
  std::string build_error;
};

class CharacterTableCache {
 public:
  // Reads the index's character (its `character` attribute: the indexer's
  // canonical form or a character file's form); when neither parses, every
  // query character gets its own tables.
  explicit CharacterTableCache(const Index& index);

  // The tables of q's character, built on first use; null when q names no
  // character or the index's own (the engine's tables serve). The pointer
  // keeps them alive. Throws InputError("query <id>") when the character file
  // cannot be read or is invalid, or its tables cannot be built.
  // Thread-safe.
  std::shared_ptr<const CharacterTables> tables_for(const Query& q) const;

 private:
  const Index* index_;
  std::optional<Character> index_character_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, std::shared_ptr<CharacterTables>> entries_;
};

}  // namespace mocap::search_detail
