// The MPI-free parts of a distributed search (distributed.hpp).
#include "mocap/search/distributed.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <stdexcept>

namespace mocap {

namespace {
using json = nlohmann::json;
constexpr double kInf = std::numeric_limits<double>::infinity();

json result_json(const SearchResult& r) {
  json labels = json::array();
  for (const auto& [k, v] : r.labels) labels.push_back({k, v});
  json from = json::array(), to = json::array();
  for (const ConstraintResidual& c : r.residuals_from)
    from.push_back({c.name, c.residual, c.tolerance, c.metres});
  for (const ConstraintResidual& c : r.residuals_to)
    to.push_back({c.name, c.residual, c.tolerance, c.metres});
  return {r.rank,    r.clip_index,   r.clip,          labels,        r.start_frame, r.end_frame,
          r.score_J, r.h_in_J,       r.h_out_J,       r.path_cost_J, from,          to,
          r.context, r.context_in_J, r.context_out_J, r.style,       r.style_J};
}

SearchResult result_from(const json& j) {
  SearchResult r;
  r.rank = j.at(0).get<std::size_t>();
  r.clip_index = j.at(1).get<std::size_t>();
  r.clip = j.at(2).get<std::string>();
  for (const json& l : j.at(3)) r.labels.emplace_back(l.at(0), l.at(1));
  r.start_frame = j.at(4).get<std::size_t>();
  r.end_frame = j.at(5).get<std::size_t>();
  r.score_J = j.at(6).get<double>();
  r.h_in_J = j.at(7).get<double>();
  r.h_out_J = j.at(8).get<double>();
  r.path_cost_J = j.at(9).get<double>();
  for (const std::size_t side : {10, 11})
    for (const json& x : j.at(side))
      (side == 10 ? r.residuals_from : r.residuals_to)
          .push_back({x.at(0).get<std::string>(), x.at(1).get<double>(), x.at(2).get<double>(),
                      x.at(3).get<bool>()});
  r.context = j.at(12).get<bool>();
  r.context_in_J = j.at(13).get<double>();
  r.context_out_J = j.at(14).get<double>();
  r.style = j.at(15).get<bool>();
  r.style_J = j.at(16).get<double>();
  return r;
}

json outcome_json(const QueryOutcome& o) {
  json pairs = json::array();
  for (const PairResults& p : o.pairs) {
    json results = json::array();
    for (const SearchResult& r : p.results) results.push_back(result_json(r));
    pairs.push_back({p.from, p.to, results});
  }
  const SearchStats& s = o.stats;
  json stats = {s.clips,         s.clips_pruned, s.frames_evaluated,
                s.frames_pruned, s.time_ms,      s.recall ? json(*s.recall) : json(nullptr)};
  return {o.id, o.error ? json(*o.error) : json(nullptr), pairs, stats, o.warnings};
}

QueryOutcome outcome_from(const json& j) {
  QueryOutcome o;
  o.id = j.at(0).get<std::string>();
  if (!j.at(1).is_null()) o.error = j.at(1).get<std::string>();
  for (const json& p : j.at(2)) {
    PairResults pr;
    pr.from = p.at(0).get<std::size_t>();
    pr.to = p.at(1).get<std::size_t>();
    for (const json& r : p.at(2)) pr.results.push_back(result_from(r));
    o.pairs.push_back(std::move(pr));
  }
  if (j.size() > 4) o.warnings = j.at(4).get<std::vector<std::string>>();
  const json& s = j.at(3);
  o.stats.clips = s.at(0).get<std::uint64_t>();
  o.stats.clips_pruned = s.at(1).get<std::uint64_t>();
  o.stats.frames_evaluated = s.at(2).get<std::uint64_t>();
  o.stats.frames_pruned = s.at(3).get<std::uint64_t>();
  o.stats.time_ms = s.at(4).get<double>();
  if (!s.at(5).is_null()) o.stats.recall = s.at(5).get<double>();
  return o;
}
}  // namespace

const char* distribution_name(Distribution d) {
  return d == Distribution::shards ? "shards" : "queries";
}

std::optional<Distribution> parse_distribution(const std::string& s) {
  if (s == "shards") return Distribution::shards;
  if (s == "queries") return Distribution::queries;
  return std::nullopt;
}

Distribution choose_distribution(std::uint64_t frames, std::size_t shards, std::size_t ranks,
                                 std::size_t ranks_per_node, std::uint64_t node_memory_bytes) {
  if (shards <= 1 || shards < ranks) return Distribution::queries;
  // In long double: frames x bytes x ranks may pass 2^64 for a huge collection.
  const long double need = static_cast<long double>(frames) * kSearchResidentBytesPerFrame *
                           static_cast<long double>(std::max<std::size_t>(ranks_per_node, 1));
  return need <= static_cast<long double>(node_memory_bytes) / 2 ? Distribution::queries
                                                                 : Distribution::shards;
}

std::vector<std::vector<std::size_t>> assign_shards(const CollectionManifest& manifest,
                                                    std::size_t ranks) {
  if (ranks == 0) throw std::invalid_argument("assign_shards: no ranks");
  std::vector<std::size_t> order(manifest.shards.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return manifest.shards[a].frames > manifest.shards[b].frames;
  });
  std::vector<std::vector<std::size_t>> out(ranks);
  std::vector<std::uint64_t> load(ranks, 0);
  for (const std::size_t s : order) {
    const std::size_t r =
        static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    out[r].push_back(s);
    load[r] += manifest.shards[s].frames;
  }
  for (auto& shards : out) std::sort(shards.begin(), shards.end());
  return out;
}

std::vector<double> rth_best_scores(const QueryOutcome& outcome, std::size_t top) {
  std::vector<double> out(outcome.pairs.size(), kInf);
  for (std::size_t h = 0; h < outcome.pairs.size(); ++h) {
    const auto& results = outcome.pairs[h].results;
    if (top > 0 && results.size() >= top) out[h] = results[top - 1].score_J;
  }
  return out;
}

double shared_ceiling(double own, double shared) {
  return std::min(own, std::isinf(shared) ? kInf : std::nextafter(shared, kInf));
}

std::string encode_outcomes(const std::vector<QueryOutcome>& outcomes) {
  json all = json::array();
  for (const QueryOutcome& o : outcomes) all.push_back(outcome_json(o));
  const std::vector<std::uint8_t> bytes = json::to_cbor(all);
  return std::string(bytes.begin(), bytes.end());
}

std::vector<QueryOutcome> decode_outcomes(std::string_view bytes) {
  try {
    const json all = json::from_cbor(bytes.begin(), bytes.end());
    std::vector<QueryOutcome> out;
    for (const json& o : all) out.push_back(outcome_from(o));
    return out;
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("decode_outcomes: not encoded outcomes: ") + e.what());
  }
}

std::string encode_label_values(const LabelValues& values) {
  json all = json::object();
  for (const auto& [key, set] : values) all[key] = std::vector<std::string>(set.begin(), set.end());
  const std::vector<std::uint8_t> bytes = json::to_cbor(all);
  return std::string(bytes.begin(), bytes.end());
}

LabelValues decode_label_values(std::string_view bytes) {
  try {
    const json all = json::from_cbor(bytes.begin(), bytes.end());
    if (!all.is_object()) throw std::invalid_argument("decode_label_values: not an object");
    LabelValues out;
    for (auto it = all.begin(); it != all.end(); ++it)
      for (const json& v : it.value()) out[it.key()].insert(v.get<std::string>());
    return out;
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("decode_label_values: not encoded label values: ") +
                                e.what());
  }
}

}  // namespace mocap
