#pragma once
// Internal to mocap_search: minima over sliding windows, for the length
// limits of a partial motion in the world clip scans. A pair s < e counts
// only when min_gap <= e - s <= max_gap, so the best partner of a frame is a
// minimum over a window of frames (or of 16-frame blocks) that moves with
// the frame: a monotone deque (WindowMin, with the argmin) or van Herk /
// Gil-Werman runs (FixedWindowMinima, all windows of one width), O(n) for n
// values.
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

// The minima of all windows of `width` consecutive values of x over an
// index range [begin, end) (windows cut to the range), van Herk /
// Gil-Werman: per run of `width` values from `begin`, the running minima
// from the run's start (prefix) and to its end (suffix); a window spans at
// most two runs, so its minimum is the suffix at its first value and the
// prefix at its last. Two passes without branches on the values: the world
// scans take them per frame.
class FixedWindowMinima {
 public:
  // x[i] = value(i) for i in [begin, end); windows of `width` >= 1 values.
  template <class Value>
  void build(std::size_t begin, std::size_t end, std::size_t width, Value value) {
    begin_ = begin;
    n_ = end > begin ? end - begin : 0;
    width_ = std::min(width, std::max<std::size_t>(n_, 1));
    prefix_.resize(n_);
    suffix_.resize(n_);
    last_start_ = 0;
    for (std::size_t r0 = 0; r0 < n_; r0 += width_) {
      const std::size_t r1 = std::min(n_, r0 + width_);
      last_start_ = r0;
      double m = kInf_;
      for (std::size_t i = r0; i < r1; ++i) {
        const double v = value(begin + i);
        suffix_[i] = v;
        m = std::min(m, v);
        prefix_[i] = m;
      }
      m = kInf_;
      for (std::size_t i = r1; i-- > r0;) suffix_[i] = m = std::min(m, suffix_[i]);
    }
    width_ = width;  // the windows' own width (the runs are cut to the range)
  }
  // min x over [first, first + width) cut to [begin, end); +inf when that is
  // empty. `first` may lie before begin (or before 0).
  double window(std::ptrdiff_t first) const {
    const std::ptrdiff_t lo = first - static_cast<std::ptrdiff_t>(begin_);
    const std::ptrdiff_t hi = lo + static_cast<std::ptrdiff_t>(width_) - 1;
    const auto n = static_cast<std::ptrdiff_t>(n_);
    if (hi < 0 || lo >= n) return kInf_;
    if (lo < 0) {
      // Cut at the start: [0, hi] lies in the first run (or the range is
      // shorter than a window: one run).
      return prefix_[static_cast<std::size_t>(std::min(hi, n - 1))];
    }
    const auto l = static_cast<std::size_t>(lo);
    if (hi < n) return std::min(suffix_[l], prefix_[static_cast<std::size_t>(hi)]);
    // Cut at the end: within the last run, or into it from the one before.
    return l >= last_start_ ? suffix_[l] : std::min(suffix_[l], prefix_[n_ - 1]);
  }

 private:
  static constexpr double kInf_ = std::numeric_limits<double>::infinity();
  std::vector<double> prefix_, suffix_;
  std::size_t begin_ = 0, n_ = 0, width_ = 1, last_start_ = 0;
};

}  // namespace mocap::search_detail
