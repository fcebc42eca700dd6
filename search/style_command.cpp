// mocap-search style (style_command.hpp).
#include "style_command.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>

#include "mocap/common/io/index.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/frame_range.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/search/recognised_styles.hpp"

namespace mocap {
namespace {

// FILE or FILE:S-E (0-based, inclusive): the path and the range, if any.
struct FileRange {
  std::string path;
  std::optional<std::pair<std::size_t, std::size_t>> frames;
};

// A tail "S-E" after the last colon is a frame range (parse_frame_range);
// anything else there is part of the path.
FileRange file_range(const std::string& arg) {
  const std::size_t colon = arg.rfind(':');
  if (colon == std::string::npos) return {arg, std::nullopt};
  const std::string tail = arg.substr(colon + 1);
  const std::size_t dash = tail.find('-');
  const auto digits = [](const std::string& t) {
    return !t.empty() &&
           std::all_of(t.begin(), t.end(), [](unsigned char c) { return c >= '0' && c <= '9'; });
  };
  if (dash == std::string::npos || !digits(tail.substr(0, dash)) || !digits(tail.substr(dash + 1)))
    return {arg, std::nullopt};
  const FrameRange r = parse_frame_range(tail, "FILE");
  return {arg.substr(0, colon), std::pair{r.first, r.last}};
}

}  // namespace

CLI::App* add_style_command(CLI::App& app, StyleArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "style",
      "The recognised style of a capture file or frames S-E of it, by a model of `mocap-index "
      "style-model` (docs/style.md): the style, its probability and the others'");
  cmd->add_option("FILE", a.file, "BVH file, or FILE.bvh:S-E for frames S to E (0-based)")
      ->required();
  cmd->add_option("--model", a.model, "Style model (JSON, mocap-index style-model)")->required();
  cmd->add_option("--index", a.index,
                  "The index the model was learned from: a FILE that is one of its clips is read "
                  "from it, and its content label standardises the features");
  cmd->add_option("--content", a.content,
                  "The motion's content (a content label of the model's index); default: "
                  "recognised");
  cmd->add_option("--up", a.up, "Up axis of the file: y, z or auto (default: detected)");
  cmd->add_flag("--json", a.json,
                "Print one JSON object: {\"style\", \"probabilities\": {STYLE: p}, \"content\", "
                "...}");
  cmd->add_flag("--features", a.features,
                "With --json: the motion's style features too (\"features\", in the model's "
                "order: docs/style.md \"Features\")");
  return cmd;
}

int run_style(const StyleArgs& a) {
  if (a.features && !a.json) throw InputError("--features", 0, "needs --json");
  const StyleModel model = read_style_model(a.model);
  const FileRange fr = file_range(a.file);
  std::optional<UpAxis> up;
  if (!a.up.empty() && a.up != "auto") {
    up = parse_up_axis(a.up);
    if (!up) throw InputError("--up", 0, "expected y, z or auto, got \"" + a.up + "\"");
  }
  std::string content = a.content;
  std::optional<StyleMotion> motion;
  std::size_t first = 0;
  if (!a.index.empty()) {
    const Index index = Index::open(a.index);
    std::error_code ec;
    const std::filesystem::path want = std::filesystem::weakly_canonical(fr.path, ec);
    for (std::size_t c = 0; c < index.clips().size() && !motion; ++c) {
      if (std::filesystem::path(index.clips()[c].path) != want) continue;
      const std::size_t n = index.clips()[c].frame_count;
      const auto [s, e] = fr.frames.value_or(std::pair<std::size_t, std::size_t>{0, n ? n - 1 : 0});
      motion = index_style_motion(index, c, s, e);
      first = s;
      if (content.empty()) content = index.label(c, "content");
    }
  }
  if (!motion) {
    motion = bvh_style_motion(fr.path, fr.frames, up);
    first = fr.frames ? fr.frames->first : 0;
  }
  std::vector<double> features;
  try {
    features = style_features(*motion, model.joints);
  } catch (const InputError& e) {
    throw InputError(fr.path, 0, e.detail());
  }
  const StylePrediction p = recognise_style(model, features, content);
  if (a.json) {
    nlohmann::json out = style_prediction_json(fr.path, first, first + motion->frame_count - 1, p);
    if (a.features) out["features"] = features;
    std::cout << json_text(out) << "\n";
  } else {
    std::cout << fmt::format("{}: {} (p = {:.2f}); content {} ({})\n", a.file, p.style,
                             p.probability, p.content,
                             p.content_recognised ? "recognised" : "given");
  }
  return 0;
}

}  // namespace mocap
