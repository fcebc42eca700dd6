// "S-E" frame ranges (frame_range.hpp).
#include "mocap/common/util/frame_range.hpp"

#include <charconv>
#include <string_view>
#include <system_error>

#include "mocap/common/util/error.hpp"

namespace mocap {

FrameRange parse_frame_range(const std::string& text, const std::string& option) {
  const auto dash = text.find('-');
  FrameRange r;
  auto num = [](std::string_view s, std::size_t& v) {
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    return !s.empty() && res.ec == std::errc() && res.ptr == s.data() + s.size();
  };
  if (dash == std::string::npos || !num(std::string_view(text).substr(0, dash), r.first) ||
      !num(std::string_view(text).substr(dash + 1), r.last))
    throw InputError(
        option, 0,
        "expected S-E (the first and last frame, 0-based, inclusive), got \"" + text + "\"");
  if (r.first > r.last)
    throw InputError(option, 0,
                     "first frame " + std::to_string(r.first) + " is after last frame " +
                         std::to_string(r.last) + " (S-E needs S <= E)");
  return r;
}

}  // namespace mocap
