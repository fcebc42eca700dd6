#pragma once
// Search results labelled with their recognised style (mocap-search
// --style-model, Python Index.search(style_model=...); docs/style.md
// "Search results with their style").
#include <string>
#include <vector>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/style.hpp"
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

}  // namespace mocap
