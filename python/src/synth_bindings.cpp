// _mocap.Index.synthesize and _mocap.Synthesis: mocap-synth's job
// (synth_job.hpp) on an open index: the query's search (or given results),
// supplementation and assembly; the motion comes back as numpy arrays, BVH
// (write_motion_bvh, the command's writer) and the REPORT.json text
// (synth_report_json).
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/batch_entry.hpp"
#include "mocap/search/query.hpp"
#include "mocap/synth/synth_batch.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap::python {

namespace {

/// One synthesis and everything its report needs. Not movable once
/// synthesised: result.skeleton points at `skeleton`.
struct Synthesis {
  Synthesis(std::shared_ptr<OpenIndex> i, Query q)
      : index(std::move(i)), clips(index->index()), query(std::move(q)) {}
  Synthesis(const Synthesis&) = delete;
  Synthesis& operator=(const Synthesis&) = delete;

  std::shared_ptr<OpenIndex> index;
  ClipSource clips;
  Query query;
  std::vector<PairResults> ranked;
  SynthOptions options;
  std::optional<SynthSkeleton> skeleton;
  SynthResult result;
  double search_ms = 0.0;
  double total_ms = 0.0;

  std::size_t frame_count() const { return result.frames.size(); }
  std::size_t joint_count() const { return skeleton->joint_count(); }
};

struct SynthArgs {
  std::string method = "astar";
  std::vector<std::string> picks;
  std::size_t max_states = SupplementParams{}.max_states;
  double cost_threshold_J = SupplementParams{}.cost_threshold_J;
  bool step_feet = false;
  std::optional<bool> warp;  // unset: the default (timed queries warped)
  std::size_t warp_candidates = SynthOptions{}.warp_candidates;
  double warp_work_weight_m_per_J = SynthOptions{}.warp_work_weight_m_per_J;
  std::string energy = "w";
  std::optional<double> fps;
  std::size_t refine = 0;
  double refine_smoothing_J = 0.0;
  std::size_t refine_polish = 0;
  std::size_t refine_polish_window = 1;
  bool refine_polish_segments = false;
  double refine_polish_smoothing_J = 0.0;
  std::string style_model;  // JSON text of a style model; empty: none
  std::string style;        // style transfer toward it (needs style_model); empty: none
  double style_strength = 1.0;
};

// The options as mocap-synth builds them from its flags (the names are the
// Python keywords).
SynthOptions synth_options(const SynthArgs& a) {
  static const std::map<std::string, TransitionMethod> methods = {
      {"astar", TransitionMethod::astar},
      {"slerp", TransitionMethod::slerp},
      {"inertialize", TransitionMethod::inertialize}};
  SynthOptions o;
  if (!methods.count(a.method))
    throw InputError("method", 0, "expected astar, slerp or inertialize, got '" + a.method + "'");
  o.method = methods.at(a.method);
  if (a.max_states < 1) throw InputError("max_states", 0, "must be >= 1");
  if (!(a.cost_threshold_J >= 0.0)) throw InputError("cost_threshold_J", 0, "must be >= 0");
  for (const auto& [name, v] :
       {std::pair{"refine_smoothing_J", a.refine_smoothing_J},
        std::pair{"refine_polish_smoothing_J", a.refine_polish_smoothing_J}})
    if (!(std::isfinite(v) && v >= 0.0))
      throw InputError(name, 0, "must be a finite number of joules >= 0");
  if (a.refine_polish_window < 1) throw InputError("refine_polish_window", 0, "must be >= 1");
  if (a.fps && !(*a.fps > 0.0 && std::isfinite(*a.fps)))
    throw InputError("fps", 0, "must be a number of frames per second > 0");
  o.params.max_states = a.max_states;
  o.params.cost_threshold_J = a.cost_threshold_J;
  o.params.step_feet = a.step_feet;
  o.warp_fill = a.warp.value_or(true);
  o.warp_required = a.warp.value_or(false);
  if (a.warp_candidates < 1) throw InputError("warp_candidates", 0, "must be >= 1");
  o.warp_candidates = a.warp_candidates;
  if (!(std::isfinite(a.warp_work_weight_m_per_J) && a.warp_work_weight_m_per_J >= 0.0))
    throw InputError("warp_work_weight_m_per_J", 0,
                     "must be a finite number of metres per joule >= 0");
  o.warp_work_weight_m_per_J = a.warp_work_weight_m_per_J;
  if (a.energy != "g" && a.energy != "w")
    throw InputError("energy", 0, "expected g or w, got '" + a.energy + "'");
  o.params.energy = a.energy == "w" ? SearchEnergy::work : SearchEnergy::g;
  if (!a.style_model.empty())
    o.style_model = std::make_shared<const StyleModel>(
        style_model_from_json(nlohmann::json::parse(a.style_model), "style_model"));
  if (!a.style.empty() && !o.style_model)
    throw InputError("style", 0, "needs style_model= (a model of Index.style_model or its file)");
  o.style_transfer.style = a.style;
  o.style_transfer.strength = a.style_strength;
  o.params.refine.iterations = a.refine;
  o.params.refine.smoothing_J = a.refine_smoothing_J;
  o.params.refine.polish_sweeps = a.refine_polish;
  o.params.refine.polish_max_window = a.refine_polish_window;
  o.params.refine.polish_segment_moves = a.refine_polish_segments;
  o.params.refine.polish_smoothing_J = a.refine_polish_smoothing_J;
  o.fps = a.fps;
  for (const std::string& p : a.picks) o.picks.push_back(parse_pick(p));
  return o;
}

std::shared_ptr<Synthesis> synthesize_query(const std::shared_ptr<OpenIndex>& self,
                                            const std::string& query_text,
                                            const std::filesystem::path& base_dir,
                                            const std::optional<std::filesystem::path>& results,
                                            const SynthArgs& args, int threads) {
  if (threads < 0) throw InputError("threads", 0, "must be >= 0 (0: all cores)");
  const SynthOptions options = synth_options(args);
  py::gil_scoped_release release;
  const auto t0 = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> parallelism;
  if (threads > 0)
    parallelism.emplace(tbb::global_control::max_allowed_parallelism,
                        static_cast<std::size_t>(threads));
  auto s = std::make_shared<Synthesis>(
      self, query_for_fill(parse_query_text(query_text, "<query>", 0, base_dir, "query"), options));
  s->options = options;
  if (results) {
    s->ranked = read_search_results(*results, s->query.id, s->clips);
  } else {
    // As mocap-synth without --results: the default search options.
    const auto ts = std::chrono::steady_clock::now();
    QueryOutcome outcome = self->engine().run(s->query, synth_search_options(options.style_model));
    if (outcome.error) throw InputError("<query>", 0, "search failed: " + *outcome.error);
    s->ranked = std::move(outcome.pairs);
    s->search_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count();
  }
  s->result = synthesize(s->clips, s->query, s->ranked, s->options, s->skeleton);
  s->total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

// A query of the batch made: its Synthesis, holding the motion the batch
// handed over (the skeleton moved with it, the result pointed at it again).
std::shared_ptr<Synthesis> batch_synthesis(const std::shared_ptr<OpenIndex>& self,
                                           SynthBatchDone& done, const SynthOptions& options) {
  auto s = std::make_shared<Synthesis>(self, *done.query->query);
  s->ranked = done.query->ranked;
  s->options = options;
  s->skeleton = std::move(done.motion->skeleton);
  s->result = std::move(done.motion->result);
  s->result.skeleton = &*s->skeleton;
  s->search_ms = done.query->search_ms;
  s->total_ms = done.query->search_ms + done.synth_ms;
  return s;
}

// Index.synthesize_batch: per query (JSON texts) a Synthesis or, for a
// query that failed, a dict {"message", "source", "line", "detail"} (the
// Python layer makes it a mocap.InputError). Without the GIL while the
// batch runs.
py::list synthesize_batch(const std::shared_ptr<OpenIndex>& self,
                          const std::vector<std::string>& texts,
                          const std::filesystem::path& base_dir,
                          const std::optional<std::filesystem::path>& results,
                          const SynthArgs& args, int threads) {
  if (threads < 0) throw InputError("threads", 0, "must be >= 0 (0: all cores)");
  const SynthOptions options = synth_options(args);
  std::vector<std::shared_ptr<Synthesis>> made(texts.size());
  std::vector<std::optional<InputError>> errors(texts.size());
  {
    py::gil_scoped_release release;
    std::optional<tbb::global_control> parallelism;
    if (threads > 0)
      parallelism.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<std::size_t>(threads));
    std::vector<BatchEntry> entries;
    for (std::size_t i = 0; i < texts.size(); ++i) {
      const std::string n = std::to_string(i + 1);
      entries.push_back(
          parse_batch_entry(texts[i], "<query " + n + ">", 0, base_dir, "query " + n));
    }
    std::vector<SynthBatchQuery> queries = synth_batch_queries(entries, options);
    const ClipSource clips(self->index());
    if (results)
      synth_batch_results_file(*results, clips, queries);
    else
      search_synth_batch(clips, queries, &self->engine(), options.style_model);
    run_synth_batch(clips, queries, options, [&](SynthBatchDone& done) {
      if (done.error)
        errors[done.index] = done.error;
      else
        made[done.index] = batch_synthesis(self, done, options);
    });
  }
  py::list out;
  for (std::size_t i = 0; i < texts.size(); ++i) {
    if (made[i]) {
      out.append(py::cast(made[i]));
      continue;
    }
    py::dict e;
    e["message"] = std::string(errors[i]->what());
    e["source"] = errors[i]->source();
    e["line"] = errors[i]->line();
    e["detail"] = errors[i]->detail();
    out.append(e);
  }
  return out;
}

py::dict result_dict(const SearchResult& r) {
  py::dict d;
  d["rank"] = r.rank;
  d["clip"] = r.clip;
  d["clip_index"] = r.clip_index;
  d["start_frame"] = r.start_frame;
  d["end_frame"] = r.end_frame;
  d["score_J"] = r.score_J;
  d["h_in_J"] = r.h_in_J;
  d["h_out_J"] = r.h_out_J;
  d["path_cost_J"] = r.path_cost_J;
  if (r.context) {
    d["context_in_J"] = r.context_in_J;
    d["context_out_J"] = r.context_out_J;
  }
  if (r.style) d["style_J"] = r.style_J;
  return d;
}

// Writes (w, x, y, z) at `out`; returns the next place.
double* put_quaternion(double* out, const Eigen::Quaterniond& q) {
  out[0] = q.w();
  out[1] = q.x();
  out[2] = q.y();
  out[3] = q.z();
  return out + 4;
}

// Per frame, per joint: world joint origins (metres) and world rotations.
void world_arrays(const Synthesis& s, py::array_t<double>* positions,
                  py::array_t<double>* rotations) {
  const std::size_t f_count = s.frame_count(), n = s.joint_count();
  double* p = positions ? positions->mutable_data() : nullptr;
  double* q = rotations ? rotations->mutable_data() : nullptr;
  WorldPose w;
  for (std::size_t f = 0; f < f_count; ++f) {
    synth_world_pose(*s.skeleton, s.result.frames[f], w);
    for (std::size_t j = 0; j < n; ++j) {
      if (p)
        for (int a = 0; a < 3; ++a) *p++ = w.positions_m[j][a];
      if (q) q = put_quaternion(q, w.rotations[j]);
    }
  }
}

py::array_t<double> new_array(std::vector<py::ssize_t> shape) {
  return py::array_t<double>(shape);
}

using SynthesisClass = py::class_<Synthesis, std::shared_ptr<Synthesis>>;

// Synthesis: the motion's size, rate, query and skeleton.
void bind_synthesis_skeleton(SynthesisClass& c) {
  c.def_property_readonly("frame_count", &Synthesis::frame_count)
      .def_property_readonly("frame_time_s",
                             [](const Synthesis& s) { return s.result.frame_time_s; })
      .def_property_readonly("query_id", [](const Synthesis& s) { return s.query.id; })
      .def_property_readonly("skeleton",
                             [](const Synthesis& s) { return s.result.skeleton->index_skeleton; })
      .def_property_readonly("joint_names",
                             [](const Synthesis& s) { return s.skeleton->skeleton.names; })
      .def_property_readonly("parents",
                             [](const Synthesis& s) {
                               const auto& p = s.skeleton->skeleton.parents;
                               return owned_array<std::int32_t>(
                                   {p.size()}, std::vector<std::int32_t>(p.begin(), p.end()));
                             })
      .def_property_readonly("root_joint",
                             [](const Synthesis& s) { return s.skeleton->root_joint; });
}

// Synthesis: the motion as numpy arrays, its energies, segments and chosen results.
void bind_synthesis_motion(SynthesisClass& c) {
  c.def_property_readonly(
       "root_positions",
       [](const Synthesis& s) {
         auto a = new_array({static_cast<py::ssize_t>(s.frame_count()), 3});
         double* p = a.mutable_data();
         for (const SynthFrame& f : s.result.frames)
           for (int k = 0; k < 3; ++k) *p++ = f.root_position_m[k];
         return a;
       },
       "(F, 3) world position of the root joint (the pelvis), metres.")
      .def_property_readonly(
          "local_rotations",
          [](const Synthesis& s) {
            auto a = new_array({static_cast<py::ssize_t>(s.frame_count()),
                                static_cast<py::ssize_t>(s.joint_count()), 4});
            double* p = a.mutable_data();
            for (const SynthFrame& f : s.result.frames)
              for (const Eigen::Quaterniond& r : f.local_rotations) p = put_quaternion(p, r);
            return a;
          },
          "(F, J, 4) local joint rotations, unit quaternions (w, x, y, z).")
      .def_property_readonly(
          "joint_positions",
          [](const Synthesis& s) {
            auto a = new_array({static_cast<py::ssize_t>(s.frame_count()),
                                static_cast<py::ssize_t>(s.joint_count()), 3});
            world_arrays(s, &a, nullptr);
            return a;
          },
          "(F, J, 3) world joint origins, metres.")
      .def_property_readonly(
          "world_rotations",
          [](const Synthesis& s) {
            auto a = new_array({static_cast<py::ssize_t>(s.frame_count()),
                                static_cast<py::ssize_t>(s.joint_count()), 4});
            world_arrays(s, nullptr, &a);
            return a;
          },
          "(F, J, 4) world joint rotations, unit quaternions (w, x, y, z).")
      .def_property_readonly("step_energies_J",
                             [](const Synthesis& s) {
                               const auto& e = s.result.step_energies_J;
                               return owned_array<double>({e.size()}, e);
                             })
      .def_property_readonly("segments",
                             [](const Synthesis& s) {
                               py::list out;
                               for (const MotionSegment& g : s.result.segments) {
                                 py::dict d;
                                 d["kind"] = g.kind;
                                 d["pair"] = g.pair;
                                 d["first_frame"] = g.first_frame;
                                 d["frames"] = g.frame_count;
                                 out.append(d);
                               }
                               return out;
                             })
      .def_property_readonly("chosen", [](const Synthesis& s) {
        py::list out;
        for (const SearchResult& r : s.result.chosen) out.append(result_dict(r));
        return out;
      });
}

// Synthesis: its BVH file and report texts.
void bind_synthesis_outputs(SynthesisClass& c) {
  c.def(
       "write_bvh",
       [](const Synthesis& s, const std::filesystem::path& path) {
         py::gil_scoped_release release;
         write_motion_bvh(s.result, path);
       },
       py::arg("path"), "Writes the motion as BVH (mocap-synth's writer).")
      .def(
          "write_motion",
          [](const Synthesis& s, const std::filesystem::path& path) {
            py::gil_scoped_release release;
            write_motion_file(s.result, path);
          },
          py::arg("path"),
          "Writes the motion in the format its extension names (.glb, .npz, else BVH), as "
          "mocap-synth --out does.")
      .def(
          "report_json",
          [](const Synthesis& s, const std::string& query_file, const std::string& bvh_path) {
            return synth_report_json(s.clips, s.query, query_file, s.ranked, s.result, s.options,
                                     s.search_ms, s.total_ms, bvh_path);
          },
          py::arg("query_file") = "", py::arg("bvh_path") = "",
          "REPORT.json text (mocap-synth --report), naming these query file and BVH paths.")
      .def(
          "report_html",
          [](const Synthesis& s) {
            py::gil_scoped_release release;
            return synth_report_html(s.clips, s.query, s.ranked, s.result, s.options);
          },
          "REPORT.html text (mocap-synth --html).");
}

// Index.synthesize_batch: a batch's synthesis (synthesize_batch).
void bind_index_synthesize_batch(py::class_<OpenIndex, std::shared_ptr<OpenIndex>>& index) {
  index.def(
      "synthesize_batch",
      [](const std::shared_ptr<OpenIndex>& self, const std::vector<std::string>& queries,
         const std::filesystem::path& base_dir, const std::optional<std::filesystem::path>& results,
         const std::string& method, std::size_t max_states, double cost_threshold_J, bool step_feet,
         std::optional<double> fps, std::size_t refine, double refine_smoothing_J,
         std::size_t refine_polish, std::size_t refine_polish_window, bool refine_polish_segments,
         double refine_polish_smoothing_J, int threads, const std::string& energy,
         std::optional<bool> warp, std::size_t warp_candidates, double warp_work_weight_m_per_J,
         const std::string& style_model, const std::string& style, double style_strength) {
        SynthArgs a;
        a.style_model = style_model;
        a.style = style;
        a.style_strength = style_strength;
        a.method = method;
        a.max_states = max_states;
        a.cost_threshold_J = cost_threshold_J;
        a.step_feet = step_feet;
        a.energy = energy;
        a.warp = warp;
        a.warp_candidates = warp_candidates;
        a.warp_work_weight_m_per_J = warp_work_weight_m_per_J;
        a.fps = fps;
        a.refine = refine;
        a.refine_smoothing_J = refine_smoothing_J;
        a.refine_polish = refine_polish;
        a.refine_polish_window = refine_polish_window;
        a.refine_polish_segments = refine_polish_segments;
        a.refine_polish_smoothing_J = refine_polish_smoothing_J;
        return synthesize_batch(self, queries, base_dir, results, a, threads);
      },
      py::arg("queries"), py::arg("base_dir"), py::arg("results") = std::nullopt,
      py::arg("method") = "astar", py::arg("max_states") = SupplementParams{}.max_states,
      py::arg("cost_threshold_J") = SupplementParams{}.cost_threshold_J,
      py::arg("step_feet") = false, py::arg("fps") = std::nullopt, py::arg("refine") = 0,
      py::arg("refine_smoothing_J") = 0.0, py::arg("refine_polish") = 0,
      py::arg("refine_polish_window") = 1, py::arg("refine_polish_segments") = false,
      py::arg("refine_polish_smoothing_J") = 0.0, py::arg("threads") = 0, py::arg("energy") = "w",
      py::arg("warp") = std::nullopt, py::arg("warp_candidates") = SynthOptions{}.warp_candidates,
      py::arg("warp_work_weight_m_per_J") = SynthOptions{}.warp_work_weight_m_per_J,
      py::arg("style_model") = "", py::arg("style") = "", py::arg("style_strength") = 1.0,
      "Synthesises a batch of queries (JSON texts) as mocap-synth --queries does: one search "
      "(or `results`, a mocap-search JSONL file), the queries in parallel. Per query, in input "
      "order, a Synthesis or, for a query that failed, a dict {message, source, line, detail}.");
}

// Index.synthesize: one query's synthesis (synthesize_query).
void bind_index_synthesize(py::module_& m) {
  auto index =
      py::reinterpret_borrow<py::class_<OpenIndex, std::shared_ptr<OpenIndex>>>(m.attr("Index"));
  index.def(
      "synthesize",
      [](const std::shared_ptr<OpenIndex>& self, const std::string& query,
         const std::filesystem::path& base_dir, const std::optional<std::filesystem::path>& results,
         const std::string& method, const std::vector<std::string>& picks, std::size_t max_states,
         double cost_threshold_J, bool step_feet, std::optional<double> fps, std::size_t refine,
         double refine_smoothing_J, std::size_t refine_polish, std::size_t refine_polish_window,
         bool refine_polish_segments, double refine_polish_smoothing_J, int threads,
         const std::string& energy, std::optional<bool> warp, std::size_t warp_candidates,
         double warp_work_weight_m_per_J, const std::string& style_model, const std::string& style,
         double style_strength) {
        SynthArgs a;
        a.style_model = style_model;
        a.style = style;
        a.style_strength = style_strength;
        a.method = method;
        a.picks = picks;
        a.max_states = max_states;
        a.cost_threshold_J = cost_threshold_J;
        a.step_feet = step_feet;
        a.energy = energy;
        a.warp = warp;
        a.warp_candidates = warp_candidates;
        a.warp_work_weight_m_per_J = warp_work_weight_m_per_J;
        a.fps = fps;
        a.refine = refine;
        a.refine_smoothing_J = refine_smoothing_J;
        a.refine_polish = refine_polish;
        a.refine_polish_window = refine_polish_window;
        a.refine_polish_segments = refine_polish_segments;
        a.refine_polish_smoothing_J = refine_polish_smoothing_J;
        return synthesize_query(self, query, base_dir, results, a, threads);
      },
      py::arg("query"), py::arg("base_dir"), py::arg("results") = std::nullopt,
      py::arg("method") = "astar", py::arg("picks") = std::vector<std::string>{},
      py::arg("max_states") = SupplementParams{}.max_states,
      py::arg("cost_threshold_J") = SupplementParams{}.cost_threshold_J,
      py::arg("step_feet") = false, py::arg("fps") = std::nullopt, py::arg("refine") = 0,
      py::arg("refine_smoothing_J") = 0.0, py::arg("refine_polish") = 0,
      py::arg("refine_polish_window") = 1, py::arg("refine_polish_segments") = false,
      py::arg("refine_polish_smoothing_J") = 0.0, py::arg("threads") = 0, py::arg("energy") = "w",
      py::arg("warp") = std::nullopt, py::arg("warp_candidates") = SynthOptions{}.warp_candidates,
      py::arg("warp_work_weight_m_per_J") = SynthOptions{}.warp_work_weight_m_per_J,
      py::arg("style_model") = "", py::arg("style") = "", py::arg("style_strength") = 1.0,
      "Synthesises the motion of one query (JSON text) as mocap-synth does: with `results` (a "
      "mocap-search JSONL file holding the query's line) or searching here with the default "
      "options; `picks` as --pick (\"PAIR:RANK\").");
  bind_index_synthesize_batch(index);
}

}  // namespace

void bind_synth(py::module_& m) {
  SynthesisClass synthesis(
      m, "Synthesis", "A synthesised motion (mocap-synth's job); low-level, see mocap.Synthesis.");
  bind_synthesis_skeleton(synthesis);
  bind_synthesis_motion(synthesis);
  bind_synthesis_outputs(synthesis);
  bind_index_synthesize(m);
}

}  // namespace mocap::python
