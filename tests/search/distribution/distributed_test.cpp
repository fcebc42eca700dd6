// The MPI-free parts of a distributed search (search/include/mocap/search/distributed.hpp).
// The MPI runs themselves are checked end to end by tests/cli/mpi.sh.
#include "mocap/search/distributed.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace mocap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

CollectionManifest manifest_of(const std::vector<std::uint64_t>& frames) {
  CollectionManifest m;
  for (std::size_t k = 0; k < frames.size(); ++k)
    m.shards.push_back({"s" + std::to_string(k) + ".h5", 10, frames[k], "0000000000000000"});
  return m;
}

QueryOutcome outcome_with_scores(const std::string& id, const std::vector<double>& scores) {
  QueryOutcome o;
  o.id = id;
  PairResults p;
  p.from = 0;
  p.to = 1;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    SearchResult r;
    r.rank = i + 1;
    r.clip_index = 100 + i;
    r.clip = "/data/clip " + std::to_string(i) + " \xc3\xa9.bvh";
    r.labels = {{"content", "walk"}, {"style", "happy"}};
    r.start_frame = i;
    r.end_frame = i + 7;
    r.score_J = scores[i];
    r.h_in_J = scores[i] / 3;
    r.h_out_J = scores[i] / 7;
    r.path_cost_J = 0.1 + i;
    p.results.push_back(r);
  }
  o.pairs.push_back(p);
  o.stats.clips = 12;
  o.stats.clips_pruned = 5;
  o.stats.frames_evaluated = 123456789012ULL;
  o.stats.frames_pruned = 7;
  o.stats.time_ms = 1.0 / 3.0;
  return o;
}

TEST(Distributed, InvalidInputs) {
  EXPECT_THROW(assign_shards(manifest_of({1, 2}), 0), std::invalid_argument);
  EXPECT_THROW(decode_outcomes("not cbor at all"), std::invalid_argument);
  EXPECT_THROW(decode_outcomes(""), std::invalid_argument);
  EXPECT_THROW(decode_label_values("not cbor at all"), std::invalid_argument);
  EXPECT_THROW(decode_label_values(""), std::invalid_argument);
  EXPECT_THROW(decode_label_values(encode_outcomes({})), std::invalid_argument);  // an array
  EXPECT_FALSE(parse_distribution("auto"));
  EXPECT_FALSE(parse_distribution("Shards"));
  EXPECT_EQ(parse_distribution("shards"), Distribution::shards);
  EXPECT_EQ(parse_distribution("queries"), Distribution::queries);
}

TEST(Distributed, ShardsAreDealtByFramesLargestFirst) {
  // 100, 90, 60, 50, 10 over 2 ranks: 100 -> r0, 90 -> r1, 60 -> r1 (90 < 100),
  // 50 -> r0 (100 < 150), 10 -> r0 (150 = 150: the lower rank).
  const auto a = assign_shards(manifest_of({60, 100, 10, 90, 50}), 2);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0], (std::vector<std::size_t>{1, 2, 4}));  // manifest order within a rank
  EXPECT_EQ(a[1], (std::vector<std::size_t>{0, 3}));
  // Every shard exactly once, for any rank count; a rank may be left without one.
  for (std::size_t ranks = 1; ranks <= 7; ++ranks) {
    const auto b = assign_shards(manifest_of({5, 4, 3, 2, 1}), ranks);
    std::vector<int> seen(5, 0);
    std::size_t empty = 0;
    for (const auto& r : b) {
      empty += r.empty();
      for (std::size_t s : r) ++seen[s];
    }
    for (int c : seen) EXPECT_EQ(c, 1);
    EXPECT_EQ(empty, ranks > 5 ? ranks - 5 : 0u);
  }
}

TEST(Distributed, AutoRuleChoosesQueriesWhenTheCollectionFitsEveryRank) {
  const std::uint64_t gib = std::uint64_t{1} << 30;
  // A plain index, or fewer shards than ranks: queries.
  EXPECT_EQ(choose_distribution(1'000'000'000, 1, 4, 4, gib), Distribution::queries);
  EXPECT_EQ(choose_distribution(1'000'000'000, 2, 4, 4, gib), Distribution::queries);
  // Set 2 (385k frames) on 2 ranks of a 24 GiB node: fits, queries.
  EXPECT_EQ(choose_distribution(384'931, 2, 2, 2, 24 * gib), Distribution::queries);
  // 8x set 2 with 4 ranks on that node: 3.08 M x 4.5 kB x 4 = 55 GB > 12 GiB: shards.
  EXPECT_EQ(choose_distribution(3'079'448, 4, 4, 4, 24 * gib), Distribution::shards);
  // The boundary: need <= half the memory.
  const std::uint64_t frames = 1000;
  const std::uint64_t need = frames * kSearchResidentBytesPerFrame * 2;
  EXPECT_EQ(choose_distribution(frames, 2, 2, 2, 2 * need), Distribution::queries);
  EXPECT_EQ(choose_distribution(frames, 2, 2, 2, 2 * need - 1), Distribution::shards);
  // No overflow for a billion frames on a thousand ranks per node.
  EXPECT_EQ(choose_distribution(1'000'000'000'000ULL, 1000, 1000, 1000, 64 * gib),
            Distribution::shards);
}

TEST(Distributed, RthBestScores) {
  const QueryOutcome o = outcome_with_scores("q", {1.0, 2.0, 3.0});
  EXPECT_EQ(rth_best_scores(o, 2), std::vector<double>{2.0});
  EXPECT_EQ(rth_best_scores(o, 3), std::vector<double>{3.0});
  EXPECT_EQ(rth_best_scores(o, 4), std::vector<double>{kInf});  // fewer than r
  EXPECT_EQ(rth_best_scores(o, 0), std::vector<double>{kInf});
  QueryOutcome failed;
  failed.error = "no";
  EXPECT_TRUE(rth_best_scores(failed, 3).empty());
}

TEST(Distributed, SharedCeilingKeepsTiesFromOtherRanks) {
  // Own shards' r-th best is exact; another rank's is raised by one ulp, so a
  // result scoring exactly that (which may rank first by clip index) is kept.
  EXPECT_EQ(shared_ceiling(kInf, kInf), kInf);
  EXPECT_EQ(shared_ceiling(2.0, kInf), 2.0);
  EXPECT_EQ(shared_ceiling(kInf, 2.0), std::nextafter(2.0, kInf));
  EXPECT_GT(shared_ceiling(kInf, 2.0), 2.0);
  EXPECT_EQ(shared_ceiling(1.5, 2.0), 1.5);
  EXPECT_EQ(shared_ceiling(2.0, 2.0), 2.0);
  EXPECT_EQ(shared_ceiling(3.0, 2.0), std::nextafter(2.0, kInf));
}

void expect_same(const QueryOutcome& a, const QueryOutcome& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.error, b.error);
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (std::size_t h = 0; h < a.pairs.size(); ++h) {
    EXPECT_EQ(a.pairs[h].from, b.pairs[h].from);
    EXPECT_EQ(a.pairs[h].to, b.pairs[h].to);
    ASSERT_EQ(a.pairs[h].results.size(), b.pairs[h].results.size());
    for (std::size_t i = 0; i < a.pairs[h].results.size(); ++i) {
      const SearchResult &x = a.pairs[h].results[i], &y = b.pairs[h].results[i];
      EXPECT_EQ(x.rank, y.rank);
      EXPECT_EQ(x.clip_index, y.clip_index);
      EXPECT_EQ(x.clip, y.clip);
      EXPECT_EQ(x.labels, y.labels);
      EXPECT_EQ(x.start_frame, y.start_frame);
      EXPECT_EQ(x.end_frame, y.end_frame);
      // Bit for bit: the gather must not round.
      EXPECT_EQ(x.score_J, y.score_J);
      EXPECT_EQ(x.h_in_J, y.h_in_J);
      EXPECT_EQ(x.h_out_J, y.h_out_J);
      EXPECT_EQ(x.path_cost_J, y.path_cost_J);
    }
  }
  EXPECT_EQ(a.stats.clips, b.stats.clips);
  EXPECT_EQ(a.stats.clips_pruned, b.stats.clips_pruned);
  EXPECT_EQ(a.stats.frames_evaluated, b.stats.frames_evaluated);
  EXPECT_EQ(a.stats.frames_pruned, b.stats.frames_pruned);
  EXPECT_EQ(a.stats.time_ms, b.stats.time_ms);
  EXPECT_EQ(a.stats.recall, b.stats.recall);
}

TEST(Distributed, OutcomesRoundTripExactly) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 50.0);
  std::vector<QueryOutcome> all;
  for (int q = 0; q < 20; ++q) {
    std::vector<double> scores;
    for (int i = 0; i < q % 6; ++i) scores.push_back(u(rng));
    all.push_back(outcome_with_scores("q" + std::to_string(q), scores));
  }
  all[3].stats.recall = 0.7;
  QueryOutcome failed;
  failed.id = "bad line";
  failed.error = "q.jsonl:4: frames: expected an array";
  all.push_back(failed);
  all.push_back(QueryOutcome{});  // no pairs, no error, zero stats
  const std::vector<QueryOutcome> back = decode_outcomes(encode_outcomes(all));
  ASSERT_EQ(back.size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i) expect_same(all[i], back[i]);
  EXPECT_TRUE(decode_outcomes(encode_outcomes({})).empty());
}

// The label values every rank sends for the union that filters are checked
// against (ShardHooks::labels).
TEST(Distributed, LabelValuesRoundTrip) {
  const LabelValues values = {{"content", {"bow", "walk", "walk-back"}},
                              {"style", {"happy", "not-confident", "\u00e9l\u00e9gant"}},
                              {"take", {""}}};
  EXPECT_EQ(decode_label_values(encode_label_values(values)), values);
  EXPECT_TRUE(decode_label_values(encode_label_values({})).empty());
}

}  // namespace
}  // namespace mocap
