#pragma once
// mocap-index style-model: a style model learned from an index's labelled
// clips (docs/style.md; mocap/common/motion/style.hpp), written as JSON,
// and with --evaluate its cross-validated accuracy.
#include <CLI/CLI.hpp>
#include <cstddef>
#include <string>

namespace mocap {

struct StyleModelArgs {
  std::string index;
  std::string out;
  bool evaluate = false;
  std::size_t folds = 0;
  double shrinkage = 0.3;
  bool json = false;
  bool force = false;
};

/// Adds the `style-model` subcommand to `app`; returns it.
CLI::App* add_style_model_command(CLI::App& app, StyleModelArgs& args);

/// Runs it: 0 when the model is written. Bad arguments or inputs throw
/// InputError naming the option or the file, before anything is written.
int run_style_model(const StyleModelArgs& args);

}  // namespace mocap
