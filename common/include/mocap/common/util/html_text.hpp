#pragma once
// Text for HTML pages (the synthesis report, the 3D player's pages).
#include <string>

namespace mocap {

/// `s` with &, <, > and " escaped for HTML text and attribute values.
std::string html_escape(const std::string& s);

}  // namespace mocap
