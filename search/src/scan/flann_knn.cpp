// FLANN's templates produce -Wnull-dereference (and friends) after inlining,
// which a system-header pragma does not silence: this file turns them off.
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#include "scan/flann_knn.hpp"

#include "scan/flann_wrapper.hpp"

namespace mocap::search_detail {

struct KnnIndex::Impl {
  flann::Index<flann::L2<float>> index;
  Impl(const float* points, std::size_t n, std::size_t dim, int trees)
      : index(flann::Matrix<float>(const_cast<float*>(points), n, dim),
              flann::KDTreeIndexParams(trees)) {}
};

KnnIndex::KnnIndex(const float* points, std::size_t n, std::size_t dim, int trees)
    : impl_(std::make_unique<Impl>(points, n, dim, trees)), dim_(dim), n_(n) {
  impl_->index.buildIndex();
}

KnnIndex::~KnnIndex() = default;

void KnnIndex::knn(const float* query, std::size_t k, int checks,
                   std::vector<std::size_t>& out) const {
  k = std::min(k, n_);
  out.assign(k, n_);
  std::vector<float> dist(k);
  flann::Matrix<float> q(const_cast<float*>(query), 1, dim_);
  flann::Matrix<std::size_t> im(out.data(), 1, k);
  flann::Matrix<float> dm(dist.data(), 1, k);
  flann::SearchParams params(checks);
  params.cores = 1;
  impl_->index.knnSearch(q, im, dm, k, params);
  std::vector<std::size_t> valid;
  for (std::size_t i : out)
    if (i < n_) valid.push_back(i);
  out.swap(valid);
}

}  // namespace mocap::search_detail
