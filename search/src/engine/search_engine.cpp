// The search engine (search.hpp; algorithm and proofs: docs/search.md): its
// construction from an index, SearchEngine::run over a query's pairs
// (query_runner.hpp), and the frame_bounds diagnostics.
#include <fmt/format.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>

#include "bounds/bound_tables.hpp"
#include "bounds/box_bounds.hpp"
#include "bounds/partial_bounds.hpp"
#include "bounds/relative_bounds.hpp"
#include "engine/query_runner.hpp"
#include "engine/ranking.hpp"
#include "engine/search_engine_impl.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/search.hpp"
#include "query/relative_frames.hpp"
#include "scan/frame_energy.hpp"
#include "scan/subtree_kernel.hpp"

namespace mocap {

using search_detail::ClipMatch;
using search_detail::PairRun;
using search_detail::SkeletonData;

const char* search_mode_name(SearchMode m) {
  switch (m) {
    case SearchMode::exact:
      return "exact";
    case SearchMode::approx:
      return "approx";
    case SearchMode::brute:
      return "brute";
  }
  return "?";
}

std::optional<SearchMode> parse_search_mode(const std::string& s) {
  if (s == "exact") return SearchMode::exact;
  if (s == "approx") return SearchMode::approx;
  if (s == "brute") return SearchMode::brute;
  return std::nullopt;
}

void validate_search_options(const SearchOptions& options, const std::string& min_name,
                             const std::string& max_name) {
  if (!(options.max_length_s > 0.0))
    throw InputError(max_name, 0,
                     fmt::format("must be a number of seconds > 0, got {}", options.max_length_s));
  if (!(options.min_length_s > 0.0))
    throw InputError(min_name, 0,
                     fmt::format("must be a number of seconds > 0, got {}", options.min_length_s));
  if (!(options.min_length_s <= options.max_length_s))
    throw InputError(min_name, 0,
                     fmt::format("{} s must not exceed {} ({} s)", options.min_length_s, max_name,
                                 options.max_length_s));
}

SearchEngine::SearchEngine(const Index& index, LabelValues filter_labels) : SearchEngine(index) {
  impl_->filter_labels = std::move(filter_labels);
  impl_->filter_labels_of = "the collection";
}

SearchEngine::SearchEngine(const Index& index) : impl_(std::make_unique<Impl>(index)) {
  Impl& m = *impl_;
  m.t_index = index.info().transition_time_s;
  m.filter_labels = label_values(index);
  for (std::size_t i = 0; i < index.label_keys().size(); ++i) {
    if (index.label_keys()[i] == "content") m.content_key = static_cast<int>(i);
    if (index.label_keys()[i] == "style") m.style_key = static_cast<int>(i);
  }
  // Query frames from indexed, unchanged files: only their +-2 frame window is parsed.
  m.bvh_cache.use_index(index);
  // Per skeleton, this thread reads the index arrays (HDF5, one reader at a
  // time) and a task builds the tables from them, so the next skeleton's
  // reading overlaps this one's building (TBB-parallel inside).
  const std::size_t nk = index.skeletons().size();
  m.skeletons.resize(nk);
  tbb::task_group builds;
  for (std::uint32_t k = 0; k < nk; ++k) {
    const double* prefix = index.array(k, "frames", "energy_prefix_J").f64.data();
    builds.run([&m, &index, k, prefix] {
      m.skeletons[k] = search_detail::build_index_skeleton(index, k, prefix);
    });
  }
  builds.wait();
}

SearchEngine::SearchEngine(SearchEngine&&) noexcept = default;
SearchEngine::~SearchEngine() = default;
const Index& SearchEngine::index() const {
  return *impl_->index;
}

namespace {

// |top-r approx  intersect  top-r exact| / r for one pair, clips compared by index.
double top_r_recall(const PairRun& approx, const PairRun& exact) {
  std::set<std::size_t> exact_clips;
  for (const ClipMatch& m : exact.top) exact_clips.insert(m.clip);
  std::size_t hit = 0;
  for (const ClipMatch& m : approx.top) hit += exact_clips.count(m.clip);
  return exact_clips.empty() ? 1.0
                             : static_cast<double>(hit) / static_cast<double>(exact_clips.size());
}

// Pair h's matches as ranked results, with the clips' paths and labels.
PairResults pair_results(const Index& index, std::size_t h, const PairRun& run) {
  PairResults res;
  res.from = h;
  res.to = h + 1;
  for (std::size_t i = 0; i < run.top.size(); ++i) {
    const ClipMatch& m = run.top[i];
    SearchResult r;
    r.rank = i + 1;
    r.clip_index = m.clip;
    const IndexClip& c = index.clips()[m.clip];
    r.clip = c.path;
    for (std::size_t key = 0; key < index.label_keys().size(); ++key)
      if (!c.labels[key].empty()) r.labels.emplace_back(index.label_keys()[key], c.labels[key]);
    r.start_frame = m.start;
    r.end_frame = m.end;
    r.score_J = m.score;
    r.h_in_J = m.h_in;
    r.h_out_J = m.h_out;
    r.path_cost_J = m.path_cost;
    res.results.push_back(std::move(r));
  }
  return res;
}

void add_stats(SearchStats& total, const SearchStats& run) {
  total.clips += run.clips;
  total.clips_pruned += run.clips_pruned;
  total.frames_evaluated += run.frames_evaluated;
  total.frames_pruned += run.frames_pruned;
}

// The best `top` results of pair h under `policy` among the clips not in
// `exclude`, the frames that miss a named constraint left out or not
// (`require_met`): the engine's best matches by score, looked at deeper
// (twice as many each time, up to deepest_look) until ranking_settled.
// `first`: the run of the query's own top without either, if made.
std::vector<SearchResult> settled_results(const Index& index, search_detail::QueryRunner& runner,
                                          std::size_t h, SearchMode mode, MetPolicy policy,
                                          std::size_t top, bool require_met,
                                          const std::set<std::size_t>& exclude,
                                          const search_detail::PairRun* first, SearchStats& stats) {
  using namespace search_detail;
  runner.set_require_met(require_met);
  for (std::size_t asked = top + exclude.size();;) {
    runner.set_top(asked);
    const bool reuse = first && !require_met && asked == runner.query().top;
    const PairRun run = reuse ? *first : runner.run_pair(h, mode);
    if (!reuse) add_stats(stats, run.stats);
    PairResults res = pair_results(index, h, run);
    runner.add_residuals(res);
    runner.add_context_energies(res);
    runner.add_style_energies(res);
    const std::size_t fetched = res.results.size();
    std::erase_if(res.results,
                  [&](const SearchResult& r) { return exclude.count(r.clip_index) > 0; });
    const std::size_t removed = fetched - res.results.size();
    if (asked >= deepest_look(top) || ranking_settled(res.results, asked - removed, policy, top)) {
      rank_results(res.results, policy, top);
      return std::move(res.results);
    }
    asked = std::min(2 * asked, deepest_look(top));
  }
}

// Pair h's results, ranked (ranking.hpp): by score, or for a pair with
// named constraints by its verdicts too: under "only" the frames that miss
// are left out; under "first" those results come first, then, if fewer than
// top, the other clips' best by score; under "any" the score order with
// ties by misfit.
PairResults ranked_pair(const Index& index, search_detail::QueryRunner& runner, std::size_t h,
                        SearchMode mode, const search_detail::PairRun& first, SearchStats& stats) {
  using namespace search_detail;
  const Query& q = runner.query();
  PairResults res = pair_results(index, h, first);
  runner.add_residuals(res);
  runner.add_context_energies(res);
  runner.add_style_energies(res);
  if (!runner.named_constraints(h)) return res;
  const bool masked = q.met != MetPolicy::any;
  res.results = settled_results(index, runner, h, mode, masked ? MetPolicy::only : MetPolicy::any,
                                q.top, masked, {}, &first, stats);
  if (q.met == MetPolicy::first && res.results.size() < q.top) {
    std::set<std::size_t> clips;
    for (const SearchResult& r : res.results) clips.insert(r.clip_index);
    for (SearchResult& r : settled_results(index, runner, h, mode, MetPolicy::any,
                                           q.top - res.results.size(), false, clips, &first, stats))
      res.results.push_back(std::move(r));
    rank_results(res.results, MetPolicy::first, q.top);
  }
  runner.set_require_met(false);
  runner.set_top(q.top);
  return res;
}

}  // namespace

QueryOutcome SearchEngine::run(const Query& q, const SearchOptions& options) const {
  return run(q, options, nullptr);
}

QueryOutcome SearchEngine::run(const Query& q, const SearchOptions& options,
                               const std::vector<double>* ceilings) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *impl_;
  if (q.frames.size() < 2)
    throw InputError("query " + q.id, 0, "frames: at least 2 query frames are needed");
  validate_search_options(options);
  check_filter_labels(q, m.filter_labels, m.filter_labels_of);
  // The query's character: the index's tables, or tables recomputed for it
  // (built once per engine and character, shared by the queries using it).
  const std::shared_ptr<const search_detail::CharacterTables> character =
      m.characters.tables_for(q);
  const auto& skeletons = character ? character->skeletons : m.skeletons;
  search_detail::QueryRunner runner(m, q, options, skeletons, ceilings);
  runner.prepare();
  QueryOutcome out;
  out.id = q.id;
  out.warnings = runner.warnings();
  double recall_sum = 0.0;
  for (std::size_t h = 0; h + 1 < q.frames.size(); ++h) {
    const PairRun run = runner.run_pair(h, options.mode);
    if (options.mode == SearchMode::approx && options.compute_recall)
      recall_sum += top_r_recall(run, runner.run_pair(h, SearchMode::exact));
    add_stats(out.stats, run.stats);
    out.pairs.push_back(ranked_pair(*m.index, runner, h, options.mode, run, out.stats));
  }
  if (options.mode == SearchMode::approx && options.compute_recall)
    out.stats.recall = recall_sum / static_cast<double>(q.frames.size() - 1);
  out.stats.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void SearchEngine::prepare(const SearchOptions& options, bool whole_body_frames) const {
  for (const auto& skeleton : impl_->skeletons) {
    if (whole_body_frames) search_detail::frame_arrays(*impl_->index, *skeleton);
    if (options.mode == SearchMode::approx)
      search_detail::ensure_forest(*impl_->index, *skeleton, options);
  }
}

FrameBounds SearchEngine::frame_bounds(const Query& q, std::size_t i, std::size_t k) const {
  using namespace search_detail;
  const Impl& m = *impl_;
  if (k >= m.skeletons.size() || i >= q.frames.size())
    throw std::invalid_argument("frame_bounds: no such skeleton or frame");
  const SkeletonData& skeleton = *m.skeletons[k];
  const SkeletonTables& tables = skeleton.tables;
  ResolvedFrame f = resolve_frame(q, i, *tables.sk, tables.model, q.transition_time_s, m.t_index,
                                  m.bvh_cache, m.index->info().unit_option, nullptr,
                                  [&] { return &typical_pose(*m.index, skeleton); });
  set_needed_joints(f, tables.model);
  const std::size_t n = tables.sk->frame_count;
  FrameBounds out;
  std::vector<double>& lower = out.lower;
  std::vector<double>& h = out.h;
  lower.assign(n, 0.0);
  h.assign(n, kInf);
  out.sketch_lower.assign(n, 0.0);
  out.chain_lower.assign(n, 0.0);
  Scratch scratch;
  out.partial_reference.assign(n, 0.0);
  if (f.kind == FrameKind::partial) {
    PartialBoundPlan plan = make_partial_bound_plan(f, tables, q.transition_time_s);
    const FrameArrays& fa = frame_arrays(*m.index, skeleton);
    partial_frame_bounds_reference(plan, tables, fa, 0, n, out.partial_reference.data(), scratch);
    attach_columns(plan, skeleton, *m.index);
    partial_frame_bounds(plan, tables, &fa, 0, n, lower.data(), scratch);
  }
  out.partial_lower = lower;
  const BoundQuery bound_query = make_bound_query(f, tables);
  // The clip and group levels (run_pair's group_bounds and clip_tile_bounds):
  // each is a lower bound for every frame of its clips, so it joins the maximum.
  std::vector<float> clip_lb(tables.clips.size(), 0.0f), group_lb;
  group_bounds(bound_query, tables, group_lb);
  for (std::size_t g = 0; g * kGroup < tables.clips.size(); ++g) {
    float tile[kLanes];
    clip_tile_bounds(bound_query, tables, g, tile);
    const float group = group_lb[g];
    for (std::size_t r = g * kGroup; r < std::min(tables.clips.size(), g * kGroup + kGroup); ++r)
      clip_lb[r] = std::max(tile[r % kLanes], group);
  }
  for (std::size_t r = 0; r < tables.clips.size(); ++r) {
    const ClipInfo& ci = tables.clips[r];
    for (std::size_t g = ci.frame_start; g < ci.frame_start + ci.frame_count; ++g)
      lower[g] = std::max(lower[g], static_cast<double>(clip_lb[r]));
  }
  for (const ClipInfo& ci : tables.clips)
    for (std::size_t bl = 0; bl * kBlock < ci.frame_count; ++bl) {
      const std::size_t row = ci.block_start + bl;
      const double x = block_box_bound(bound_query, tables, row);
      const std::size_t g0 = ci.frame_start + bl * kBlock,
                        g1 = ci.frame_start + std::min(ci.frame_count, bl * kBlock + kBlock);
      const float* sketch = tables.sketch.data() + row * kSketchFields * kBlock;
      float chain[kBlock];
      if (bound_query.kind == FrameKind::full)
        chain_sketch_bounds(
            bound_query.chain_sketch.data(),
            tables.chain_sketch.data() + row * tables.chains * kSketchFields * kBlock,
            tables.chains, chain);
      for (std::size_t g = g0; g < g1; ++g) {
        lower[g] = std::max(lower[g], x);
        if (bound_query.kind == FrameKind::full) {
          const std::size_t l = g - g0;
          const auto whole = static_cast<double>(
              sketch_term(bound_query.sketch.data(), sketch[l], sketch[kBlock + l],
                          sketch[2 * kBlock + l], sketch[3 * kBlock + l], sketch[4 * kBlock + l]));
          lower[g] = std::max({lower[g], whole, static_cast<double>(chain[l])});
          out.sketch_lower[g] = whole;
          out.chain_lower[g] = chain[l];
        }
      }
      const HScanView tile = tables.tile(row, g0, g1 - g0);
      evaluate_h(f, skeleton, *m.index, q.transition_time_s, g0, g1, h.data() + g0, scratch,
                 std::nullopt, nullptr, &tile);
    }
  out.root_lower.assign(n, 0.0);
  if (root_bound_applies(f)) {
    const RootBoundQuery rq = make_root_bound_query(f, skeleton, q.transition_time_s);
    ensure_frame_kinetic(skeleton);
    frame_headings(skeleton);
    const float* moments = rq.turns ? turn_moments_of(rq, skeleton) : nullptr;
    const double psi = rq.turns ? *f.partial.spec.root_heading_rad : 0.0;
    const double cq = std::cos(psi), sq = std::sin(psi);
    for (std::size_t g = 0; g < n; ++g) {
      const Eigen::Vector3d r(tables.root_position(0, g), tables.root_position(1, g),
                              tables.root_position(2, g));
      out.root_lower[g] = frame_root_bound(
          rq, rq.turns ? moments + 4 * g : nullptr, static_cast<double>(skeleton.caches.kinetic[g]),
          static_cast<double>(skeleton.caches.kinetic_rot[g]), r,
          skeleton.caches.heading_cos_sin.data() + 2 * g, f.root_m, cq, sq);
    }
  }
  out.engine_h = h;
  set_subtree_plan(f, skeleton, *m.index, q.transition_time_s);
  if (!f.subtree.empty()) subtree_energy(f, tables, 0, n, out.engine_h.data(), scratch);
  return out;
}

}  // namespace mocap
