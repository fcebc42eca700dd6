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
        const StyleMotion m = index_style_motion(*at.index, at.clip, r.start_frame, r.end_frame);
        const std::vector<std::string> has = m.joint_names;
        if (!std::all_of(model.joints.begin(), model.joints.end(), [&](const std::string& j) {
              return std::find(has.begin(), has.end(), j) != has.end();
            }))
          continue;
        std::string content = at.index->label(at.clip, "content");
        if (std::find(model.content.classes.begin(), model.content.classes.end(), content) ==
            model.content.classes.end())
          content.clear();
        const StylePrediction p = recognise_style(model, style_features(m, model.joints), content);
        r.recognised_style = p.style;
        for (const auto& [style, prob] : p.probabilities)
          if (style == p.style) r.recognised_style_p = prob;
      }
}

std::vector<std::vector<double>> clip_style_probabilities(const StyleModel& model,
                                                          const Index& index) {
  std::vector<std::vector<double>> out(index.clips().size());
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    const IndexClip& clip = index.clips()[c];
    if (clip.frame_count < 4) continue;
    const StyleMotion m = index_style_motion(index, c, 0, clip.frame_count - 1);
    if (!std::all_of(model.joints.begin(), model.joints.end(), [&](const std::string& j) {
          return std::find(m.joint_names.begin(), m.joint_names.end(), j) != m.joint_names.end();
        }))
      continue;
    std::string content = index.label(c, "content");
    if (std::find(model.content.classes.begin(), model.content.classes.end(), content) ==
        model.content.classes.end())
      content.clear();
    for (const auto& [style, p] :
         recognise_style(model, style_features(m, model.joints), content).probabilities)
      out[c].push_back(p);
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
  RawClip clip = read_bvh_file(*style.like_bvh);
  normalise_up_axis(clip, std::nullopt);
  const std::size_t last =
      style.like_whole ? (clip.frame_count ? clip.frame_count - 1 : 0) : style.like_last;
  std::vector<double> asked;
  try {
    const StyleMotion m = raw_style_motion(clip, style.like_whole ? 0 : style.like_first, last);
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
