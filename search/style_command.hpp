#pragma once
// mocap-search style: the recognised style of a capture file or a frame
// range of it, by a model of `mocap-index style-model` (docs/style.md).
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

struct StyleArgs {
  std::string index;
  std::string model;
  std::string file;  // FILE.bvh or FILE.bvh:S-E
  std::string content;
  std::string unit;
  std::string up;
  bool json = false;
};

/// Adds the `style` subcommand to `app`; returns it.
CLI::App* add_style_command(CLI::App& app, StyleArgs& args);

/// A style model file (JSON of mocap-index style-model). Throws InputError
/// naming the file.
StyleModel read_style_model(const std::string& path);

/// mocap-search --style-model: every result of `outcomes` gets the style its
/// partial motion (frames start..end of its clip) is recognised as, its
/// clip's content label standardising the features when it has one
/// (recognised otherwise). Partial motions of fewer than 4 frames, or of a
/// skeleton lacking a joint of the model, get none.
void add_recognised_styles(const StyleModel& model, const ClipSource& clips,
                           std::vector<QueryOutcome>& outcomes);

/// Runs it: prints the style; 0. Bad arguments or inputs throw InputError
/// naming the option or the file.
int run_style(const StyleArgs& args);

}  // namespace mocap
