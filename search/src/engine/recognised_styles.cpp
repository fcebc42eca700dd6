// Search results with their recognised style (recognised_styles.hpp).
#include "mocap/search/recognised_styles.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

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

}  // namespace mocap
