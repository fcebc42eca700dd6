#pragma once
// Internal to mocap_search: the best partial motion of a clip for one query
// pair (ClipMatch) and the shared top-r list of a pair (TopMatches) that
// the clip scans of every thread offer their matches to.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <limits>
#include <mutex>
#include <utility>
#include <vector>

namespace mocap::search_detail {

// The best partial motion F^start..F^end of one clip for one pair (J):
// score = h_in + h_out + lambda * path_cost, as computed.
struct ClipMatch {
  double score;
  std::size_t clip, start, end;  // global clip index; frames within the clip
  double h_in, h_out;            // h(Q^h -> F^start), h(F^end -> Q^h+1)
  double path_cost;              // P[end] - P[start] (lambda not applied)
};

// The ranking: score, then clip index, then end frame, then start frame.
inline bool match_less(const ClipMatch& x, const ClipMatch& y) {
  if (x.score != y.score) return x.score < y.score;
  if (x.clip != y.clip) return x.clip < y.clip;
  if (x.end != y.end) return x.end < y.end;
  return x.start < y.start;
}

// The shared top-r list of one pair; tau is the r-th best score (until r
// matches are in: `ceiling`, +inf unless a collection's other shards already
// hold r matches that rank before any of this index's at that score).
// Thread-safe; tau only decreases.
class TopMatches {
 public:
  explicit TopMatches(std::size_t r, double ceiling = std::numeric_limits<double>::infinity())
      : r_(r), tau_(ceiling) {}
  double tau() const { return tau_.load(std::memory_order_acquire); }
  void insert(const ClipMatch& m) {
    std::lock_guard lock(mutex_);
    auto it = std::lower_bound(matches_.begin(), matches_.end(), m, match_less);
    matches_.insert(it, m);
    if (matches_.size() > r_) matches_.pop_back();
    if (matches_.size() == r_ && matches_.back().score < tau_.load(std::memory_order_relaxed))
      tau_.store(matches_.back().score, std::memory_order_release);
  }
  // The matches, best first (at most r); the list is left empty.
  std::vector<ClipMatch> take() { return std::move(matches_); }

 private:
  std::size_t r_;
  std::mutex mutex_;
  std::vector<ClipMatch> matches_;
  std::atomic<double> tau_{std::numeric_limits<double>::infinity()};
};

}  // namespace mocap::search_detail
