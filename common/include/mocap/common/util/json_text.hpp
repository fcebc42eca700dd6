#pragma once
// JSON text of the tools' outputs. Strings that are not valid UTF-8 (a file
// or joint name in Latin-1, a byte of a damaged file quoted in a message) are
// written with each invalid byte replaced by U+FFFD instead of aborting the
// output (nlohmann::json's dump throws on them by default).
#include <nlohmann/json.hpp>
#include <string>

namespace mocap {

/// j.dump(indent) with invalid UTF-8 replaced (indent -1: one line).
inline std::string json_text(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace mocap
