#pragma once
// Internal to mocap_search: minima over sliding windows (a monotone deque),
// for the length limits of a partial motion in the world clip scans. A pair
// s < e counts only when min_gap <= e - s <= max_gap, so the best partner of
// a frame is a minimum over a window of frames (or of 16-frame blocks) whose
// ends move forward with the frame: O(n + m) for m windows over n values.
#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace mocap::search_detail {

// The least value of a window of entries, and its index. Entries enter in
// increasing index order and leave from the oldest (drop_before); among
// equal values the earliest index is the one in front.
class WindowMin {
 public:
  struct Entry {
    std::size_t index;
    double value;
  };
  // `storage` is grown to hold `n` entries: every entry that will enter.
  WindowMin(std::vector<Entry>& storage, std::size_t n) {
    if (storage.size() < n) storage.resize(n);
    q_ = storage.data();
  }
  void push(std::size_t index, double value) {
    while (tail_ > head_ && q_[tail_ - 1].value > value) --tail_;  // strict: the earlier stays
    q_[tail_++] = {index, value};
  }
  // Drops the entries of index < first.
  void drop_before(std::size_t first) {
    while (head_ < tail_ && q_[head_].index < first) ++head_;
  }
  bool empty() const { return head_ == tail_; }
  // +inf when empty.
  double min() const { return empty() ? std::numeric_limits<double>::infinity() : q_[head_].value; }
  // The index of min() (not empty).
  std::size_t argmin() const { return q_[head_].index; }

 private:
  Entry* q_ = nullptr;
  std::size_t head_ = 0, tail_ = 0;
};

// For every window i < m: emit(i, min of value(j) over j in [first(i),
// end(i))), +inf when the window is empty (first(i) >= end(i)). end(i) <= n,
// and neither first(i) nor end(i) decreases with i. Scratch: one buffer per
// thread and instantiation.
template <class First, class End, class Value, class Emit>
void window_minima(std::size_t n, std::size_t m, First first, End end, Value value, Emit emit) {
  thread_local std::vector<WindowMin::Entry> storage;
  WindowMin window(storage, n);
  std::size_t next = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t f = first(i), e = end(i);
    for (next = std::max(next, f); next < e; ++next) window.push(next, value(next));
    window.drop_before(f);
    emit(i, window.min());
  }
}

// The minima of all windows of `width` consecutive values of x[0, n) (cut
// to the array), van Herk / Gil-Werman: per run of `width` values from the
// start, the running minima from the run's start (prefix) and to its end
// (suffix); a window spans at most two runs, so its minimum is the suffix
// at its first value and the prefix at its last. Two passes without
// branches on the values: the bounds of the world scans take them per frame.
class FixedWindowMinima {
 public:
  // x[i] = value(i), windows of `width` >= 1 values.
  template <class Value>
  void build(std::size_t n, std::size_t width, Value value) {
    n_ = n;
    width_ = std::min(width, std::max<std::size_t>(n, 1));
    prefix_.resize(n);
    suffix_.resize(n);
    last_start_ = 0;
    for (std::size_t r0 = 0; r0 < n; r0 += width_) {
      const std::size_t r1 = std::min(n, r0 + width_);
      last_start_ = r0;
      double m = kInf_;
      for (std::size_t i = r0; i < r1; ++i) {
        const double v = value(i);
        suffix_[i] = v;
        m = std::min(m, v);
        prefix_[i] = m;
      }
      m = kInf_;
      for (std::size_t i = r1; i-- > r0;) suffix_[i] = m = std::min(m, suffix_[i]);
    }
  }
  // min x[j, j + width) (cut to the array); +inf when j >= n.
  double from(std::size_t j) const {
    if (j >= n_) return kInf_;
    if (j + width_ <= n_) return std::min(suffix_[j], prefix_[j + width_ - 1]);
    // Cut by the end: within the last run, or into it from the one before.
    return j >= last_start_ ? suffix_[j] : std::min(suffix_[j], prefix_[n_ - 1]);
  }
  // min x(e - width, e] (cut to the array); e < n.
  double until(std::size_t e) const {
    if (e + 1 < width_) return prefix_[e];  // [0, e] lies in the first run
    return std::min(suffix_[e + 1 - width_], prefix_[e]);
  }

 private:
  static constexpr double kInf_ = std::numeric_limits<double>::infinity();
  std::vector<double> prefix_, suffix_;
  std::size_t n_ = 0, width_ = 1, last_start_ = 0;
};

}  // namespace mocap::search_detail
