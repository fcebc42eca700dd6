// The order of a pair's results (ranking.hpp).
#include "engine/ranking.hpp"

#include <algorithm>
#include <limits>

namespace mocap {

double ConstraintResidual::limit() const {
  return std::max(tolerance, metres ? kMetFloorM : kMetFloorDeg);
}

bool SearchResult::met() const {
  for (const auto* side : {&residuals_from, &residuals_to})
    for (const ConstraintResidual& c : *side)
      if (!c.met()) return false;
  return true;
}

double SearchResult::misfit() const {
  double sum = 0.0;
  for (const auto* side : {&residuals_from, &residuals_to})
    for (const ConstraintResidual& c : *side) sum += c.residual / c.limit();
  return sum;
}

}  // namespace mocap

namespace mocap::search_detail {

bool ranks_before(const SearchResult& x, const SearchResult& y, MetPolicy policy) {
  if (policy != MetPolicy::any) {
    const bool xm = x.met(), ym = y.met();
    if (xm != ym) return xm;
  }
  if (x.score_J != y.score_J) return x.score_J < y.score_J;
  const double xf = x.misfit(), yf = y.misfit();
  if (xf != yf) return xf < yf;
  if (x.clip_index != y.clip_index) return x.clip_index < y.clip_index;
  if (x.end_frame != y.end_frame) return x.end_frame < y.end_frame;
  return x.start_frame < y.start_frame;
}

void rank_results(std::vector<SearchResult>& results, MetPolicy policy, std::size_t top) {
  std::stable_sort(results.begin(), results.end(),
                   [policy](const SearchResult& x, const SearchResult& y) {
                     return ranks_before(x, y, policy);
                   });
  if (policy == MetPolicy::only)
    results.erase(std::remove_if(results.begin(), results.end(),
                                 [](const SearchResult& r) { return !r.met(); }),
                  results.end());
  if (results.size() > top) results.resize(top);
  for (std::size_t i = 0; i < results.size(); ++i) results[i].rank = i + 1;
}

bool ranking_settled(const std::vector<SearchResult>& fetched, std::size_t asked, MetPolicy policy,
                     std::size_t top) {
  if (top == 0 || fetched.size() < asked) return true;
  double worst = -std::numeric_limits<double>::infinity();
  std::vector<double> needed;  // the scores of the results the ranking may take
  for (const SearchResult& r : fetched) {
    worst = std::max(worst, r.score_J);
    if (policy == MetPolicy::any || r.met()) needed.push_back(r.score_J);
  }
  if (needed.size() < top) return false;
  std::nth_element(needed.begin(), needed.begin() + static_cast<std::ptrdiff_t>(top - 1),
                   needed.end());
  return needed[top - 1] < worst;
}

std::size_t deepest_look(std::size_t top) {
  return std::max<std::size_t>(32 * top, 256);
}

}  // namespace mocap::search_detail
