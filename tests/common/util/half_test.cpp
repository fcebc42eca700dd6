// Half floats for bound tables (mocap/common/util/half.hpp): directed rounding is exact
// where possible and otherwise brackets the value between neighbours.
#include "mocap/common/util/half.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace mocap {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

bool is_nan_half(std::uint16_t h) {
  return (h & 0x7c00u) == 0x7c00u && (h & 0x3ffu) != 0;
}

// The slow reference: the conversions as first written, with std::ldexp and
// the library's classification.
float reference_half_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t exp = (h >> 10) & 0x1fu, man = h & 0x3ffu;
  if (exp == 0) {
    const float v = std::ldexp(static_cast<float>(man), -24);
    return sign != 0 ? -v : v;
  }
  const std::uint32_t bits =
      exp == 31 ? (sign | 0x7f800000u | (man << 13)) : (sign | ((exp + 112) << 23) | (man << 13));
  return std::bit_cast<float>(bits);
}

std::uint16_t reference_float_to_half(float x, bool up) {
  if (std::isnan(x)) return 0x7e00u;
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const std::uint16_t sign = (bits >> 31) != 0 ? 0x8000u : 0u;
  const float a = std::fabs(x);
  std::uint16_t mag = 0;
  if (std::isinf(a)) {
    mag = 0x7c00u;
  } else if (a >= 65504.0f) {
    mag = 0x7bffu;
  } else if (a < std::ldexp(1.0f, -14)) {
    mag = static_cast<std::uint16_t>(std::ldexp(a, 24));
  } else {
    const std::uint32_t ab = bits & 0x7fffffffu;
    const std::uint32_t e = (ab >> 23) - 127 + 15;
    mag = static_cast<std::uint16_t>((e << 10) | ((ab >> 13) & 0x3ffu));
  }
  const auto h = static_cast<std::uint16_t>(sign | mag);
  if (reference_half_to_float(h) == x) return h;
  const bool away = sign == 0 ? up : !up;
  return away ? static_cast<std::uint16_t>(h + 1) : h;
}

std::uint16_t reference_float_to_half_nearest(float x) {
  if (std::isnan(x)) return 0x7e00u;
  if (x >= 65504.0f) return 0x7bffu;
  if (x <= -65504.0f) return 0xfbffu;
  const std::uint16_t down = reference_float_to_half(x, false),
                      up = reference_float_to_half(x, true);
  return x - reference_half_to_float(down) <= reference_half_to_float(up) - x ? down : up;
}

// The inline conversions equal the reference bit for bit: every half, every
// float next to a half (and the halves' midpoints), and 4 M random bit
// patterns (NaNs, infinities, subnormals, both signs).
TEST(Half, ConversionsEqualTheReferenceBitForBit) {
  auto same = [](float x) {
    ASSERT_EQ(float_to_half(x, false), reference_float_to_half(x, false)) << x;
    ASSERT_EQ(float_to_half(x, true), reference_float_to_half(x, true)) << x;
    ASSERT_EQ(float_to_half_nearest(x), reference_float_to_half_nearest(x)) << x;
  };
  for (std::uint32_t h = 0; h < 65536; ++h) {
    const auto hh = static_cast<std::uint16_t>(h);
    const float f = half_to_float(hh), r = reference_half_to_float(hh);
    ASSERT_EQ(std::bit_cast<std::uint32_t>(f), std::bit_cast<std::uint32_t>(r)) << h;
    const auto b = std::bit_cast<std::uint32_t>(f);
    for (const std::uint32_t n : {b - 1, b, b + 1, b + 0x1000u}) same(std::bit_cast<float>(n));
  }
  std::mt19937 rng(11);
  for (int i = 0; i < 4000000; ++i) same(std::bit_cast<float>(static_cast<std::uint32_t>(rng())));
}

TEST(Half, NanAndInfinities) {
  EXPECT_TRUE(is_nan_half(float_to_half(std::numeric_limits<float>::quiet_NaN(), false)));
  EXPECT_TRUE(std::isnan(half_to_float(0x7e00u)));
  EXPECT_EQ(float_to_half(kInf, false), 0x7c00u);
  EXPECT_EQ(float_to_half(-kInf, true), 0xfc00u);
  EXPECT_EQ(half_to_float(0x7c00u), kInf);
  EXPECT_EQ(half_to_float(0xfc00u), -kInf);
  // Beyond the largest finite half: the bound side is infinite, the other 65504.
  EXPECT_EQ(half_to_float(float_to_half(70000.0f, true)), kInf);
  EXPECT_EQ(half_to_float(float_to_half(70000.0f, false)), 65504.0f);
  EXPECT_EQ(half_to_float(float_to_half(-70000.0f, false)), -kInf);
  EXPECT_EQ(half_to_float(float_to_half(-70000.0f, true)), -65504.0f);
}

TEST(Half, EveryHalfRoundTripsBothWays) {
  std::vector<std::uint16_t> all(65536);
  std::vector<float> fast(65536);
  for (std::uint32_t h = 0; h < 65536; ++h) all[h] = static_cast<std::uint16_t>(h);
  halves_to_floats(all.data(), all.size(), fast.data());
  for (std::uint32_t h = 0; h < 65536; ++h) {
    const auto x = static_cast<std::uint16_t>(h);
    const float f = half_to_float(x);
    if (std::isnan(f)) {
      EXPECT_TRUE(std::isnan(fast[h])) << h;
      continue;
    }
    EXPECT_EQ(fast[h], f) << h;  // F16C (where present) agrees with the reference
    if (f == 0.0f) {             // +0 and -0 compare equal; either is exact
      EXPECT_EQ(half_to_float(float_to_half(f, false)), 0.0f);
      continue;
    }
    EXPECT_EQ(float_to_half(f, false), x) << h;
    EXPECT_EQ(float_to_half(f, true), x) << h;
  }
}

// down(x) <= x <= up(x), and nothing representable lies strictly between:
// the two are neighbours (or equal when x is a half).
TEST(Half, DirectedRoundingBracketsRandomFloats) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> mant(1.0f, 2.0f);
  std::uniform_int_distribution<int> expo(-30, 17);
  for (int i = 0; i < 200000; ++i) {
    float x = std::ldexp(mant(rng), expo(rng));
    if (i % 2) x = -x;
    const std::uint16_t lo = float_to_half(x, false), hi = float_to_half(x, true);
    const float l = half_to_float(lo), u = half_to_float(hi);
    ASSERT_LE(l, x) << x;
    ASSERT_GE(u, x) << x;
    if (l == u) continue;
    // Neighbours: the next half above l is u (order of halves: bits for >= 0,
    // reversed for negative values).
    const float next = l >= 0.0f         ? half_to_float(static_cast<std::uint16_t>(lo + 1))
                       : (lo == 0x8000u) ? half_to_float(0x0001u)
                                         : half_to_float(static_cast<std::uint16_t>(lo - 1));
    ASSERT_EQ(next, u) << x;
  }
}

// Round to nearest: every finite half maps to itself; a float maps to the
// nearer of its two directed roundings, and lies within
// half_nearest_radius of it (the conservative-interval property the chain
// sketches rely on), with v - r and v + r exact; the radius is at most a
// half step of the binade (not vacuous). Clamped beyond the halves, where
// the radius is infinite.
TEST(Half, NearestRoundingLiesWithinItsRadius) {
  for (std::uint32_t h = 0; h < 65536; ++h) {
    const float f = half_to_float(static_cast<std::uint16_t>(h));
    if (std::isnan(f) || std::isinf(f)) continue;
    ASSERT_EQ(half_to_float(float_to_half_nearest(f)), f) << h;
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> mant(1.0f, 2.0f);
  std::uniform_int_distribution<int> expo(-40, 17);
  for (int i = 0; i < 400000; ++i) {
    float x = std::ldexp(mant(rng), expo(rng));
    if (i % 2) x = -x;
    const float v = half_to_float(float_to_half_nearest(x));
    const float r = half_nearest_radius(v);
    ASSERT_LE(v - r, x) << x;
    ASSERT_GE(v + r, x) << x;
    const float l = half_to_float(float_to_half(x, false)),
                u = half_to_float(float_to_half(x, true));
    ASSERT_LE(std::fabs(v - x), std::fabs(x - l)) << x;
    ASSERT_LE(std::fabs(v - x), std::fabs(u - x)) << x;
    if (std::fabs(v) < 65504.0f) {
      ASSERT_LE(r, std::max(std::fabs(v) * 0x1p-11f, 0x1p-25f)) << x;
      // The interval's ends are exact: they differ from v by exactly r.
      ASSERT_EQ((v + r) - v, r) << x;
      ASSERT_EQ(v - (v - r), r) << x;
    }
  }
  EXPECT_EQ(half_to_float(float_to_half_nearest(1e6f)), 65504.0f);
  EXPECT_EQ(half_to_float(float_to_half_nearest(-kInf)), -65504.0f);
  EXPECT_EQ(half_nearest_radius(65504.0f), kInf);
  EXPECT_EQ(half_nearest_radius(-65504.0f), kInf);
  EXPECT_EQ(half_nearest_radius(0.0f), 0x1p-25f);
  EXPECT_TRUE(is_nan_half(float_to_half_nearest(std::numeric_limits<float>::quiet_NaN())));
}

}  // namespace
}  // namespace mocap
