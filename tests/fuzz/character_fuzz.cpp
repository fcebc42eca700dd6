// libFuzzer target for the character-file parser (common/src/body/character.cpp).
//
// Any input must either parse or throw mocap::InputError (never crash or
// hang); a parsed character's masses and scales are within docs/cli.md
// "Value ranges".
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mocap/common/body/character.hpp"
#include "mocap/common/util/error.hpp"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "character_fuzz: %s\n", what);
  std::abort();
}

bool in_range(double v, double max) {
  return std::isfinite(v) && v > 0.0 && v <= max;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mocap::Character c;
  try {
    c = mocap::parse_character_json(text, "fuzz");
  } catch (const mocap::InputError&) {
    return 0;
  }
  if (!in_range(c.total_mass_kg, 1e4)) fail("total mass");
  for (const auto& [k, v] : c.class_mass_kg)
    if (!in_range(v, 1e4)) fail("class mass");
  for (const auto& [k, v] : c.joint_mass_kg)
    if (!in_range(v, 1e4)) fail("joint mass");
  for (const auto& [k, v] : c.class_length_scale)
    if (!in_range(v, 100.0)) fail("class length scale");
  return 0;
}
