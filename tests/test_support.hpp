#pragma once
// Helpers shared by the tests: where the real data is, temporary folders.
#include <filesystem>
#include <string>

namespace mocap::test {

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
