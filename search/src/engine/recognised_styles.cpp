// Search results with their recognised style (recognised_styles.hpp).
#include "mocap/search/recognised_styles.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

StyleModel read_style_model(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot read the style model");
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, 0, std::string("not JSON: ") + e.what());
  }
  return style_model_from_json(j, path);
}

void add_recognised_styles(const StyleModel& model, const ClipSource& clips,
                           std::vector<QueryOutcome>& outcomes) {
  for (QueryOutcome& o : outcomes)
    for (PairResults& pair : o.pairs)
      for (SearchResult& r : pair.results) {
        if (r.end_frame < r.start_frame + 3) continue;
        const ClipSource::Location at = clips.locate(r.clip_index);
        const std::optional<StylePrediction> p = recognise_motion_style(
            model, index_style_motion(*at.index, at.clip, r.start_frame, r.end_frame),
            at.index->label(at.clip, "content"));
        if (!p) continue;
        r.recognised_style = p->style;
        r.recognised_style_p = p->probability;
      }
}

std::vector<std::vector<double>> clip_style_probabilities(const StyleModel& model,
                                                          const Index& index) {
  std::vector<std::vector<double>> out(index.clips().size());
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    const IndexClip& clip = index.clips()[c];
    if (clip.frame_count < 4) continue;
    const std::optional<StylePrediction> p = recognise_motion_style(
        model, index_style_motion(index, c, 0, clip.frame_count - 1), index.label(c, "content"));
    if (!p) continue;
    for (const auto& [style, prob] : p->probabilities) out[c].push_back(prob);
  }
  return out;
}

std::vector<double> asked_style(const StyleModel& model, const QueryStyle& style,
                                const std::string& source) {
  const std::vector<std::string>& styles = model.style.classes;
  if (!style.label.empty()) {
    const auto it = std::find(styles.begin(), styles.end(), style.label);
    if (it == styles.end()) {
      std::string known;
      for (const std::string& s : styles) known += (known.empty() ? "" : ", ") + s;
      throw InputError(source, 0,
                       "style.label: the style model has no style \"" + style.label +
                           "\" (it has " + known + ")");
    }
    std::vector<double> asked(styles.size(), 0.0);
    asked[static_cast<std::size_t>(it - styles.begin())] = 1.0;
    return asked;
  }
  std::vector<double> asked;
  try {
    const StyleMotion m = bvh_style_motion(
        *style.like_bvh, style.like_whole
                             ? std::nullopt
                             : std::optional(std::pair{style.like_first, style.like_last}));
    for (const auto& [s, p] : recognise_style(model, style_features(m, model.joints)).probabilities)
      asked.push_back(p);
  } catch (const InputError& e) {
    throw InputError(source, 0, "style.like: " + style.like_bvh->string() + ": " + e.detail());
  }
  return asked;
}

double style_distance(const std::vector<double>& asked, const std::vector<double>& p) {
  if (p.empty()) return std::log(static_cast<double>(asked.size()));
  double d = 0.0;
  for (std::size_t k = 0; k < asked.size() && k < p.size(); ++k)
    if (asked[k] > 0.0) d -= asked[k] * std::log(std::max(p[k], 1e-12));
  return std::max(0.0, d);
}

}  // namespace mocap
