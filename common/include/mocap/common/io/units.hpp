#pragma once
// Length units and up axes of capture files, and their detection.
//
// Everything inside the engine is metres, Y up. Files declare neither, so the
// up axis is given (--up) or detected by detect_up_axis() (a Z-up clip is then
// rotated to Y up, up_axis.cpp), and the unit is given (--unit) or detected by
// detect_unit() on the Y-up clip: the skeleton height (below) is compared with
// a 1.7 m adult, and the candidate unit whose converted height is closest on a
// log scale wins (docs/units.md). CMU's unit is 0.056444 m ("inch-like", per
// the CMU FAQ); MakeHuman writes decimetres.
#include <optional>
#include <string>
#include <string_view>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

enum class LengthUnit { m, cm, mm, inch, cmu, dm };

/// Metres per file unit: m=1, dm=0.1, cm=0.01, mm=0.001, inch=0.0254, cmu=0.056444.
double unit_scale_m(LengthUnit u);
const char* unit_name(LengthUnit u);
/// "m", "dm", "cm", "mm", "inch", "cmu" (case-insensitive); nullopt otherwise.
std::optional<LengthUnit> parse_unit(std::string_view s);

/// The axis along which a file's figure stands.
enum class UpAxis { y, z };
const char* up_axis_name(UpAxis a);
/// "y", "z" (case-insensitive); nullopt otherwise.
std::optional<UpAxis> parse_up_axis(std::string_view s);

/// Z when the figure stands along Z: the median over up to `samples` evenly
/// spaced frames of the Z extent of the body's joints and End Sites (the same
/// points as the heights below) exceeds 1.5 times the median Y extent; Y
/// otherwise, and for clips with no frames. A clip lying down along Z for most
/// of its frames is taken for Z up: declare --up y for such data.
UpAxis detect_up_axis(const RawClip& clip, int samples = 16);

/// The clip with Y up: itself for UpAxis::y; for UpAxis::z every world
/// position p = (x, y, z) becomes (x, z, -y), the rotation by -90 degrees about
/// X (+Z goes to +Y, +Y to -Z, X stays). Each ROOT then gets the channels
/// Xposition Yposition Zposition and its rotation channels (its own three in
/// their order, ZXY when it had fewer), with values rotated accordingly; no
/// other joint changes. Positions are exact (a signed permutation), rotations
/// are re-expressed as Euler angles (~1e-15 relative).
RawClip rotate_to_y_up(const RawClip& clip, UpAxis up);

/// The up axis `declared`, or the detected one when nullopt; `clip` is
/// rotated to Y up in place when it is Z. Returns the axis.
UpAxis normalise_up_axis(RawClip& clip, std::optional<UpAxis> declared);

/// Height of the character in file units: median over up to `samples` evenly
/// spaced frames of (max Y - min Y) over joints and End Sites. 0 if no frames.
/// Y is up: rotate a Z-up clip first (normalise_up_axis).
double standing_height_file_units(const RawClip& clip, int samples = 16);

/// Height of the skeleton stretched out, in file units: in each of up to
/// `samples` evenly spaced frames, the lowest and the highest point (joints and
/// End Sites) are found and the bone lengths along the tree path between them
/// are summed (a stooping or crouching pose does not shorten it); the median
/// over those frames. 0 if no frames.
double skeleton_height_file_units(const RawClip& clip, int samples = 16);

/// The unit whose converted skeleton height is closest to 1.7 m (log scale),
/// among m, dm, cm, mm, inch and cmu. Clips with no frames or zero height get
/// metres. Y is up: rotate a Z-up clip first (normalise_up_axis).
LengthUnit detect_unit(const RawClip& clip);

}  // namespace mocap
