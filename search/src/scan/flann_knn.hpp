#pragma once
// Internal to mocap_search: FLANN randomised kd-trees behind a small
// interface, so that FLANN's headers are compiled in one translation unit
// (flann_knn.cpp) with its warnings silenced.
#include <cstddef>
#include <memory>
#include <vector>

namespace mocap::search_detail {

class KnnIndex {
 public:
  /// Builds `trees` randomised kd-trees over n points of `dim` floats (row
  /// major, not copied: `points` must outlive the index).
  KnnIndex(const float* points, std::size_t n, std::size_t dim, int trees);
  ~KnnIndex();
  KnnIndex(const KnnIndex&) = delete;
  KnnIndex& operator=(const KnnIndex&) = delete;
  /// Approximate k nearest points (squared L2) of `query`, visiting at most
  /// `checks` leaves; indices in `out` (size <= k). Thread-safe.
  void knn(const float* query, std::size_t k, int checks, std::vector<std::size_t>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t dim_ = 0, n_ = 0;
};

}  // namespace mocap::search_detail
