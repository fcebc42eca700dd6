// libFuzzer target for the ASF (Acclaim skeleton) reader, common/src/io/asf_amc.cpp.
//
// Any input must either parse or throw mocap::InputError (never crash, hang or
// throw anything else). A parsed skeleton must be consistent: every bone has a
// name other than "root", a parent index in range, a unit direction
// (or a zero one when its length is 0), a length >= 0 and as many limits as dofs (or none), and
// a one-frame take at rest converts to a RawClip of one joint per bone + root.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/util/error.hpp"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "asf_fuzz: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  mocap::AsfSkeleton s;
  try {
    s = mocap::parse_asf(text, "fuzz");
  } catch (const mocap::InputError&) {
    return 0;
  }
  if (!(s.length > 0.0)) fail("length unit <= 0");
  const auto n = static_cast<int>(s.bones.size());
  for (const mocap::AsfBone& b : s.bones) {
    if (b.name.empty() || b.name == "root") fail("bone name");
    if (b.parent < -1 || b.parent >= n) fail("parent index out of range");
    if (!(b.length >= 0.0)) fail("negative length");
    // A bone of length > 0 has a unit direction; one of length 0 a unit or zero one.
    const double norm = b.direction.norm();
    if ((b.length > 0.0 || norm != 0.0) && std::abs(norm - 1.0) > 1e-9)
      fail("direction not normalised");
    if (!b.limits.empty() && b.limits.size() != b.dofs.size()) fail("limits != dofs");
    if (s.find_bone(b.name) < 0) fail("find_bone misses a bone");
  }
  for (const int c : s.root_children)
    if (c < 0 || c >= n || s.bones[static_cast<std::size_t>(c)].parent != -1) fail("root child");
  // The conversion of a one-frame take at rest walks the whole hierarchy.
  try {
    const mocap::AmcMotion m = mocap::parse_amc("1\n", "fuzz.amc", s);
    const mocap::RawClip clip = mocap::asf_amc_to_raw_clip(s, m);
    if (clip.joints.size() != s.bones.size() + 1) fail("clip joints != bones + 1");
    if (clip.values.size() != clip.channel_count) fail("clip values size");
  } catch (const mocap::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    fail("a one-frame take at rest does not parse");
  }
  return 0;
}
