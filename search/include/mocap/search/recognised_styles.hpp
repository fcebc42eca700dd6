#pragma once
// Search results labelled with their recognised style (mocap-search
// --style-model, Python Index.search(style_model=...); docs/style.md
// "Search results with their style").
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/style.hpp"
#include "mocap/search/query.hpp"
#include "mocap/search/search.hpp"

namespace mocap {

/// A style model file (JSON of mocap-index style-model). Throws InputError
/// naming the file.
StyleModel read_style_model(const std::string& path);

/// Every result of `outcomes` gets the style its partial motion (frames
/// start..end of its clip) is recognised as, its clip's content label
/// standardising the features when the model knows it (recognised
/// otherwise). Partial motions of fewer than 4 frames, or of a skeleton
/// lacking a joint of the model, get none. The ranking does not change.
void add_recognised_styles(const StyleModel& model, const ClipSource& clips,
                           std::vector<QueryOutcome>& outcomes);

/// Per clip of `index`, whole: its style probabilities by `model` (in the
/// model's style order; its content label standardising the features when
/// the model knows it, recognised otherwise), or empty when it cannot be
/// read as the model's (fewer than 4 frames, another rig).
std::vector<std::vector<double>> clip_style_probabilities(const StyleModel& model,
                                                          const Index& index);

/// The style distribution a query's "style" asks for: its label's (one
/// style; InputError "style.label" listing the model's styles when unknown)
/// or the probabilities of its "like" file's frames. `source` names the
/// query in messages.
std::vector<double> asked_style(const StyleModel& model, const QueryStyle& style,
                                const std::string& source);

/// The style distance of a clip, nats: the cross-entropy -sum_k asked_k
/// log p_k of its probabilities p (each at least 1e-12); log(K) for a clip
/// with none (nothing known: as far as a uniform guess). >= 0.
double style_distance(const std::vector<double>& asked, const std::vector<double>& p);

}  // namespace mocap
