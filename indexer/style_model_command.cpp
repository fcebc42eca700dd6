// mocap-index style-model (style_model_command.hpp).
#include "style_model_command.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "mocap/common/io/index.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/common/util/output_path.hpp"

namespace mocap {

CLI::App* add_style_model_command(CLI::App& app, StyleModelArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "style-model",
      "Learn a style model from the index's clips labelled with a content and a style (features "
      "of joint rotations and the root path, linear discriminants; docs/style.md) and write it as "
      "JSON for `mocap-search style`");
  cmd->add_option("INDEX", a.index, "Index file")->required();
  cmd->add_option("--out", a.out, "The model (JSON) to write")->required();
  cmd->add_flag("--evaluate", a.evaluate,
                "Also cross-validate: each take's style named by a model learned without it");
  cmd->add_option("--folds", a.folds,
                  "With --evaluate: 0 = leave one take out (default), K = take i in fold i % K")
      ->capture_default_str();
  cmd->add_option("--shrinkage", a.shrinkage,
                  "Shrinkage of the pooled covariance toward its mean variance, in (0, 1]")
      ->capture_default_str();
  cmd->add_flag("--json", a.json, "Print one JSON object (docs/style.md)");
  cmd->add_flag("--force", a.force,
                "Replace --out even when it holds something else (docs/cli.md \"Output paths\")");
  return cmd;
}

int run_style_model(const StyleModelArgs& a) {
  const std::filesystem::path out = checked_output_path(a.out, OutputKind::json, a.force, "--out");
  const Index index = Index::open(a.index);
  std::vector<std::string> joints;
  const std::vector<StyleSample> samples = index_style_samples(index, joints);
  const StyleModel model = learn_style_model(samples, joints, a.shrinkage);
  nlohmann::json report{{"index", a.index},
                        {"model", std::filesystem::absolute(out).string()},
                        {"clips", samples.size()},
                        {"joints", joints.size()},
                        {"temperature", model.temperature},
                        {"styles", model.style.classes},
                        {"contents", model.content.classes}};
  if (a.evaluate) {
    report["evaluation"] =
        style_evaluation_json(evaluate_style(samples, joints, a.folds, a.shrinkage), a.folds);
  }
  write_file_atomically(out, json_text(style_model_json(model)) + "\n");
  if (a.json) {
    std::cout << json_text(report) << "\n";
  } else {
    std::cout << fmt::format("style model: {} ({} clips, {} styles, {} contents, {} joints)\n",
                             report["model"].get<std::string>(), samples.size(),
                             model.style.classes.size(), model.content.classes.size(),
                             joints.size());
    if (a.evaluate)
      std::cout << fmt::format(
          "{}: {} of {} takes named right ({:.3f}; {} alone in their content, not counted)\n",
          a.folds == 0 ? std::string("leave one take out") : fmt::format("{} folds", a.folds),
          report["evaluation"]["right"].get<std::size_t>(),
          report["evaluation"]["takes"].get<std::size_t>(),
          report["evaluation"]["accuracy"].get<double>(),
          report["evaluation"]["alone"].get<std::size_t>());
  }
  return 0;
}

}  // namespace mocap
