// _mocap.Index.style_model and _mocap.recognise_style: the style model of
// mocap-index style-model and the recognition of mocap-search style
// (mocap/common/motion/style.hpp, docs/style.md), as JSON texts the Python
// layer loads: the same fields, written by the same code.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/json_text.hpp"

namespace mocap::python {
namespace {

std::string style_model(const std::shared_ptr<OpenIndex>& self, double shrinkage, bool evaluate,
                        std::size_t folds) {
  py::gil_scoped_release release;
  std::vector<std::string> joints;
  const std::vector<StyleSample> samples = index_style_samples(self->index(), joints);
  nlohmann::json out{{"model", style_model_json(learn_style_model(samples, joints, shrinkage))}};
  if (evaluate) {
    const StyleEvaluation e = evaluate_style(samples, joints, folds, shrinkage);
    std::map<std::string, std::map<std::string, std::size_t>> confusion;
    for (const auto& [pair, n] : e.confusion) confusion[pair.first][pair.second] = n;
    out["evaluation"] = {{"folds", folds},           {"takes", e.takes}, {"right", e.right},
                         {"accuracy", e.accuracy()}, {"alone", e.alone}, {"confusion", confusion}};
  }
  return json_text(out);
}

std::string recognise(const std::string& model_text, const std::filesystem::path& file,
                      std::optional<std::size_t> first, std::optional<std::size_t> last,
                      const std::string& content) {
  py::gil_scoped_release release;
  const StyleModel model = style_model_from_json(nlohmann::json::parse(model_text), "<model>");
  RawClip clip = read_bvh_file(file);
  normalise_up_axis(clip, std::nullopt);
  const std::size_t s = first.value_or(0);
  const std::size_t e = last.value_or(clip.frame_count ? clip.frame_count - 1 : 0);
  std::vector<double> features;
  try {
    features = style_features(raw_style_motion(clip, s, e), model.joints);
  } catch (const InputError& err) {
    throw InputError(file.string(), 0, err.detail());
  }
  const StylePrediction p = recognise_style(model, features, content);
  nlohmann::json probs = nlohmann::json::object();
  for (const auto& [style, prob] : p.probabilities) probs[style] = prob;
  return json_text({{"file", file.string()},
                    {"frames", {s, e}},
                    {"style", p.style},
                    {"probabilities", probs},
                    {"content", p.content},
                    {"content_recognised", p.content_recognised}});
}

}  // namespace

void bind_style(py::module_& m) {
  auto index =
      py::reinterpret_borrow<py::class_<OpenIndex, std::shared_ptr<OpenIndex>>>(m.attr("Index"));
  index.def("style_model", &style_model, py::arg("shrinkage") = 0.3, py::arg("evaluate") = false,
            py::arg("folds") = 0, "JSON text: {\"model\", \"evaluation\" (with evaluate)}");
  m.def("recognise_style", &recognise, py::arg("model"), py::arg("file"),
        py::arg("first") = std::nullopt, py::arg("last") = std::nullopt, py::arg("content") = "",
        "JSON text: mocap-search style --json's object");
}

}  // namespace mocap::python
