#pragma once
// Internal to mocap_search: the order of a pair's results (docs/queries.md
// "Ranking"). The engine finds the best matches by score (ties: the clip
// index, then the end and start frames); a pair whose query frames carry
// named constraints is then ranked by its verdicts too:
//  - MetPolicy::first: results meeting every named constraint first;
//    MetPolicy::only: the others dropped; MetPolicy::any: neither;
//  - then the score, then the misfit (SearchResult::misfit: equal scores,
//    the result nearer the request first), then clip index, end, start.
// Without named constraints every result is met with misfit 0: the order is
// the engine's.
#include <cstddef>
#include <vector>

#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"

namespace mocap::search_detail {

// Whether x ranks before y under `policy` (a strict weak order; a total
// order on results of distinct clips).
bool ranks_before(const SearchResult& x, const SearchResult& y, MetPolicy policy);

// Sorts `results` in that order, drops the unmet ones under MetPolicy::only,
// keeps the first `top` and numbers their ranks from 1.
void rank_results(std::vector<SearchResult>& results, MetPolicy policy, std::size_t top);

// Whether the best `top` results under `policy` are certainly among
// `fetched`: the best `asked` matches of the pair by score (any order). True
// when fewer than `asked` came back (every match is there), or when the
// `top`-th result the ranking needs (under first and only: the top-th met
// one; under any: the top-th) scores below the worst fetched match, which
// every match not fetched scores at or above.
bool ranking_settled(const std::vector<SearchResult>& fetched, std::size_t asked, MetPolicy policy,
                     std::size_t top);

// The deepest look of a pair ranked by its verdicts: the best
// max(32 * top, 256) matches by score. A pair with fewer results meeting
// the request among them ranks them as if no more existed (docs/queries.md).
std::size_t deepest_look(std::size_t top);

}  // namespace mocap::search_detail
