#pragma once
// A range of frames as the command line and queries write it: "S-E", the
// first and last frame of a clip, 0-based and inclusive (FILE:S-E in
// `mocap-search style`, `--frames` of export and of search, the query field
// style.like.frames). Text only: whether the range lies inside a clip is
// the reader's check, since only it knows the clip.
#include <cstddef>
#include <string>

namespace mocap {

/// Frames first..last of a clip, 0-based, inclusive (first <= last).
struct FrameRange {
  std::size_t first = 0;
  std::size_t last = 0;
};

/// "S-E" (decimal, S <= E; E = S gives one frame) -> {S, E}. Anything else
/// (signs, spaces, a missing or extra part, a number past size_t) throws
/// InputError(option, 0, ...) saying what was expected.
FrameRange parse_frame_range(const std::string& text, const std::string& option);

}  // namespace mocap
