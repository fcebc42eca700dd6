// One query's run: resolving its frames, then each pair's candidates,
// groups, seeding and sweep (query_runner.hpp).
#include "engine/query_runner.hpp"

#include "mocap/search/timing.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <filesystem>
#include <numbers>
#include <set>
#include <string>

#include "bounds/partial_bounds.hpp"
#include "mocap/search/recognised_styles.hpp"
#include "query/relative_frames.hpp"
#include "scan/context_energy.hpp"
#include "scan/frame_energy.hpp"
#include "scan/subtree_kernel.hpp"

namespace mocap::search_detail {

QueryRunner::QueryRunner(const SearchEngine::Impl& engine, const Query& query,
                         const SearchOptions& options,
                         const std::vector<std::unique_ptr<SkeletonData>>& skeletons,
                         const std::vector<double>* ceilings)
    : engine_(engine),
      q_(query),
      options_(options),
      skeletons_(skeletons),
      ceilings_(ceilings),
      top_(query.top) {}

double QueryRunner::ceiling(std::size_t h) const {
  // A pair ranked by its verdicts too (rank_pair_results) may need results
  // that score above another shard's: no ceiling.
  if (!ceilings_ || h >= ceilings_->size() || named_constraints(h))
    return std::numeric_limits<double>::infinity();
  return (*ceilings_)[h];
}

bool QueryRunner::named_constraints(std::size_t h) const {
  for (const auto& frames : resolved_)
    for (const std::size_t i : {h, h + 1})
      for (const PoseConstraint& c : frames[i].constraints)
        if (!c.name.empty()) return true;
  return false;
}

void QueryRunner::add_name_warnings(std::size_t k, std::size_t i, const QueryBvhFile* file) {
  const Index& index = *engine_.index;
  std::string rig = "index skeleton " + std::to_string(k);
  for (const IndexClip& c : index.clips())
    if (c.skeleton == k) {
      rig += " (" + std::filesystem::path(c.path).filename().string() + ", ...)";
      break;
    }
  const QueryFrameSpec& spec = q_.frames[i];
  const std::string file_name =
      spec.asf ? spec.asf->filename().string()
               : (spec.bvh ? spec.bvh->filename().string() : std::string("the file"));
  for (std::string& w : joint_name_warnings(q_, i, index.skeletons()[k].skeleton, rig,
                                            file ? &file->motion.skeleton : nullptr, file_name))
    if (std::find(warnings_.begin(), warnings_.end(), w) == warnings_.end())
      warnings_.push_back(std::move(w));
}

void QueryRunner::set_require_met(bool on) {
  auto set = [on](ResolvedFrame& f) {
    bool named = false;
    for (const PoseConstraint& c : f.constraints) named = named || !c.name.empty();
    f.require_met = on && named;
  };
  for (auto& frames : resolved_)
    for (ResolvedFrame& f : frames) set(f);
  for (auto& pairs : body_)
    for (auto& pair : pairs)
      for (ResolvedFrame& f : pair) set(f);
  // Shared h values were computed with the other setting.
  for (auto& frames : cache_)
    for (FrameCache& c : frames)
      if (c.values) std::fill(c.done.begin(), c.done.end(), std::uint8_t{0});
}

void QueryRunner::prepare() {
  const SearchEngine::Impl& m = engine_;
  resolved_.resize(skeletons_.size());
  bounds_.resize(skeletons_.size());
  // Each frame's BVH file is looked up once, for the first skeleton.
  std::vector<std::shared_ptr<const QueryBvhFile>> files(q_.frames.size());
  for (std::size_t k = 0; k < skeletons_.size(); ++k)
    for (std::size_t i = 0; i < q_.frames.size(); ++i) {
      const SkeletonData& skeleton = *skeletons_[k];
      resolved_[k].push_back(resolve_frame(q_, i, *skeleton.tables.sk, skeleton.tables.model,
                                           q_.transition_time_s, m.t_index, m.bvh_cache,
                                           m.index->info().unit_option, &files[i],
                                           [&] { return &typical_pose(*m.index, skeleton); }));
      add_name_warnings(k, i, files[i].get());
      set_needed_joints(resolved_[k].back(), skeleton.tables.model);
      set_subtree_plan(resolved_[k].back(), skeleton, *m.index, q_.transition_time_s);
      bounds_[k].push_back(make_bound_query(resolved_[k].back(), skeleton.tables));
    }
  if (q_.style) prepare_style();
  // Resolution reported a deferred joint value after the frame's names; an
  // index without skeletons has no names to check first.
  for (const QueryFrameSpec& f : q_.frames)
    if (f.joint_value_error) throw *f.joint_value_error;
  if (q_.relative()) {
    body_.assign(skeletons_.size(), {});
    for (std::size_t k = 0; k < skeletons_.size(); ++k)
      for (std::size_t h = 0; h + 1 < q_.frames.size(); ++h) {
        auto& pair = body_[k].emplace_back();
        pair_body_frames(q_, h, resolved_[k][h], resolved_[k][h + 1], skeletons_[k]->tables,
                         q_.transition_time_s, pair[0], pair[1]);
        pair[0].context = pair[0].context_before.get();
        pair[1].context = pair[1].context_after.get();
        pair[0].style_rows = style_rows_.empty() ? nullptr : style_rows_[k].data();
        pair[1].style_rows = nullptr;
      }
    relative_bounds_.assign(skeletons_.size(), {});
    root_bounds_.assign(skeletons_.size(), {});
    for (std::size_t k = 0; k < skeletons_.size(); ++k)
      for (const auto& pair : body_[k]) {
        auto& ob = relative_bounds_[k].emplace_back();
        auto& rb = root_bounds_[k].emplace_back();
        for (std::size_t side = 0; side < 2; ++side) {
          if (q_.placement == FramePlacement::relative && pair[side].kind == FrameKind::full &&
              pair[side].compared.empty())  // masked frames: no bound (resolve.hpp)
            ob[side] =
                make_relative_bound_query(pair[side], skeletons_[k]->tables, q_.transition_time_s);
          if (root_bound_applies(pair[side]))
            rb[side] = make_root_bound_query(pair[side], *skeletons_[k], q_.transition_time_s);
        }
      }
  }
  prepare_caches();
  if ((options_.mode == SearchMode::exact || options_.mode == SearchMode::approx) &&
      !all_relative())
    compute_frame_bounds();
}

void QueryRunner::prepare_caches() {
  cache_.clear();
  for (std::size_t k = 0; k < skeletons_.size(); ++k) {
    cache_.emplace_back();
    cache_.back().resize(q_.frames.size());
  }
  // With "style" a frame scores otherwise as Q^h than as Q^h+1: not shared.
  if (q_.relative() || q_.style) return;
  for (std::size_t k = 0; k < skeletons_.size(); ++k)
    for (std::size_t i = 1; i + 1 < q_.frames.size(); ++i) {
      // A frame with context scores otherwise as Q^h+1 and as Q^h: not shared.
      if (q_.frames[i].context_before > 0 || q_.frames[i].context_after > 0) continue;
      const std::size_t n = skeletons_[k]->tables.sk->frame_count;
      cache_[k][i].values.reset(new double[n]);
      cache_[k][i].done.assign(n, 0);
    }
}

bool QueryRunner::relative_pair(std::size_t h) const {
  if (!q_.relative()) return false;
  for (const auto& frames : resolved_)
    if (!placement_free(frames[h]) || !placement_free(frames[h + 1])) return true;
  return false;
}

bool QueryRunner::all_relative() const {
  for (std::size_t h = 0; h + 1 < q_.frames.size(); ++h)
    if (!relative_pair(h)) return false;
  return true;
}

FrameCache* QueryRunner::cache_of(std::size_t k, std::size_t i) {
  return cache_.empty() || !cache_[k][i].values ? nullptr : &cache_[k][i];
}

const float* QueryRunner::group_lbs(std::size_t k, std::size_t i) {
  if (tiles_.empty()) tiles_.assign(skeletons_.size(), std::vector<FrameTiles>(q_.frames.size()));
  FrameTiles& t = tiles_[k][i];
  if (t.clips_done.empty()) {
    group_bounds(bounds_[k][i], skeletons_[k]->tables, t.groups);
    t.clips.resize(t.groups.size() * kLanes);
    t.clips_done.assign(t.groups.size(), 0);
  }
  return t.groups.data();
}

const float* QueryRunner::clip_lbs(std::size_t k, std::size_t i, std::size_t g) {
  FrameTiles& t = tiles_[k][i];
  float* out = t.clips.data() + g * kLanes;
  if (!t.clips_done[g]) {
    clip_tile_bounds(bounds_[k][i], skeletons_[k]->tables, g, out);
    t.clips_done[g] = 1;
  }
  return out;
}

void QueryRunner::compute_frame_bounds() {
  frame_lb_.assign(skeletons_.size(), std::vector<std::vector<double>>(q_.frames.size()));
  for (std::size_t k = 0; k < skeletons_.size(); ++k) {
    const SkeletonData& skeleton = *skeletons_[k];
    const SkeletonTables& tables = skeleton.tables;
    const std::size_t n = tables.sk->frame_count;
    for (std::size_t i = 0; i < q_.frames.size(); ++i) {
      // Constrained frames are solved per frame: no per-frame bounds (0).
      if (resolved_[k][i].kind != FrameKind::partial || n == 0 || resolved_[k][i].solve ||
          resolved_[k][i].weight < 1.0)
        continue;
      PartialBoundPlan plan =
          make_partial_bound_plan(resolved_[k][i], tables, q_.transition_time_s);
      attach_columns(plan, skeleton, *engine_.index);
      // The reference (frames the columns do not serve) reads the frame arrays.
      const FrameArrays* fa =
          plan.col_segs.empty() ? &frame_arrays(*engine_.index, skeleton) : nullptr;
      std::vector<double>& out = frame_lb_[k][i];
      out.resize(n);
      auto chunk = [&](std::size_t g0, std::size_t g1) {
        partial_frame_bounds(plan, tables, fa, g0, g1, out.data() + g0, engine_.scratch.local());
      };
      if (options_.parallel_clips)
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, n, 4096),
            [&](const tbb::blocked_range<std::size_t>& rg) { chunk(rg.begin(), rg.end()); });
      else
        chunk(0, n);
    }
  }
}

const double* QueryRunner::frame_bounds_of(std::size_t k, std::size_t i) const {
  if (frame_lb_.empty() || frame_lb_[k][i].empty()) return nullptr;
  return frame_lb_[k][i].data();
}

bool QueryRunner::passes(std::size_t clip) const {
  if (q_.filter.empty()) return true;
  const IndexClip& c = engine_.index->clips()[clip];
  const std::string name = std::filesystem::path(c.path).filename().string();
  const std::string content =
      engine_.content_key >= 0 ? c.labels[static_cast<std::size_t>(engine_.content_key)] : "";
  const std::string style =
      engine_.style_key >= 0 ? c.labels[static_cast<std::size_t>(engine_.style_key)] : "";
  return q_.filter.accepts(name, content, style);
}

PairContext QueryRunner::context(std::size_t k, std::size_t h, SearchMode mode) {
  double min_length = q_.min_length_s.value_or(options_.min_length_s);
  double max_length = q_.max_length_s.value_or(options_.max_length_s);
  if (q_.timed()) {  // lengths that fill the time between the two key poses
    const TimedPairWindow w = timed_pair_window(*q_.frames[h + 1].time_s - *q_.frames[h].time_s,
                                                q_.transition_time_s, min_length);
    min_length = w.min_length_s;
    max_length = w.max_length_s;
  }
  PairContext pair{
      engine_.index,        skeletons_[k].get(), &resolved_[k][h], &resolved_[k][h + 1],
      q_.transition_time_s, q_.path_weight,      q_.placement,     mode,
      min_length,           max_length,          nullptr,          nullptr,
      &bounds_[k][h],       &bounds_[k][h + 1],  cache_of(k, h),   cache_of(k, h + 1)};
  if (mode == SearchMode::exact && !relative_pair(h)) {
    pair.frame_lb_a = frame_bounds_of(k, h);
    pair.frame_lb_b = frame_bounds_of(k, h + 1);
  }
  if (relative_pair(h)) {
    pair.qa = &body_[k][h][0];
    pair.qb = &body_[k][h][1];
    if (mode == SearchMode::exact && relative_bounds_[k][h][0])
      pair.in_bound = &*relative_bounds_[k][h][0];
    if (mode == SearchMode::exact && relative_bounds_[k][h][1])
      pair.out_bound = &*relative_bounds_[k][h][1];
    if (mode == SearchMode::exact && root_bounds_[k][h][0]) pair.root_in = &*root_bounds_[k][h][0];
    if (mode == SearchMode::exact && root_bounds_[k][h][1]) pair.root_out = &*root_bounds_[k][h][1];
  }
  return pair;
}

std::optional<std::vector<std::pair<std::size_t, std::size_t>>> QueryRunner::approx_candidates(
    std::size_t h) const {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t k = 0; k < skeletons_.size(); ++k) {
    const ResolvedFrame& qa = resolved_[k][h];
    const ResolvedFrame& qb = resolved_[k][h + 1];
    if (qa.kind != FrameKind::full || qb.kind != FrameKind::full || q_.relative())
      return std::nullopt;
  }
  for (std::size_t k = 0; k < skeletons_.size(); ++k) {
    const SkeletonData& skeleton = *skeletons_[k];
    const std::size_t n = skeleton.tables.sk->frame_count;
    if (n == 0) continue;
    ensure_forest(*engine_.index, skeleton, options_);
    const std::size_t knn = std::min<std::size_t>(
        n, static_cast<std::size_t>(options_.approx_neighbours_per_result) * top_);
    std::set<std::size_t> rows;
    std::vector<std::size_t> idx;
    for (const ResolvedFrame* f : {&resolved_[k][h], &resolved_[k][h + 1]}) {
      skeleton.caches.forest->knn(f->kd.data(), knn, options_.approx_checks, idx);
      for (std::size_t i : idx) rows.insert(skeleton.tables.frame_row[i]);
    }
    for (std::size_t r : rows) out.emplace_back(k, r);
  }
  return out;
}

// One pair's search, step by step (QueryRunner::run_pair).
//
// Work is done in groups of kGroup consecutive clip rows of a skeleton
// (similar clips are adjacent: files sorted by name). A group's bound (its
// union box) orders the groups and prunes whole groups; inside a group,
// clip bounds order and prune the clips. Likely winners come first, so tau
// falls fast; the answer does not depend on the order (docs/search.md
// "Search order").
class PairSearch {
 public:
  PairSearch(QueryRunner& runner, std::size_t h, SearchMode mode)
      : runner_(runner),
        q_(runner.q_),
        h_(h),
        eval_mode_(mode == SearchMode::approx ? SearchMode::exact : mode),
        relative_(runner.relative_pair(h)),
        bounded_(eval_mode_ == SearchMode::exact && !relative_),
        top_(runner_.top_, eval_mode_ == SearchMode::exact
                               ? runner.ceiling(h)
                               : std::numeric_limits<double>::infinity()) {
    const std::size_t skeletons = runner_.skeletons_.size();
    for (std::size_t k = 0; k < skeletons; ++k)
      contexts_.push_back(runner_.context(k, h, eval_mode_));
    // Full or root-only query frames on both sides: block-level evaluation.
    blocks_only_.resize(skeletons);
    for (std::size_t k = 0; k < skeletons; ++k)
      blocks_only_[k] = bounded_ && runner_.bounds_[k][h].kind != FrameKind::partial &&
                        runner_.bounds_[k][h + 1].kind != FrameKind::partial &&
                        runner_.frame_bounds_of(k, h) == nullptr &&
                        runner_.frame_bounds_of(k, h + 1) == nullptr;
  }

  // The candidate clips (skeleton, row) that pass the filter: approx mode's
  // when it has them, else all; counts them in the stats.
  void collect_candidates(SearchMode mode) {
    std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx;
    if (mode == SearchMode::approx) approx = runner_.approx_candidates(h_);
    const auto& skeletons = runner_.skeletons_;
    if (approx) {
      for (auto [k, r] : *approx)
        if (runner_.passes(skeletons[k]->tables.clips[r].clip)) candidates_.emplace_back(k, r);
      for (std::size_t k = 0; k < skeletons.size(); ++k)
        for (const ClipInfo& ci : skeletons[k]->tables.clips)
          if (runner_.passes(ci.clip)) ++result_.stats.clips;
      result_.stats.clips_pruned += result_.stats.clips - candidates_.size();
    } else {
      for (std::size_t k = 0; k < skeletons.size(); ++k)
        for (std::size_t r = 0; r < skeletons[k]->tables.clips.size(); ++r)
          if (runner_.passes(skeletons[k]->tables.clips[r].clip)) candidates_.emplace_back(k, r);
      result_.stats.clips = candidates_.size();
    }
    seeded_.assign(candidates_.size(), 0);
  }

  // Cuts the candidates into groups (runs of one kGroup group of clip rows)
  // with their bounds (both query frames' group bounds when bounded), least
  // bound first.
  void form_groups() {
    const auto& skeletons = runner_.skeletons_;
    // Every group's bound for both query frames, 16 groups at a time.
    std::vector<std::array<const float*, 2>> group_lb(skeletons.size());
    if (bounded_)
      for (std::size_t k = 0; k < skeletons.size(); ++k)
        for (std::size_t side = 0; side < 2; ++side)
          group_lb[k][side] = runner_.group_lbs(k, h_ + side);
    for (std::size_t i = 0; i < candidates_.size();) {
      const auto [k, r] = candidates_[i];
      std::size_t j = i + 1;
      while (j < candidates_.size() && candidates_[j].first == k &&
             candidates_[j].second / kGroup == r / kGroup)
        ++j;
      double glb = 0.0;
      if (bounded_)
        glb = static_cast<double>(group_lb[k][0][r / kGroup]) +
              static_cast<double>(group_lb[k][1][r / kGroup]);
      groups_.push_back({glb, i, j - i});
      i = j;
    }
    std::sort(groups_.begin(), groups_.end(), [&](const ClipGroup& x, const ClipGroup& y) {
      if (x.lb != y.lb) return x.lb < y.lb;
      return x.first < y.first;
    });
  }

  // Seeding (docs/search.md "Search order"): best-first over the groups (by
  // group bound) and the clips of the groups opened (by clip bound) until 2r
  // clips are evaluated, so that tau is finite and low before the sweep;
  // those clips are skipped there. One thread: the 2r clips of least bound
  // among the groups of least bound, in the order of their bounds, wherever
  // they lie. Bounded searches only.
  void seed() {
    Scratch& scratch = runner_.engine_.scratch.local();
    ScanTotals totals;
    std::vector<ClipWork> pool, work;
    auto later = [&](const ClipWork& x, const ClipWork& y) { return by_bound(y, x); };
    std::size_t next = 0, done = 0;
    while (done < 2 * runner_.top_) {
      if (next < groups_.size() && (pool.empty() || !(pool.front().lb < groups_[next].lb))) {
        bounded_work(groups_[next++], work);
        for (const ClipWork& w : work) {
          pool.push_back(w);
          std::push_heap(pool.begin(), pool.end(), later);
        }
        continue;
      }
      if (pool.empty()) break;
      std::pop_heap(pool.begin(), pool.end(), later);
      const ClipWork w = pool.back();
      pool.pop_back();
      const double tau = top_.tau();
      // Every bound left is at least this one: the sweep prunes them all.
      if (safe(w.lb) > tau) break;
      evaluate_clip(w, tau, scratch, totals);
      seeded_[w.candidate] = 1;
      ++done;
    }
    add(totals);
  }

  // Every group not pruned by its bound, its clips in the order of their
  // bounds until the rest are pruned (parallel over groups with
  // SearchOptions::parallel_clips).
  void sweep(bool parallel) {
    if (parallel) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groups_.size(), 1),
                        [&](const tbb::blocked_range<std::size_t>& rg) {
                          std::vector<ClipWork> work;
                          for (std::size_t i = rg.begin(); i != rg.end(); ++i)
                            sweep_group(groups_[i], work);
                        });
    } else {
      std::vector<ClipWork> work;
      for (const ClipGroup& group : groups_) sweep_group(group, work);
    }
  }

  bool bounded() const { return bounded_; }

  // Relative placements with full query frames (exact): the 2r candidates
  // of least clip box bound (relative_bounds.hpp) first, one thread, so that
  // tau is finite and low before the sweep; those clips are skipped there.
  void seed_relative() {
    std::vector<ClipWork> work;
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
      const auto [k, r] = candidates_[i];
      const PairContext& pair = contexts_[k];
      if (!has_relative_clip_bound(pair)) return;
      const SkeletonTables& tables = runner_.skeletons_[k]->tables;
      work.push_back({relative_clip_bound(pair, r), tables.clips[r].clip, k, r, i});
    }
    const std::size_t n = std::min(work.size(), 2 * runner_.top_);
    std::partial_sort(work.begin(), work.begin() + static_cast<std::ptrdiff_t>(n), work.end(),
                      by_bound);
    Scratch& scratch = runner_.engine_.scratch.local();
    ScanTotals totals;
    for (std::size_t i = 0; i < n; ++i) {
      evaluate_clip(work[i], top_.tau(), scratch, totals);
      seeded_[work[i].candidate] = 1;
    }
    add(totals);
  }

  PairRun finish() {
    result_.top = top_.take();
    result_.stats.frames_evaluated = evaluated_;
    result_.stats.frames_pruned += pruned_;
    result_.stats.clips_pruned += clips_pruned_;
    return std::move(result_);
  }

 private:
  // A candidate clip to evaluate, with its lower bound (0 when not bounded).
  struct ClipWork {
    double lb;
    std::size_t clip;       // global clip index
    std::size_t k, r;       // skeleton, clip row
    std::size_t candidate;  // index in candidates_
  };
  // A run of candidates_ in one group of clip rows, with its lower bound.
  struct ClipGroup {
    double lb;
    std::size_t first, count;
  };
  // Counters of one thread's share, added to the pair's at the end.
  struct ScanTotals {
    std::uint64_t evaluated = 0, pruned = 0, clips_pruned = 0;
  };

  static bool by_bound(const ClipWork& x, const ClipWork& y) {
    if (x.lb != y.lb) return x.lb < y.lb;
    return x.clip < y.clip;
  }

  void add(const ScanTotals& totals) {
    evaluated_ += totals.evaluated;
    pruned_ += totals.pruned;
    clips_pruned_ += totals.clips_pruned;
  }

  // Clip bound: boxes, and the per-frame bounds of partial query frames:
  // min over s < e of (max(xa, fa[s]) + max(xb, fb[e])).
  // xa, xb: the clip's tile bounds (clip_tile_bounds over its group's tile).
  double clip_bound(std::size_t k, std::size_t r, double xa, double xb) const {
    const SkeletonTables& tables = runner_.skeletons_[k]->tables;
    const double* fa = runner_.frame_bounds_of(k, h_);
    const double* fb = runner_.frame_bounds_of(k, h_ + 1);
    if (fa == nullptr && fb == nullptr) return xa + xb;
    const ClipInfo& ci = tables.clips[r];
    double best = kInf, suffix = kInf;
    for (std::size_t f = ci.frame_count; f-- > 0;) {
      const std::size_t g = ci.frame_start + f;
      best = std::min(best, (fa ? std::max(xa, fa[g]) : xa) + suffix);
      suffix = std::min(suffix, fb ? std::max(xb, fb[g]) : xb);
    }
    return std::max(xa + xb, best);
  }

  // Evaluates one candidate against tau (its bound does not exceed tau)
  // and offers its best partial motion to the top.
  void evaluate_clip(const ClipWork& w, double tau, Scratch& scratch, ScanTotals& totals) {
    const ClipInfo& ci = runner_.skeletons_[w.k]->tables.clips[w.r];
    const PairContext& pair = contexts_[w.k];
    ClipCounters counters;
    ClipMatch match{};
    bool found = false;
    if (relative_) {
      found = eval_clip_relative(pair, ci, tau, scratch, counters, match);
    } else if (blocks_only_[w.k]) {
      clip_block_bounds(pair, ci, tau, scratch);
      found = eval_clip_blocks(pair, ci, tau, scratch.blk_a.data(), scratch.blk_b.data(), scratch,
                               counters, match);
    } else {
      found = eval_clip_world(pair, ci, tau, scratch, counters, match);
    }
    if (found) top_.insert(match);
    totals.evaluated += counters.evaluated;
    totals.pruned += counters.pruned;
    totals.clips_pruned += counters.clip_pruned;
  }

  // The group's candidates not seeded (bounds 0).
  void unseeded_work(const ClipGroup& group, std::vector<ClipWork>& work) const {
    work.clear();
    for (std::size_t i = group.first; i < group.first + group.count; ++i)
      if (!seeded_[i]) {
        const auto [k, r] = candidates_[i];
        work.push_back({0.0, runner_.skeletons_[k]->tables.clips[r].clip, k, r, i});
      }
  }

  // The same with their clip bounds when bounded.
  void bounded_work(const ClipGroup& group, std::vector<ClipWork>& work) {
    unseeded_work(group, work);
    if (!bounded_ || work.empty()) return;
    // The group's clip bounds: one lane-major tile per side.
    const std::size_t gk = candidates_[group.first].first;
    const std::size_t g = candidates_[group.first].second / kGroup;
    const float* xa = runner_.clip_lbs(gk, h_, g);
    const float* xb = runner_.clip_lbs(gk, h_ + 1, g);
    for (ClipWork& w : work) w.lb = clip_bound(w.k, w.r, xa[w.r % kLanes], xb[w.r % kLanes]);
  }

  void sweep_group(const ClipGroup& group, std::vector<ClipWork>& work) {
    ScanTotals totals;
    auto prune_all = [&](std::size_t from) {
      for (std::size_t j = from; j < work.size(); ++j) {
        totals.pruned +=
            relative_ ? 0 : 2 * runner_.skeletons_[work[j].k]->tables.clips[work[j].r].frame_count;
        ++totals.clips_pruned;
      }
    };
    Scratch& scratch = runner_.engine_.scratch.local();
    if (bounded_ && safe(group.lb) > top_.tau()) {
      unseeded_work(group, work);
      prune_all(0);
    } else {
      bounded_work(group, work);
      std::sort(work.begin(), work.end(), by_bound);
      for (std::size_t i = 0; i < work.size(); ++i) {
        const double tau = top_.tau();
        if (bounded_ && safe(work[i].lb) > tau) {
          // The rest of the group has bounds >= this one and tau only decreases.
          prune_all(i);
          break;
        }
        evaluate_clip(work[i], tau, scratch, totals);
      }
    }
    add(totals);
  }

  QueryRunner& runner_;
  const Query& q_;
  const std::size_t h_;
  const SearchMode eval_mode_;
  const bool relative_;  // QueryRunner::relative_pair
  const bool bounded_;
  std::vector<std::pair<std::size_t, std::size_t>> candidates_;  // (skeleton, clip row)
  std::vector<std::uint8_t> seeded_;  // per candidate: evaluated by the seeding
  std::vector<ClipGroup> groups_;
  std::vector<PairContext> contexts_;      // per skeleton
  std::vector<std::uint8_t> blocks_only_;  // per skeleton: eval_clip_blocks serves
  TopMatches top_;
  std::atomic<std::uint64_t> evaluated_{0}, pruned_{0}, clips_pruned_{0};
  PairRun result_;
};

void QueryRunner::add_residuals(PairResults& pair) const {
  Scratch& scratch = engine_.scratch.local();
  for (SearchResult& r : pair.results) {
    const IndexClip& clip = engine_.index->clips()[r.clip_index];
    const SkeletonData& skeleton = *skeletons_[clip.skeleton];
    const DynamicsModel& model = skeleton.tables.model;
    for (const bool in : {true, false}) {
      const ResolvedFrame& f = resolved_[clip.skeleton][in ? pair.from : pair.to];
      auto& out = in ? r.residuals_from : r.residuals_to;
      bool named = false;
      for (const PoseConstraint& c : f.constraints) named = named || !c.name.empty();
      if (!named) continue;
      const FrameRef frame = database_frame(
          skeleton, *engine_.index, clip.frame_start + (in ? r.start_frame : r.end_frame), scratch);
      for (const PoseConstraint& c : f.constraints) {
        if (c.name.empty()) continue;
        ConstraintResidual cr;
        cr.name = c.name;
        cr.residual = constraint_residual(model.parents, model.root(), c,
                                          frame.state.joint_positions_m, frame.state.rotations);
        cr.metres = c.kind == PoseConstraintKind::effector;
        cr.tolerance = cr.metres ? c.tolerance : c.tolerance * 180.0 / std::numbers::pi;
        out.push_back(std::move(cr));
      }
    }
  }
}

void QueryRunner::add_context_energies(PairResults& pair) const {
  for (SearchResult& r : pair.results) {
    const IndexClip& clip = engine_.index->clips()[r.clip_index];
    const SkeletonData& skeleton = *skeletons_[clip.skeleton];
    const FrameContext* in = resolved_[clip.skeleton][pair.from].context_before.get();
    const FrameContext* out = resolved_[clip.skeleton][pair.to].context_after.get();
    r.context = in != nullptr || out != nullptr;
    if (in != nullptr) {
      r.context_in_J = in->weight * context_energy(*in, skeleton, *engine_.index,
                                                   clip.frame_start + r.start_frame);
      r.h_in_J -= r.context_in_J;
    }
    if (out != nullptr) {
      r.context_out_J = out->weight * context_energy(*out, skeleton, *engine_.index,
                                                     clip.frame_start + r.end_frame);
      r.h_out_J -= r.context_out_J;
    }
  }
}

void QueryRunner::prepare_style() {
  const std::string src = "<query " + q_.id + ">";
  if (!options_.style_model)
    throw InputError(src, 0,
                     "style: needs a style model (mocap-search --style-model, Python "
                     "style_model=; docs/style.md)");
  std::shared_ptr<const std::vector<std::vector<double>>> probs;
  {
    std::lock_guard<std::mutex> lock(engine_.style_mutex);
    auto& entry = engine_.clip_styles[options_.style_model.get()];
    if (!entry.probabilities) {
      entry.model = options_.style_model;
      entry.probabilities = std::make_shared<const std::vector<std::vector<double>>>(
          clip_style_probabilities(*options_.style_model, *engine_.index));
    }
    probs = entry.probabilities;
  }
  const std::vector<double> asked = asked_style(*options_.style_model, *q_.style, src);
  style_rows_.assign(skeletons_.size(), {});
  for (std::size_t k = 0; k < skeletons_.size(); ++k) {
    const SkeletonTables& tables = skeletons_[k]->tables;
    for (const ClipInfo& ci : tables.clips)
      style_rows_[k].push_back(q_.style->weight * style_distance(asked, (*probs)[ci.clip]));
  }
}

void QueryRunner::add_style_energies(PairResults& pair) const {
  if (style_rows_.empty()) return;
  for (SearchResult& r : pair.results) {
    const IndexClip& clip = engine_.index->clips()[r.clip_index];
    const SkeletonTables& tables = skeletons_[clip.skeleton]->tables;
    r.style = true;
    r.style_J = style_rows_[clip.skeleton][tables.frame_row[clip.frame_start + r.start_frame]];
    r.h_in_J -= r.style_J;
  }
}

PairRun QueryRunner::run_pair(std::size_t h, SearchMode mode) {
  // A frame weighted below 1 scores below the bounds, which bound the
  // unweighted h: such a pair is evaluated whole (brute, the same values).
  if (q_.frames[h].weight < 1.0 || q_.frames[h + 1].weight < 1.0) mode = SearchMode::brute;
  // Context: Q^h's frames before it, Q^h+1's after it (docs/queries.md).
  for (std::size_t k = 0; k < resolved_.size(); ++k) {
    std::vector<ResolvedFrame>& frames = resolved_[k];
    for (ResolvedFrame& f : frames) {
      f.context = nullptr;
      f.style_rows = nullptr;
    }
    frames[h].context = frames[h].context_before.get();
    frames[h + 1].context = frames[h + 1].context_after.get();
    // The style term: once a result, with its start (docs/style.md).
    if (!style_rows_.empty()) frames[h].style_rows = style_rows_[k].data();
  }
  PairSearch search(*this, h, mode);
  search.collect_candidates(mode);
  search.form_groups();
  if (search.bounded()) search.seed();
  if (q_.relative() && relative_pair(h) && mode != SearchMode::brute) search.seed_relative();
  search.sweep(options_.parallel_clips);
  return search.finish();
}

}  // namespace mocap::search_detail
