#pragma once
// Helpers shared by the tests: where the real data is, temporary folders,
// the message of an input error.
#include <cstdlib>
#include <filesystem>
#include <string>

#include "mocap/common/util/error.hpp"

namespace mocap::test {

/// The message of the InputError that `f()` throws; "" when it throws none
/// (another exception passes through).
inline std::string input_error_message(const auto& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// True in a sanitizer build (MOCAP_SANITIZE: CI's AddressSanitizer and
/// UndefinedBehaviorSanitizer stage at -O1, where the set-1 scans run 20 to
/// 50 times slower than in Release). The heaviest exactness tests then check
/// a smaller sample of the same cases, so that every code path still runs
/// under the sanitizers; the Release run (the README's test command) checks
/// them all.
inline constexpr bool kSanitizerBuild = MOCAP_SANITIZER_BUILD != 0;

/// ../shared/data, or $MOCAP_DATA_DIR when set.
std::filesystem::path data_dir();
/// True when data_dir() holds the Bandai Namco set 1 folder.
bool have_data();
/// A fresh empty folder under the system temp dir, removed when the binary
/// exits normally (kept when MOCAP_KEEP_TEST_DIRS=1).
std::filesystem::path temp_dir(const std::string& tag);
/// Set 2 unpacked once per machine into a cache folder (tar --zstd; safe when
/// several test processes ask at once), or an
/// empty path when the archive or tar is unavailable.
std::filesystem::path bandai_namco_2_dir();

// `out`, an index of the BVH files in `dir` built with the mocap-index binary
// (with `character` when not empty); empty path on failure.
inline std::filesystem::path build_index_with_binary(const std::filesystem::path& dir,
                                                     const std::filesystem::path& out,
                                                     const std::filesystem::path& character) {
  const char* bin = std::getenv("MOCAP_BIN_DIR");
  const std::filesystem::path exe =
      std::filesystem::path(bin ? bin : MOCAP_BINARY_DIR) / "indexer/mocap-index";
  std::string cmd =
      "'" + exe.string() + "' build -q --out '" + out.string() + "' '" + dir.string() + "'";
  if (!character.empty()) cmd += " --character '" + character.string() + "'";
  cmd += " > /dev/null";
  if (!std::filesystem::exists(exe) || std::system(cmd.c_str()) != 0) return {};
  return out;
}

}  // namespace mocap::test

/// Skips the current test when the real data is absent (local builds without ../shared).
#define MOCAP_REQUIRE_DATA()                                                                     \
  do {                                                                                           \
    if (!::mocap::test::have_data()) GTEST_SKIP() << "no data at " << ::mocap::test::data_dir(); \
  } while (0)
