// resolve_clip_labels: a clip's labels from its sidecar NAME.json (with
// cfg/<key>_label.txt line numbers) or its file name (index_builder.hpp).
#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/util/json_text.hpp"
#include "mocap/indexer/index_builder.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    out.push_back(s.substr(start, p == std::string::npos ? std::string::npos : p - start));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  return out;
}

bool all_digits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return c >= '0' && c <= '9'; });
}

/// Line `n` (0-based) of cfg/<key>_label.txt near the clip, if any.
std::optional<std::string> cfg_label(const fs::path& bvh, const std::string& key, long long n) {
  if (n < 0) return std::nullopt;
  fs::path dir = bvh.parent_path();
  for (int up = 0; up < 3 && !dir.empty(); ++up, dir = dir.parent_path()) {
    const fs::path cfg = dir / "cfg" / (key + "_label.txt");
    std::error_code ec;
    if (!fs::is_regular_file(cfg, ec)) continue;
    std::ifstream in(cfg);
    std::string line;
    for (long long i = 0; std::getline(in, line); ++i) {
      if (i != n) continue;
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
        line.pop_back();
      // Drop a collection prefix ("dataset-1_") that also starts the file name.
      const std::size_t us = line.find('_');
      const std::string stem = bvh.stem().string();
      if (us != std::string::npos && us + 1 < line.size() &&
          stem.compare(0, us + 1, line, 0, us + 1) == 0)
        line = line.substr(us + 1);
      return line;
    }
    return std::nullopt;
  }
  return std::nullopt;
}

// Labels of a file name PREFIX_CONTENT_STYLE_TAKE (take numeric): content
// and style; none otherwise.
std::vector<std::pair<std::string, std::string>> file_name_labels(const fs::path& bvh) {
  const auto parts = split(bvh.stem().string(), '_');
  if (parts.size() < 4 || !all_digits(parts.back())) return {};
  std::string content = parts[1];
  for (std::size_t i = 2; i + 2 < parts.size(); ++i) content += "_" + parts[i];
  return {{"content", content}, {"style", parts[parts.size() - 2]}};
}

}  // namespace

ClipLabels resolve_clip_labels(const fs::path& bvh) {
  ClipLabels out;
  const auto from_name = file_name_labels(bvh);
  fs::path sidecar = bvh;
  sidecar.replace_extension(".json");
  std::error_code ec;
  if (fs::is_regular_file(sidecar, ec)) {
    std::ifstream in(sidecar);
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_object()) {
      out.source = LabelSource::sidecar;
      for (const auto& [key, value] : j.items()) {
        std::string label;
        if (value.is_number_integer()) {
          const auto named = std::find_if(from_name.begin(), from_name.end(),
                                          [&](const auto& kv) { return kv.first == key; });
          if (auto l = cfg_label(bvh, key, value.get<long long>())) {
            label = *l;
            out.source = LabelSource::sidecar_cfg;
          } else if (named != from_name.end()) {
            label = named->second;  // no cfg file to read the number: the file name's
          } else {
            label = std::to_string(value.get<long long>());
          }
        } else if (value.is_string()) {
          label = value.get<std::string>();
        } else {
          label = json_text(value);
        }
        out.labels.emplace_back(key, label);
      }
      std::sort(out.labels.begin(), out.labels.end());
      return out;
    }
  }
  if (!from_name.empty()) {
    out.source = LabelSource::file_name;
    out.labels = from_name;
  }
  return out;
}

}  // namespace mocap
