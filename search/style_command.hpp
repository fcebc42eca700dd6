#pragma once
// mocap-search style: the recognised style of a capture file or a frame
// range of it, by a model of `mocap-index style-model` (docs/style.md).
#include <CLI/CLI.hpp>
#include <string>

namespace mocap {

struct StyleArgs {
  std::string index;
  std::string model;
  std::string file;  // FILE.bvh or FILE.bvh:S-E
  std::string content;
  std::string up;
  bool json = false;
  /// With json: the motion's style features too ("features", the model's
  /// order; docs/style.md "Features").
  bool features = false;
};

/// Adds the `style` subcommand to `app`; returns it.
CLI::App* add_style_command(CLI::App& app, StyleArgs& args);

/// Runs it: prints the style; 0. Bad arguments or inputs throw InputError
/// naming the option or the file.
int run_style(const StyleArgs& args);

}  // namespace mocap
