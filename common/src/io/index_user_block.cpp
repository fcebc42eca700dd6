// The index file's user block: "MOCAP-INDEX-USERBLOCK 1\nbytes <N>\nxxh64 <hex>\n",
// zero padded to kIndexUserBlockBytes, in front of the HDF5 data: written last
// (seal_index_file), checked first (check_index_file).
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>

#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {
constexpr const char* kUserBlockMagic = "MOCAP-INDEX-USERBLOCK 1\n";

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;
}  // namespace

void seal_index_file(const fs::path& path) {
  FilePtr f(std::fopen(path.c_str(), "r+b"));
  if (!f) throw InputError(path.string(), 0, "cannot open to seal");
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec || size < kIndexUserBlockBytes)
    throw InputError(path.string(), 0, "too small to be an index");
  const std::uint64_t h = hash_file(path, kIndexUserBlockBytes);
  std::string block =
      std::string(kUserBlockMagic) + "bytes " + std::to_string(size) + "\nxxh64 " + hex64(h) + "\n";
  block.resize(kIndexUserBlockBytes, '\0');
  if (std::fseek(f.get(), 0, SEEK_SET) != 0 ||
      std::fwrite(block.data(), 1, block.size(), f.get()) != block.size() ||
      std::fflush(f.get()) != 0)
    throw InputError(path.string(), 0, "cannot write the user block");
}

void check_index_file(const fs::path& path, bool hash) {
  const std::string p = path.string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(p, 0, "no such index file");
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) throw InputError(p, 0, "cannot get the file size");
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw InputError(p, 0, "cannot open for reading");
  char block[kIndexUserBlockBytes] = {0};
  const std::size_t got = std::fread(block, 1, sizeof block, f.get());
  const std::size_t magic_len = std::strlen(kUserBlockMagic);
  if (got < magic_len || std::memcmp(block, kUserBlockMagic, magic_len) != 0)
    throw InputError(
        p, 0, "not a mocap index (no index user block; was it written by mocap-index build?)");
  std::istringstream in(
      std::string(block + magic_len, strnlen(block + magic_len, sizeof block - magic_len)));
  std::string k1, k2, hex;
  std::uint64_t expected = 0;
  if (!(in >> k1 >> expected >> k2 >> hex) || k1 != "bytes" || k2 != "xxh64" || hex.size() != 16)
    throw InputError(p, 0, "damaged index user block");
  // The block must be exactly what seal_index_file writes (padding included).
  std::string canonical =
      std::string(kUserBlockMagic) + "bytes " + std::to_string(expected) + "\nxxh64 " + hex + "\n";
  canonical.resize(kIndexUserBlockBytes, '\0');
  if (got != kIndexUserBlockBytes ||
      std::memcmp(canonical.data(), block, kIndexUserBlockBytes) != 0)
    throw InputError(p, 0, "damaged index user block");
  if (size < expected)
    throw InputError(
        p, 0, "truncated: " + std::to_string(size) + " of " + std::to_string(expected) + " bytes");
  if (size > expected)
    throw InputError(
        p, 0, "damaged: " + std::to_string(size - expected) + " unexpected bytes after the index");
  if (!hash) return;
  const std::uint64_t h = hash_file(path, kIndexUserBlockBytes);
  if (hex64(h) != hex)
    throw InputError(
        p, 0,
        "checksum mismatch: the file is damaged (xxh64 " + hex64(h) + ", expected " + hex + ")");
}

}  // namespace mocap
