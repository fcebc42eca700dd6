#pragma once
// Shared by the synth tests: an index of data folders built once per test
// binary with this build's indexer, and clips by file name.
#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/synth/synth.hpp"
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

// A gap from frame a of clip x to frame b of clip y (same skeleton), y
// placed by the assembly rule 0.4 s ahead (continuation_placement).
struct RealGap {
  SynthSkeleton sk;
  RangeOfMotion rom;
  GapProblem gap;
};
inline std::unique_ptr<RealGap> make_gap(const Index& index, std::size_t x, std::size_t a,
                                         std::size_t y, std::size_t b) {
  auto g = std::make_unique<RealGap>();
  g->sk = make_synth_skeleton(index, index.clips()[x].skeleton, x);
  g->rom = range_of_motion(index, g->sk, index.skeletons()[index.clips()[x].skeleton].clips);
  auto& gap = g->gap;
  gap.skeleton = &g->sk;
  gap.range = &g->rom;
  gap.frame_time_s = index.clips()[x].frame_time_s;
  gap.before = clip_frame(index, x, a - 1);
  gap.start = clip_frame(index, x, a);
  const SynthFrame g0 = clip_frame(index, y, b), g1 = clip_frame(index, y, b + 1);
  const double dt = gap.frame_time_s;
  const auto p =
      continuation_placement(g->sk, gap.start, horizontal_root_velocity(gap.before, gap.start, dt),
                             g0, horizontal_root_velocity(g0, g1, dt), 0.4);
  gap.goal = place_frame(g->sk, g0, p);
  gap.after = place_frame(g->sk, g1, p);
  return g;
}

// The same, clips given by file name.
inline std::unique_ptr<RealGap> make_gap(const Index& index, const std::string& x, std::size_t a,
                                         const std::string& y, std::size_t b) {
  return make_gap(index, clip_named(index, x), a, clip_named(index, y), b);
}

}  // namespace mocap::test
