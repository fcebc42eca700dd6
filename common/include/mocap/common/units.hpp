#pragma once
// Length units of capture files and their detection.
//
// Everything inside the engine is metres, Y up. Files declare nothing, so the
// unit is either given (--unit) or detected by detect_unit(): the standing
// height of the clip (Y extent of all joints and End Sites over sampled
// frames, median over those frames) is compared with a 1.7 m adult, and the
// candidate unit whose converted height is closest on a log scale wins
// (docs/units.md). CMU's unit is 0.056444 m ("inch-like", per the CMU FAQ).
#include <optional>
#include <string>
#include <string_view>

#include "mocap/common/raw_clip.hpp"

namespace mocap {

enum class LengthUnit { m, cm, mm, inch, cmu };

/// Metres per file unit: m=1, cm=0.01, mm=0.001, inch=0.0254, cmu=0.056444.
double unit_scale_m(LengthUnit u);
const char* unit_name(LengthUnit u);
/// "m", "cm", "mm", "inch", "cmu" (case-insensitive); nullopt otherwise.
std::optional<LengthUnit> parse_unit(std::string_view s);

/// Height of the character in file units: median over up to `samples` evenly
/// spaced frames of (max Y - min Y) over joints and End Sites. 0 if no frames.
double standing_height_file_units(const RawClip& clip, int samples = 16);

/// Height of the skeleton stretched out, in file units: in each of up to
/// `samples` evenly spaced frames, the lowest and the highest point (joints and
/// End Sites) are found and the bone lengths along the tree path between them
/// are summed (a stooping or crouching pose does not shorten it); the median
/// over those frames. 0 if no frames.
double skeleton_height_file_units(const RawClip& clip, int samples = 16);

/// The unit whose converted skeleton height is closest to 1.7 m (log scale).
/// Clips with no frames or zero height get metres.
LengthUnit detect_unit(const RawClip& clip);

}  // namespace mocap
