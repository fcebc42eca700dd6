#include "test_support.hpp"

#include <cstdlib>
#include <random>
#include <system_error>

namespace mocap::test {

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("MOCAP_DATA_DIR"); env && *env) return env;
  return MOCAP_DEFAULT_DATA_DIR;
}

bool have_data() { return std::filesystem::is_directory(data_dir() / "bandai-namco-1" / "data"); }

std::filesystem::path temp_dir(const std::string& tag) {
  std::random_device rd;
  auto dir = std::filesystem::temp_directory_path() /
             ("mocap-test-" + tag + "-" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  return dir;
}

std::filesystem::path bandai_namco_2_dir() {
  const auto archive = data_dir() / "bandai-namco-2.tar.zst";
  if (!std::filesystem::exists(archive)) return {};
  std::filesystem::path cache;
  if (const char* env = std::getenv("MOCAP_BN2_DIR"); env && *env) return env;
  cache = std::filesystem::temp_directory_path() / "mocap-bandai-namco-2";
  const auto done = cache / ".unpacked";
  if (!std::filesystem::exists(done)) {
    std::error_code ec;
    std::filesystem::create_directories(cache, ec);
    const std::string cmd = "tar --zstd -xf '" + archive.string() + "' -C '" + cache.string() + "'";
    if (std::system(cmd.c_str()) != 0) return {};
    std::FILE* f = std::fopen(done.c_str(), "w");
    if (f) std::fclose(f);
  }
  return cache / "bandai-namco-2" / "data";
}

}  // namespace mocap::test
