#pragma once
// Shared by the synth tests: an index of data folders built once per test
// binary with this build's indexer, and clips by file name.
#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mocap/common/index.hpp"
#include "test_support.hpp"

namespace mocap::test {

// The index of `folders` (under data_dir()), built on first use into a
// temporary folder; null when the build fails.
inline const Index* built_index(const std::vector<std::string>& folders) {
  static std::map<std::vector<std::string>, std::unique_ptr<Index>> built;
  auto it = built.find(folders);
  if (it != built.end()) return it->second.get();
  auto& slot = built[folders];
  const auto out = temp_dir("synth-index") / "index.h5";
  std::string cmd =
      std::string(MOCAP_BINARY_DIR) + "/indexer/mocap-index build -q --out '" + out.string() + "'";
  for (const auto& f : folders) cmd += " '" + (data_dir() / f).string() + "'";
  cmd += " >/dev/null 2>&1";
  if (std::system(cmd.c_str()) == 0) slot = std::make_unique<Index>(Index::open(out));
  return slot.get();
}

// The clip whose file is `name` (a test failure when there is none).
inline std::size_t clip_named(const Index& index, const std::string& name) {
  for (std::size_t c = 0; c < index.clips().size(); ++c)
    if (index.clips()[c].path.ends_with("/" + name)) return c;
  ADD_FAILURE() << "no clip " << name;
  return 0;
}

}  // namespace mocap::test
