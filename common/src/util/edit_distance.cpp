// Edit distances between names (edit_distance.hpp).
#include "mocap/common/util/edit_distance.hpp"

#include <algorithm>
#include <cctype>
#include <utility>
#include <vector>

namespace mocap {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // Two rows of the dynamic-programming table.
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string ascii_lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string closest_name(std::string_view key, const std::vector<std::string>& names,
                         std::size_t max_distance) {
  const std::string lower_key = ascii_lower(key);
  const std::string* best = nullptr;
  std::size_t best_distance = max_distance + 1;
  for (const std::string& n : names) {
    const std::size_t d = edit_distance(lower_key, ascii_lower(n));
    if (d < best_distance) best = &n, best_distance = d;
  }
  return best ? *best : std::string();
}

}  // namespace mocap
