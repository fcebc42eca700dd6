#pragma once
// Helpers shared by the tests: where the real data is, temporary folders.
#include <filesystem>
#include <string>

namespace mocap::test {

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

}  // namespace mocap::test

/// Skips the current test when the real data is absent (local builds without ../shared).
#define MOCAP_REQUIRE_DATA()                                                                     \
  do {                                                                                           \
    if (!::mocap::test::have_data()) GTEST_SKIP() << "no data at " << ::mocap::test::data_dir(); \
  } while (0)
