// libFuzzer target for the query parser (search/src/query/query.cpp).
//
// Any input must either parse or throw mocap::InputError (never crash or
// hang). A parsed query keeps the parser's promises: 2 to input_limits().query_frames
// frames, a transition time in range, top >= 1, finite given values.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/search/query.hpp"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "query_fuzz: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mocap::Query q;
  try {
    q = mocap::parse_query_text(text, "fuzz", 1, "/nonexistent", "q");
  } catch (const mocap::InputError&) {
    return 0;
  }
  if (q.frames.size() < 2 || q.frames.size() > mocap::input_limits().query_frames)
    fail("frame count");
  if (!(q.transition_time_s >= 1e-3 && q.transition_time_s <= 60.0)) fail("transition time");
  if (q.top < 1) fail("top");
  if (!std::isfinite(q.path_weight) || q.path_weight < 0.0) fail("path weight");
  for (const auto& f : q.frames) {
    for (const auto& p : f.root_position_m)
      if (p && !(std::abs(*p) <= 1e4)) fail("root position");
    for (const auto& j : f.joints)
      if (!std::isfinite(j.rotation.norm()) || std::abs(j.rotation.norm() - 1.0) > 1e-6)
        fail("joint rotation not unit");
  }
  return 0;
}
