// BVH text: quoting bytes for messages and the exact (std::from_chars) path
// of the number parser.
#include "io/bvh_text.hpp"

#include <charconv>
#include <cstdio>
#include <system_error>

namespace mocap::detail {

std::string show(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 40)) {
    if (is_binary(c)) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x",
                    static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  if (s.size() > 40) out += "...";
  out += "'";
  return out;
}

const char* parse_double_slow(const char* p, const char* end, double& out) {
  // from_chars takes '-' but not '+'.
  const char* start = (p < end && *p == '+') ? p + 1 : p;
  if (start < end && *start == '-' && p != start) return nullptr;  // "+-1"
  const auto [ptr, ec] = std::from_chars(start, end, out);
  if (ec != std::errc() || ptr == start) return nullptr;
  return ptr;
}

}  // namespace mocap::detail
