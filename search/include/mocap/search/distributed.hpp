#pragma once
// The parts of a distributed search (docs/search.md "Many machines: MPI")
// that do not talk to MPI, so that they are tested without it: which rank
// searches which shards, which distribution a run chooses, the ceilings a
// rank prunes against, and outcomes as bytes for the gather on rank 0.
//
// A run over K ranks distributes either
//  - shards: the collection's shards are dealt to the ranks by frames (the
//    largest first, each to the rank with the fewest frames so far); every
//    rank answers every query on its shards and the top-r lists are merged
//    on rank 0 (merge_shard_outcomes), or
//  - queries: every rank opens the whole index or collection and answers the
//    queries i with i mod K == its rank.
// Either way rank 0's output equals one process's, but for the stats.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/search/query_validation.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

enum class Distribution : std::uint8_t { shards, queries };
const char* distribution_name(Distribution d);
/// "shards", "queries"; nullopt otherwise ("auto" is the caller's).
std::optional<Distribution> parse_distribution(const std::string& s);

/// Resident bytes per indexed frame that the auto rule budgets for one
/// process holding a whole index (docs/performance.md "Search memory").
inline constexpr std::uint64_t kSearchResidentBytesPerFrame = 4500;

/// The auto rule: queries when every rank of a node can hold the whole
/// collection in half the node's memory (frames x
/// kSearchResidentBytesPerFrame x ranks_per_node <= memory / 2), or when
/// there are fewer shards than ranks (ranks would idle); shards otherwise.
/// A plain index (shards = 1) always gives queries. ranks, ranks_per_node >= 1.
Distribution choose_distribution(std::uint64_t frames, std::size_t shards, std::size_t ranks,
                                 std::size_t ranks_per_node, std::uint64_t node_memory_bytes);

/// Deals the manifest's shards to `ranks` ranks by frames (largest first, to
/// the rank with the fewest frames so far, ties to the lower rank and the
/// earlier shard): per rank its shard indices in manifest order (empty for a
/// rank left without one when there are fewer shards than ranks).
/// Throws std::invalid_argument when ranks == 0.
std::vector<std::vector<std::size_t>> assign_shards(const CollectionManifest& manifest,
                                                    std::size_t ranks);

/// The r-th best score of each pair of an outcome, r = top: +inf for a pair
/// with fewer than `top` results (or top = 0) and for a failed query (no pairs).
std::vector<double> rth_best_scores(const QueryOutcome& outcome, std::size_t top);

/// The ceiling a rank prunes pair h against: the least of its own shards'
/// r-th best (`own`, exact: those clips rank before the shard it searches
/// next) and the r-th best that any rank has reported (`shared`, raised by
/// one ulp, since that rank's clips may rank after this one's at an equal
/// score). +inf where neither is known.
double shared_ceiling(double own, double shared);

/// Outcomes as bytes (CBOR: every field of QueryOutcome, doubles exact) and
/// back. decode_outcomes throws std::invalid_argument on bytes it did not
/// write.
std::string encode_outcomes(const std::vector<QueryOutcome>& outcomes);
std::vector<QueryOutcome> decode_outcomes(std::string_view bytes);

/// Label values as bytes (CBOR) and back, for the union of every rank's
/// shards that query filters are checked against when the shards are dealt
/// to the ranks (ShardHooks::labels). decode_label_values throws
/// std::invalid_argument on bytes it did not write.
std::string encode_label_values(const LabelValues& values);
LabelValues decode_label_values(std::string_view bytes);

}  // namespace mocap
