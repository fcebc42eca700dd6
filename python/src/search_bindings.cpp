// _mocap.Index.search: a query batch on the shared engine. Queries come in as
// JSON texts (the Python layer dumps its dicts) and are parsed as a batch
// file's lines are (parse_batch_entry); each outcome goes out as the contract
// line of mocap-search (query_outcome_json), which the Python layer loads:
// the same fields, written by the same code.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <tbb/global_control.h>

#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/batch_entry.hpp"
#include "mocap/search/recognised_styles.hpp"
#include "mocap/search/search.hpp"

namespace mocap::python {

namespace {

std::vector<std::string> search(const std::shared_ptr<OpenIndex>& self,
                                const std::vector<std::string>& queries,
                                const std::filesystem::path& base_dir, const std::string& mode,
                                double min_length_s, double max_length_s, int approx_checks,
                                int approx_trees, bool compute_recall, int threads,
                                bool raise_errors, const std::string& style_model) {
  SearchOptions options;
  const auto m = parse_search_mode(mode);
  if (!m) throw InputError("mode", 0, "expected exact, approx or brute, got '" + mode + "'");
  options.mode = *m;
  options.min_length_s = min_length_s;
  options.max_length_s = max_length_s;
  if (approx_checks < 1) throw InputError("checks", 0, "must be >= 1");
  if (approx_trees < 1) throw InputError("trees", 0, "must be >= 1");
  if (threads < 0) throw InputError("threads", 0, "must be >= 0 (0: all cores)");
  options.approx_checks = approx_checks;
  options.approx_trees = approx_trees;
  options.compute_recall = compute_recall;
  validate_search_options(options, "min_length_s", "max_length_s");
  std::shared_ptr<const StyleModel> styles;
  if (!style_model.empty())
    styles = std::make_shared<const StyleModel>(
        style_model_from_json(nlohmann::json::parse(style_model), "style_model"));
  options.style_model = styles;
  const auto labelled = [&](std::vector<QueryOutcome> outcomes) {
    if (styles) add_recognised_styles(*styles, ClipSource(self->index()), outcomes);
    return outcomes;
  };

  std::vector<std::string> lines;
  {
    py::gil_scoped_release release;
    std::vector<BatchEntry> batch;
    batch.reserve(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const std::string n = std::to_string(i + 1);
      batch.push_back(
          parse_batch_entry(queries[i], "<query " + n + ">", 0, base_dir, "query " + n));
    }
    std::optional<tbb::global_control> parallelism;
    if (threads > 0)
      parallelism.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<std::size_t>(threads));
    // One query asked for alone: its error is raised (mocap.InputError),
    // not returned as an error line.
    if (raise_errors && batch.size() == 1) {
      if (batch[0].failure) throw *batch[0].failure;
      return {query_outcome_json(labelled({self->engine().run(*batch[0].query, options)})[0])};
    }
    const std::vector<QueryOutcome> outcomes =
        labelled(run_query_batch(self->engine(), batch, options));
    lines.reserve(outcomes.size());
    for (const QueryOutcome& o : outcomes) lines.push_back(query_outcome_json(o));
  }
  return lines;
}

}  // namespace

void bind_search(py::module_& m) {
  auto index =
      py::reinterpret_borrow<py::class_<OpenIndex, std::shared_ptr<OpenIndex>>>(m.attr("Index"));
  const SearchOptions defaults;
  index.def("search", &search, py::arg("queries"), py::arg("base_dir"), py::arg("mode") = "exact",
            py::arg("min_length_s") = defaults.min_length_s,
            py::arg("max_length_s") = defaults.max_length_s,
            py::arg("checks") = defaults.approx_checks, py::arg("trees") = defaults.approx_trees,
            py::arg("recall") = defaults.compute_recall, py::arg("threads") = 0,
            py::arg("raise_errors") = false, py::arg("style_model") = "",
            "Answers a batch of queries (JSON texts, docs/queries.md); returns one mocap-search "
            "output line (JSON text) per query, in order. Relative paths in the queries resolve "
            "against base_dir; a query without an id gets 'query N' (1-based). With "
            "raise_errors and one query, a query that cannot be answered raises InputError "
            "instead of giving an error line.");
}

}  // namespace mocap::python
