#pragma once
// Timed key poses (docs/queries.md "Timed key poses"): how the time between
// two key poses is shared between the partial motion and its two
// transitions, and how far the partial motion may be time-warped. Search
// (which partial motions fit) and synthesis (where the frames go) both use it.
#include <cstddef>

namespace mocap {

/// A partial motion may be played at most this much slower or faster than
/// captured (its played length over its captured length).
inline constexpr double kMinTimeWarp = 0.8, kMaxTimeWarp = 1.25;

/// One pair of key poses Q^h (at t) and Q^h+1 (at t + interval).
struct TimedPairWindow {
  /// Each transition's share of the interval, seconds: the query's
  /// transition time, at most a quarter of the interval.
  double transition_s = 0.0;
  /// The partial motion's played length: the interval less both
  /// transitions, seconds.
  double played_s = 0.0;
  /// Captured lengths that fit by a warp within [kMinTimeWarp,
  /// kMaxTimeWarp], seconds, and at least `min_length_s`.
  double min_length_s = 0.0, max_length_s = 0.0;
  /// No captured length fits (max_length_s < the minimum): the pair is
  /// filled by one transition from Q^h to Q^h+1 (synthesis), the search
  /// ranking partial motions of the minimum length.
  bool direct = false;
};

/// The window of a pair `interval_s` apart (> 0) with the query's
/// transition time and minimum partial-motion length (both > 0).
inline TimedPairWindow timed_pair_window(double interval_s, double transition_time_s,
                                         double min_length_s) {
  TimedPairWindow w;
  w.transition_s = interval_s / 4 < transition_time_s ? interval_s / 4 : transition_time_s;
  w.played_s = interval_s - 2 * w.transition_s;
  w.max_length_s = w.played_s / kMinTimeWarp;
  const double lo = w.played_s / kMaxTimeWarp;
  w.min_length_s = lo > min_length_s ? lo : min_length_s;
  w.direct = w.max_length_s < min_length_s;
  if (w.direct) w.max_length_s = w.min_length_s = min_length_s;
  return w;
}

}  // namespace mocap
