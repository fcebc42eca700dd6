// The order of a pair's results by verdicts (engine/ranking.hpp,
// docs/queries.md "Residuals and verdicts"): degenerate inputs first, the
// verdict floor, the order under each policy, then the deeper-look rule
// cross-checked against a reference: whenever ranking_settled says the best
// `asked` matches by score suffice, ranking them gives what ranking every
// match gives.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "engine/ranking.hpp"

using namespace mocap;
using search_detail::deepest_look;
using search_detail::rank_results;
using search_detail::ranking_settled;
using search_detail::ranks_before;

namespace {

// A result of clip `clip` scoring `score`; `residual` (degrees) against a
// 10-degree tolerance: met at or below 10.
SearchResult result(std::size_t clip, double score, double residual = 0.0) {
  SearchResult r;
  r.clip_index = clip;
  r.clip = "clip" + std::to_string(clip);
  r.start_frame = 0;
  r.end_frame = 10;
  r.score_J = score;
  r.residuals_to.push_back({"trunk_flexion", residual, 10.0, false});
  return r;
}

std::vector<std::size_t> clips_of(const std::vector<SearchResult>& rs) {
  std::vector<std::size_t> out;
  for (const SearchResult& r : rs) out.push_back(r.clip_index);
  return out;
}

// The engine's order: score, then clip (then end, start).
void engine_order(std::vector<SearchResult>& rs) {
  std::sort(rs.begin(), rs.end(), [](const SearchResult& x, const SearchResult& y) {
    return x.score_J != y.score_J ? x.score_J < y.score_J : x.clip_index < y.clip_index;
  });
}

}  // namespace

TEST(Ranking, DegenerateInputs) {
  std::vector<SearchResult> none;
  rank_results(none, MetPolicy::first, 3);
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(ranking_settled(none, 3, MetPolicy::first, 3));  // fewer than asked: all there
  std::vector<SearchResult> some = {result(0, 1.0), result(1, 2.0)};
  EXPECT_TRUE(ranking_settled(some, 2, MetPolicy::first, 0));  // nothing asked for
  rank_results(some, MetPolicy::any, 0);
  EXPECT_TRUE(some.empty());
  // A result without constraints is met, with misfit 0.
  SearchResult plain;
  EXPECT_TRUE(plain.met());
  EXPECT_EQ(plain.misfit(), 0.0);
  EXPECT_GE(deepest_look(1), 256u);
  EXPECT_EQ(deepest_look(100), 3200u);
}

TEST(Ranking, VerdictFloorAllowsRoundOffOnly) {
  ConstraintResidual exact{"RightHand", 0.009, 0.0, true};
  EXPECT_DOUBLE_EQ(exact.limit(), kMetFloorM);
  EXPECT_TRUE(exact.met());
  exact.residual = 0.011;
  EXPECT_FALSE(exact.met());
  ConstraintResidual angle{"right_knee_flexion", 73.0, 20.0, false};
  EXPECT_DOUBLE_EQ(angle.limit(), 20.0);
  EXPECT_FALSE(angle.met());  // the cookbook kick's rank 3 of old: 73 deg, asked 10 +- 20
  angle.residual = 20.0;
  EXPECT_TRUE(angle.met());
  angle.tolerance = 0.0;
  angle.residual = 0.9;
  EXPECT_DOUBLE_EQ(angle.limit(), kMetFloorDeg);
  EXPECT_TRUE(angle.met());
  // misfit: residual over limit, summed over both frames.
  SearchResult r = result(0, 0.0, 5.0);
  r.residuals_from.push_back({"RightHand", 0.3, 0.15, true});
  EXPECT_DOUBLE_EQ(r.misfit(), 0.5 + 2.0);
  EXPECT_FALSE(r.met());
}

TEST(Ranking, PoliciesOrderMetFirstDropOrIgnore) {
  // clip 0 scores best but misses; clip 1 and 2 tie at 0 J, 2 nearer the target.
  const std::vector<SearchResult> base = {result(0, 0.0, 40.0), result(1, 0.0, 9.0),
                                          result(2, 0.0, 2.0), result(3, 1.0, 0.0),
                                          result(4, 0.5, 30.0)};
  std::vector<SearchResult> any = base, first = base, only = base;
  rank_results(any, MetPolicy::any, 5);
  EXPECT_EQ(clips_of(any), (std::vector<std::size_t>{2, 1, 0, 4, 3}));
  rank_results(first, MetPolicy::first, 5);
  EXPECT_EQ(clips_of(first), (std::vector<std::size_t>{2, 1, 3, 0, 4}));
  rank_results(only, MetPolicy::only, 5);
  EXPECT_EQ(clips_of(only), (std::vector<std::size_t>{2, 1, 3}));
  for (std::size_t i = 0; i < first.size(); ++i) EXPECT_EQ(first[i].rank, i + 1);
  std::vector<SearchResult> two = base;
  rank_results(two, MetPolicy::first, 2);
  EXPECT_EQ(clips_of(two), (std::vector<std::size_t>{2, 1}));
  // Equal score and misfit: the clip, then the end frame.
  SearchResult a = result(5, 1.0, 3.0), b = result(6, 1.0, 3.0);
  EXPECT_TRUE(ranks_before(a, b, MetPolicy::first));
  EXPECT_FALSE(ranks_before(b, a, MetPolicy::first));
  b.clip_index = 5;
  b.end_frame = 9;
  EXPECT_TRUE(ranks_before(b, a, MetPolicy::any));
}

TEST(Ranking, SettledOnlyWhenNoUnfetchedMatchCanEnter) {
  // Ties across the boundary: the third best scores what the fourth does.
  std::vector<SearchResult> tied = {result(0, 0.0), result(1, 0.0), result(2, 0.0)};
  EXPECT_FALSE(ranking_settled(tied, 3, MetPolicy::any, 3));
  EXPECT_FALSE(ranking_settled(tied, 3, MetPolicy::any, 2));  // the worst fetched is 0 too
  tied.push_back(result(3, 1.0));
  EXPECT_TRUE(ranking_settled(tied, 4, MetPolicy::any, 3));
  // Two met among four fetched: the third met one may lie deeper.
  std::vector<SearchResult> few = {result(0, 0.0), result(1, 0.1, 50.0), result(2, 0.2),
                                   result(3, 0.3, 50.0)};
  EXPECT_FALSE(ranking_settled(few, 4, MetPolicy::first, 3));
  EXPECT_FALSE(ranking_settled(few, 4, MetPolicy::only, 3));
  EXPECT_TRUE(ranking_settled(few, 4, MetPolicy::any, 3));
  EXPECT_TRUE(ranking_settled(few, 4, MetPolicy::first, 2));
  EXPECT_TRUE(ranking_settled(few, 5, MetPolicy::first, 3));  // every match fetched
}

// Reference: rank every match; the fast path: rank the best `asked` by the
// engine's order, doubling `asked` until ranking_settled. Equal whenever
// settled (random scores with many ties, random verdicts, every policy).
TEST(Ranking, DeeperLooksEqualRankingEveryMatch) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> score(0, 6), residual(0, 30);
  int settled_early = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<SearchResult> all;
    const std::size_t n = 1 + static_cast<std::size_t>(trial % 40);
    for (std::size_t c = 0; c < n; ++c)
      all.push_back(result(c, score(rng) * 0.5, static_cast<double>(residual(rng))));
    engine_order(all);
    for (const MetPolicy policy : {MetPolicy::any, MetPolicy::first, MetPolicy::only})
      for (const std::size_t top : {1u, 3u, 5u}) {
        std::vector<SearchResult> reference = all;
        rank_results(reference, policy, top);
        for (std::size_t asked = top; asked <= 2 * n + top; asked *= 2) {
          std::vector<SearchResult> fetched(
              all.begin(), all.begin() + static_cast<std::ptrdiff_t>(std::min(asked, all.size())));
          if (!ranking_settled(fetched, asked, policy, top)) continue;
          settled_early += asked < all.size();
          rank_results(fetched, policy, top);
          EXPECT_EQ(clips_of(fetched), clips_of(reference))
              << "trial " << trial << " policy " << met_policy_name(policy) << " top " << top
              << " asked " << asked;
          break;
        }
      }
  }
  EXPECT_GT(settled_early, 100);  // the rule does settle before every match is fetched
}
