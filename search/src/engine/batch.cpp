// Query batches: reading JSONL batches and single queries, running a batch
// in parallel, and the contract's output line per query (search.hpp).
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <mutex>
#include <nlohmann/json.hpp>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/search/batch_entry.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

namespace {

// How many lines and bytes a query spread over lines may take for the hint
// below (it tries each start once: a bad batch costs at most that much more).
constexpr std::size_t kSpreadQueryLines = 400;
constexpr std::size_t kSpreadQueryBytes = 64 * 1024;

// A query written over several lines (as docs show them) and pasted into a
// batch: each of its lines is invalid JSON alone. Where the lines from an
// entry that is not JSON on to a later one make one JSON object together,
// each of those entries' errors says so and how to fix it.
void hint_spread_queries(std::vector<BatchEntry>& entries,
                         const std::vector<std::string_view>& lines,
                         const std::filesystem::path& path) {
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const std::size_t first = lines[i].find_first_not_of(" \t");
    if (entries[i].error.empty() || lines[i][first] != '{' || nlohmann::json::accept(lines[i]))
      continue;
    std::string joined(lines[i]);
    std::size_t end = i;
    bool one_object = false;
    while (!one_object && end + 1 < entries.size() && end - i < kSpreadQueryLines &&
           joined.size() < kSpreadQueryBytes && entries[end + 1].error.size()) {
      joined += '\n';
      joined += lines[++end];
      const auto j = nlohmann::json::parse(joined, nullptr, false);
      if (j.is_discarded()) continue;
      if (!j.is_object()) break;
      one_object = true;
    }
    if (!one_object) continue;
    const std::string hint = fmt::format(
        " (lines {}-{} are one query spread over several lines: a batch holds one query per "
        "line; join each onto one line, e.g. `jq -c . FILE`, or give a single query with "
        "--query)",
        entries[i].line, entries[end].line);
    for (std::size_t k = i; k <= end; ++k) {
      const InputError with(
          path.string(), entries[k].line,
          (entries[k].failure ? entries[k].failure->detail() : "invalid JSON") + hint);
      entries[k].error = with.what();
      entries[k].failure = with;
    }
    i = end;
  }
}

}  // namespace

std::vector<BatchEntry> read_query_batch(const std::filesystem::path& path) {
  const FileBytes text = read_input_file(path, input_limits().batch_bytes);
  std::vector<BatchEntry> out;
  std::vector<std::string_view> lines;  // of each entry, for the hint
  const std::filesystem::path base = path.parent_path();
  for_each_line(text.view(), [&](std::string_view line, std::size_t n) {
    if (line.find_first_not_of(" \t\r") != std::string_view::npos) {
      out.push_back(
          parse_batch_entry(std::string(line), path.string(), n, base, fmt::format("line {}", n)));
      lines.push_back(line);
    }
    return true;
  });
  hint_spread_queries(out, lines, path);
  return out;
}

std::vector<BatchEntry> require_queries(std::vector<BatchEntry> entries,
                                        const std::filesystem::path& path, bool allow_empty) {
  if (entries.empty() && !allow_empty)
    throw InputError(path.string(), 0,
                     "holds no query (one JSON query per line, docs/queries.md; "
                     "--allow-empty accepts an empty batch)");
  return entries;
}

std::vector<BatchEntry> read_single_query(const std::filesystem::path& path) {
  const FileBytes text = read_input_file(path, input_limits().json_file_bytes);
  BatchEntry e;
  e.id = path.stem().string();
  try {
    e.query =
        parse_query_text(std::string(text.view()), path.string(), 0, path.parent_path(), e.id);
    e.id = e.query->id;
  } catch (const InputError& err) {
    e.error = err.what();
    e.failure = err;
  }
  return {std::move(e)};
}

namespace {
// Whether a query frame surely moves the whole body other than by a root
// position alone (a heading, or a root position with joint rotations), so
// that partial_approximate_energy reads the frame arrays. A frame giving
// joint rotations alone moves the whole body when one is the root's: the
// arrays are then loaded on first use. Full frames, root positions alone and
// joint rotations alone read none (joint rotations: per-joint columns,
// streamed on first use).
bool reads_frame_arrays(const QueryFrameSpec& f) {
  if (f.bvh && f.only.empty()) return false;
  bool root_position = false, heading = f.root_heading_deg.has_value(), joints = !f.joints.empty();
  for (const auto& c : f.root_position_m) root_position = root_position || c.has_value();
  for (const std::string& o : f.only) {
    if (o == "root_position" || o == "root_position_xz")
      root_position = true;
    else if (o == "root_heading")
      heading = true;
    else
      joints = true;
  }
  return heading || (root_position && joints);
}

// A result's residuals, its verdicts and misfit (docs/queries.md "Residuals
// and verdicts"): "residuals" {"from": {NAME: r}, "to": {...}} as before,
// "verdicts" the same names with residual, tolerance, limit, unit and met,
// "met" every constraint met, "misfit" the tie-break key.
void add_verdicts(const SearchResult& r, nlohmann::ordered_json& rj) {
  nlohmann::ordered_json res = nlohmann::ordered_json::object();
  nlohmann::ordered_json verdicts = nlohmann::ordered_json::object();
  for (const auto* side : {&r.residuals_from, &r.residuals_to}) {
    if (side->empty()) continue;
    const char* key = side == &r.residuals_from ? "from" : "to";
    nlohmann::ordered_json by_name = nlohmann::ordered_json::object();
    nlohmann::ordered_json verdict = nlohmann::ordered_json::object();
    for (const ConstraintResidual& c : *side) {
      by_name[c.name] = c.residual;
      verdict[c.name] = {{"residual", c.residual},
                         {"tolerance", c.tolerance},
                         {"limit", c.limit()},
                         {"unit", c.metres ? "m" : "deg"},
                         {"met", c.met()}};
    }
    res[key] = std::move(by_name);
    verdicts[key] = std::move(verdict);
  }
  rj["residuals"] = std::move(res);
  rj["verdicts"] = std::move(verdicts);
  rj["met"] = r.met();
  rj["misfit"] = r.misfit();
}
}  // namespace

std::vector<QueryOutcome> run_query_batch(
    const SearchEngine& engine, const std::vector<BatchEntry>& batch, const SearchOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress,
    const std::vector<std::vector<double>>* ceilings) {
  BatchControl control;
  if (ceilings) control.ceilings = [ceilings](std::size_t i) { return (*ceilings)[i]; };
  return run_query_batch(engine, batch, options, control, progress);
}

std::vector<QueryOutcome> run_query_batch(
    const SearchEngine& engine, const std::vector<BatchEntry>& batch, const SearchOptions& options,
    const BatchControl& control, const std::function<void(std::size_t, std::size_t)>& progress) {
  validate_search_options(options);
  bool whole_body = false;
  for (const BatchEntry& e : batch)
    if (e.query)
      for (const QueryFrameSpec& f : e.query->frames)
        whole_body = whole_body || reads_frame_arrays(f);
  engine.prepare(options, whole_body);
  std::vector<QueryOutcome> out(batch.size());
  std::mutex progress_mutex;
  std::size_t done = 0;
  const std::size_t n = batch.size();
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
    const std::size_t i = (k + control.first) % n;
    const BatchEntry& e = batch[i];
    if (!e.query) {
      out[i].id = e.id;
      out[i].error = e.error;
    } else {
      try {
        std::vector<double> ceilings;
        if (control.ceilings) ceilings = control.ceilings(i);
        out[i] = engine.run(*e.query, options, ceilings.empty() ? nullptr : &ceilings);
      } catch (const InputError& err) {  // bad input; a bug is not caught here
        out[i] = QueryOutcome{};
        out[i].id = e.id;
        out[i].error = err.what();
      }
    }
    if (control.answered) control.answered(i, out[i]);
    if (progress) {
      std::lock_guard lock(progress_mutex);
      progress(++done, n);
    }
  });
  return out;
}

std::string query_outcome_json(const QueryOutcome& o) {
  nlohmann::ordered_json j;
  j["id"] = o.id;
  if (o.error) {
    j["error"] = *o.error;
    return json_text(j);
  }
  j["pairs"] = nlohmann::ordered_json::array();
  for (const PairResults& p : o.pairs) {
    nlohmann::ordered_json pj;
    pj["from"] = p.from;
    pj["to"] = p.to;
    pj["results"] = nlohmann::ordered_json::array();
    for (const SearchResult& r : p.results) {
      nlohmann::ordered_json rj;
      rj["rank"] = r.rank;
      rj["clip"] = r.clip;
      rj["clip_index"] = r.clip_index;
      nlohmann::ordered_json labels = nlohmann::ordered_json::object();
      for (const auto& [k, v] : r.labels) labels[k] = v;
      rj["labels"] = labels;
      rj["start_frame"] = r.start_frame;
      rj["end_frame"] = r.end_frame;
      rj["score_J"] = r.score_J;
      rj["h_in_J"] = r.h_in_J;
      rj["h_out_J"] = r.h_out_J;
      rj["path_cost_J"] = r.path_cost_J;
      if (r.context) {
        rj["context_in_J"] = r.context_in_J;
        rj["context_out_J"] = r.context_out_J;
      }
      if (r.style) rj["style_J"] = r.style_J;
      if (!r.residuals_from.empty() || !r.residuals_to.empty()) add_verdicts(r, rj);
      if (!r.recognised_style.empty())
        rj["recognised_style"] = {{"label", r.recognised_style}, {"p", r.recognised_style_p}};
      pj["results"].push_back(std::move(rj));
    }
    j["pairs"].push_back(std::move(pj));
  }
  if (!o.warnings.empty()) j["warnings"] = o.warnings;
  nlohmann::ordered_json s;
  s["clips"] = o.stats.clips;
  s["clips_pruned"] = o.stats.clips_pruned;
  s["frames_evaluated"] = o.stats.frames_evaluated;
  s["frames_pruned"] = o.stats.frames_pruned;
  s["time_ms"] = o.stats.time_ms;
  if (o.stats.recall) s["recall"] = *o.stats.recall;
  j["stats"] = s;
  return json_text(j);
}

}  // namespace mocap
