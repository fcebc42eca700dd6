// _mocap.Index.style_model and _mocap.recognise_style: the style model of
// mocap-index style-model and the recognition of mocap-search style
// (mocap/common/motion/style.hpp, docs/style.md), as JSON texts the Python
// layer loads: the same fields, written by the same code.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>
#include <string>
#include <utility>

#include "bindings.hpp"
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
    out["evaluation"] =
        style_evaluation_json(evaluate_style(samples, joints, folds, shrinkage), folds);
  }
  return json_text(out);
}

std::string recognise(const std::string& model_text, const std::filesystem::path& file,
                      std::optional<std::pair<std::size_t, std::size_t>> frames,
                      const std::string& content) {
  py::gil_scoped_release release;
  const StyleModel model = style_model_from_json(nlohmann::json::parse(model_text), "<model>");
  const StyleMotion motion = bvh_style_motion(file, frames);
  std::vector<double> features;
  try {
    features = style_features(motion, model.joints);
  } catch (const InputError& err) {
    throw InputError(file.string(), 0, err.detail());
  }
  const std::size_t s = frames ? frames->first : 0;
  return json_text(style_prediction_json(file.string(), s, s + motion.frame_count - 1,
                                         recognise_style(model, features, content)));
}

}  // namespace

void bind_style(py::module_& m) {
  auto index =
      py::reinterpret_borrow<py::class_<OpenIndex, std::shared_ptr<OpenIndex>>>(m.attr("Index"));
  index.def("style_model", &style_model, py::arg("shrinkage") = 0.3, py::arg("evaluate") = false,
            py::arg("folds") = 0, "JSON text: {\"model\", \"evaluation\" (with evaluate)}");
  m.def("recognise_style", &recognise, py::arg("model"), py::arg("file"),
        py::arg("frames") = std::nullopt, py::arg("content") = "",
        "JSON text: mocap-search style --json's object");
}

}  // namespace mocap::python
