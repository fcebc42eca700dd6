#include "test_support.hpp"

#include <cstdlib>
#include <mutex>
#include <random>
#include <system_error>
#include <vector>

namespace mocap::test {

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("MOCAP_DATA_DIR"); env && *env) return env;
  return MOCAP_DEFAULT_DATA_DIR;
}

bool have_data() {
  return std::filesystem::is_directory(data_dir() / "bandai-namco-1" / "data");
}

namespace {

// The folders temp_dir handed out, removed when the test binary exits
// normally (static destruction). A crashed binary leaves its folders; set
// MOCAP_KEEP_TEST_DIRS=1 to keep them on purpose (debugging).
class TempDirs {
 public:
  void add(const std::filesystem::path& dir) {
    std::lock_guard lock(mutex_);
    dirs_.push_back(dir);
  }
  ~TempDirs() {
    if (const char* keep = std::getenv("MOCAP_KEEP_TEST_DIRS"); keep && *keep && *keep != '0')
      return;
    for (const auto& dir : dirs_) {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  }

 private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

TempDirs& temp_dirs() {
  static TempDirs dirs;
  return dirs;
}

}  // namespace

std::filesystem::path temp_dir(const std::string& tag) {
  auto& registry =
      temp_dirs();  // constructed before, so destroyed after, any static using a folder
  std::random_device rd;
  auto dir =
      std::filesystem::temp_directory_path() / ("mocap-test-" + tag + "-" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  registry.add(dir);
  return dir;
}

std::filesystem::path bandai_namco_2_dir() {
  const auto archive = data_dir() / "bandai-namco-2.tar.zst";
  if (!std::filesystem::exists(archive)) return {};
  if (const char* env = std::getenv("MOCAP_BN2_DIR"); env && *env) return env;
  const auto cache = std::filesystem::temp_directory_path() / "mocap-bandai-namco-2";
  const auto data = cache / "bandai-namco-2" / "data";
  if (std::filesystem::exists(cache / ".unpacked")) return data;
  // Test processes run in parallel: each unpacks into its own folder and
  // renames it into place, so no process ever reads a half-written cache.
  // The first rename wins; the others find the cache complete and drop theirs.
  std::random_device rd;
  const auto mine = cache.string() + ".tmp-" + std::to_string(rd());
  std::error_code ec;
  std::filesystem::create_directories(mine, ec);
  const std::string cmd = "tar --zstd -xf '" + archive.string() + "' -C '" + mine + "'";
  if (ec || std::system(cmd.c_str()) != 0) {
    std::filesystem::remove_all(mine, ec);
    return {};
  }
  if (std::FILE* f = std::fopen((mine + "/.unpacked").c_str(), "w")) std::fclose(f);
  std::filesystem::rename(mine, cache, ec);
  if (ec && !std::filesystem::exists(cache / ".unpacked")) {
    // A cache left half-written by an older version: replace it.
    std::filesystem::remove_all(cache, ec);
    std::filesystem::rename(mine, cache, ec);
  }
  std::filesystem::remove_all(mine, ec);
  return std::filesystem::exists(cache / ".unpacked") ? data : std::filesystem::path{};
}

}  // namespace mocap::test
