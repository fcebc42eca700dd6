// libFuzzer target for the AMC (Acclaim motion) reader, common/src/io/asf_amc.cpp.
//
// The input is an AMC text read against a fixed small skeleton (below: a root
// with all six dofs, a bone with three rotations, one with one and one with
// none). It must either parse or throw mocap::InputError (never crash, hang or
// throw anything else). A parsed take must have frame_count x value_count
// finite values, and its conversion to RawClip must succeed with a consistent
// layout.
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
  std::fprintf(stderr, "amc_fuzz: %s\n", what);
  std::abort();
}

constexpr std::string_view kAsf =
    ":version 1.10\n"
    ":name fuzz\n"
    ":units\n"
    "  length 0.45\n"
    "  angle deg\n"
    ":root\n"
    "  order TX TY TZ RX RY RZ\n"
    "  axis XYZ\n"
    "  position 0 0 0\n"
    "  orientation 0 0 0\n"
    ":bonedata\n"
    "  begin\n"
    "    id 1\n"
    "    name hip\n"
    "    direction 0 1 0\n"
    "    length 2\n"
    "    axis 0 0 20 XYZ\n"
    "    dof rx ry rz\n"
    "  end\n"
    "  begin\n"
    "    id 2\n"
    "    name knee\n"
    "    direction 0 -1 0\n"
    "    length 3\n"
    "    axis 10 0 0 ZYX\n"
    "    dof rz\n"
    "  end\n"
    "  begin\n"
    "    id 3\n"
    "    name toe\n"
    "    direction 1 0 0\n"
    "    length 1\n"
    "    axis 0 0 0 XYZ\n"
    "  end\n"
    ":hierarchy\n"
    "  begin\n"
    "    root hip\n"
    "    hip knee\n"
    "    knee toe\n"
    "  end\n";

const mocap::AsfSkeleton& skeleton() {
  static const mocap::AsfSkeleton s = mocap::parse_asf(kAsf, "fuzz.asf");
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const mocap::AsfSkeleton& s = skeleton();
  mocap::AmcMotion m;
  try {
    m = mocap::parse_amc(text, "fuzz.amc", s);
  } catch (const mocap::InputError&) {
    return 0;
  }
  if (m.value_count != 6 + 3 + 1) fail("value_count");
  if (m.values.size() != m.frame_count * m.value_count) fail("values size != frames x values");
  for (const double v : m.values)
    if (!std::isfinite(v)) fail("non-finite value");
  const mocap::RawClip clip = mocap::asf_amc_to_raw_clip(s, m);
  if (clip.frame_count != m.frame_count || clip.joints.size() != 4 ||
      clip.channel_count != 6 + 3 + 3)
    fail("clip layout");
  if (clip.values.size() != clip.frame_count * clip.channel_count) fail("clip values size");
  return 0;
}
