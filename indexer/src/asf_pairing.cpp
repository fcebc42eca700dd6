// ASF/AMC pairing and capture-file reading (asf_pairing.hpp).
#include "mocap/indexer/asf_pairing.hpp"

#include <algorithm>
#include <cctype>
#include <system_error>

#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {
bool has_extension(const fs::path& p, const char* want) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == want;
}

constexpr const char* kRulesTried =
    "no ASF skeleton for this AMC file (tried --asf, the folder's only .asf, NN.asf for "
    "NN_MM.amc, the same name, an ASF named by a prefix of the name; docs/asf-amc.md)";
}  // namespace

bool has_amc_extension(const fs::path& p) {
  return has_extension(p, ".amc");
}
bool has_asf_extension(const fs::path& p) {
  return has_extension(p, ".asf");
}

// The rules in order (header). Rules 3-5 compare stems: NAME.asf whose stem
// is wanted exactly (rules 3, 4) or is the longest proper prefix (rule 5).
AsfPairing pair_asf_by_name(const fs::path& amc, const std::optional<fs::path>& asf_option,
                            const std::vector<std::string>& folder_asf_names) {
  AsfPairing out;
  if (amc.empty() || !has_amc_extension(amc) || amc.stem().empty()) {
    out.error = "not an AMC file name (expected NAME.amc)";
    return out;
  }
  if (asf_option) {
    if (asf_option->empty())
      out.error = "--asf is empty";
    else
      out.asf = *asf_option;
    return out;
  }
  std::vector<std::string> names;
  for (const auto& n : folder_asf_names)
    if (has_asf_extension(n) && !fs::path(n).stem().empty()) names.push_back(n);
  const fs::path folder = amc.parent_path();
  if (names.size() == 1) {
    out.asf = folder / names.front();
    return out;
  }
  const std::string stem = amc.stem().string();
  auto with_stem = [&](const std::string& want) -> const std::string* {
    for (const auto& n : names)
      if (fs::path(n).stem().string() == want) return &n;
    return nullptr;
  };
  if (const auto us = stem.rfind('_'); us != std::string::npos && us > 0 && us + 1 < stem.size())
    if (const std::string* n = with_stem(stem.substr(0, us))) {
      out.asf = folder / *n;
      return out;
    }
  if (const std::string* n = with_stem(stem)) {
    out.asf = folder / *n;
    return out;
  }
  const std::string* best = nullptr;
  std::size_t best_len = 0;
  for (const auto& n : names) {
    const std::string s = fs::path(n).stem().string();
    if (s.size() < stem.size() && stem.compare(0, s.size(), s) == 0 && s.size() > best_len) {
      best = &n;
      best_len = s.size();
    }
  }
  if (best)
    out.asf = folder / *best;
  else
    out.error = std::string(kRulesTried) + ", " + std::to_string(names.size()) +
                " .asf file(s) in its folder";
  return out;
}

AsfPairing pair_asf(const fs::path& amc, const std::optional<fs::path>& asf_option) {
  std::error_code ec;
  if (asf_option && !asf_option->empty() && !fs::is_regular_file(*asf_option, ec)) {
    AsfPairing out;
    out.error = "--asf " + asf_option->string() + ": no such file";
    return out;
  }
  std::vector<std::string> names;
  if (!asf_option) {
    const fs::path folder = amc.parent_path().empty() ? fs::path(".") : amc.parent_path();
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      const fs::path& p = it->path();
      std::error_code fec;
      if (has_asf_extension(p) && fs::is_regular_file(p, fec))
        names.push_back(p.filename().string());
    }
  }
  return pair_asf_by_name(amc, asf_option, names);
}

CaptureFile read_capture_file(const fs::path& path, const AmcReadOptions& amc) {
  CaptureFile out;
  if (!has_amc_extension(path)) {
    out.clip = read_bvh_file(path);
    return out;
  }
  const AsfPairing pairing = pair_asf(path, amc.asf);
  if (pairing.asf.empty()) throw InputError(path.string(), 0, pairing.error);
  const AsfSkeleton skeleton = read_asf_file(pairing.asf);
  const AmcMotion motion = read_amc_file(path, skeleton);
  if (!(amc.frame_time_s > 0.0))
    throw InputError(path.string(), 0, "the AMC frame rate must be positive");
  out.clip = asf_amc_to_raw_clip(skeleton, motion, amc.frame_time_s);
  out.asf = pairing.asf;
  out.metres_per_unit = skeleton.metres_per_unit();
  return out;
}

}  // namespace mocap
