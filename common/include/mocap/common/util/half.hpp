#pragma once
// IEEE 754 binary16 ("half") storage for tables of bounds: a box stored as
// halves rounded outwards (its minima down, its maxima up) still holds every
// value it held, in half the bytes. Conversions are exact where a half can
// represent the value; float_to_half_nearest alone rounds to nearest, and
// half_nearest_radius says how far the value may have moved.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace mocap {

// The conversions are inline: the search converts every block box and chain
// sketch when it loads an index (a quarter of a one-query process's time
// when they were calls with std::ldexp).

/// The value of half `h` (exact: every half is a float). NaN halves give NaN.
inline float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t exp = (h >> 10) & 0x1fu, man = h & 0x3ffu;
  if (exp == 0) {  // zero or subnormal: man 2^-24 (exact in float)
    const float v = static_cast<float>(man) * 0x1p-24f;
    return sign != 0 ? -v : v;
  }
  const std::uint32_t bits =
      exp == 31 ? (sign | 0x7f800000u | (man << 13)) : (sign | ((exp + 112) << 23) | (man << 13));
  return std::bit_cast<float>(bits);
}

/// The largest half <= x (`up` false) or the smallest half >= x (`up` true).
/// Beyond the finite halves (|x| > 65504) that is +-65504 or +-infinity;
/// infinities map to infinities, NaN to a NaN half.
inline std::uint16_t float_to_half(float x, bool up) {
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const std::uint32_t ab = bits & 0x7fffffffu;
  if (ab > 0x7f800000u) return 0x7e00u;  // NaN
  const std::uint16_t sign = (bits >> 31) != 0 ? 0x8000u : 0u;
  if (ab >= 0x38800000u && ab < 0x477fe000u) {  // 2^-14 <= |x| < 65504: a normal half
    // |x| rounded toward zero: the float's bits with the exponent rebased;
    // exact when the 13 bits dropped are zero.
    const auto mag = static_cast<std::uint16_t>((ab >> 13) - (112u << 10));
    const bool away = (ab & 0x1fffu) != 0 && (sign == 0 ? up : !up);
    return static_cast<std::uint16_t>(sign | (away ? mag + 1 : mag));
  }
  const float a = std::bit_cast<float>(ab);
  std::uint16_t mag = 0;  // |x| rounded toward zero
  if (ab == 0x7f800000u) {
    mag = 0x7c00u;
  } else if (a >= 65504.0f) {
    mag = 0x7bffu;
  } else if (a < 0x1p-14f) {
    mag = static_cast<std::uint16_t>(a * 0x1p24f);  // subnormal half: truncates (exact product)
  } else {
    const std::uint32_t e = (ab >> 23) - 127 + 15;
    mag = static_cast<std::uint16_t>((e << 10) | ((ab >> 13) & 0x3ffu));
  }
  const auto h = static_cast<std::uint16_t>(sign | mag);
  if (half_to_float(h) == x) return h;
  // |h| < |x|: the other neighbour is one step away from zero.
  const bool away = sign == 0 ? up : !up;
  return away ? static_cast<std::uint16_t>(h + 1) : h;
}

/// The half nearest to x (ties either way), finite: values beyond the
/// finite halves (|x| > 65504, infinities) are clamped to +-65504, NaN gives
/// a NaN half. With half_nearest_radius, [h - r, h + r] holds x: a table of
/// such halves gives bounds that stay sound when evaluated on the intervals.
inline std::uint16_t float_to_half_nearest(float x) {
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const std::uint32_t ab = bits & 0x7fffffffu;
  if (ab >= 0x38800000u && ab < 0x477fe000u) {  // a normal half
    // Of |x|'s two neighbours the one toward zero when the dropped 13 bits
    // are below half a step; at exactly half, the lower (below x) of the
    // two, as the comparison below chooses.
    const auto mag = static_cast<std::uint16_t>((ab >> 13) - (112u << 10));
    const std::uint32_t rest = ab & 0x1fffu;
    if ((bits >> 31) == 0) return rest <= 0x1000u ? mag : static_cast<std::uint16_t>(mag + 1);
    return static_cast<std::uint16_t>(0x8000u | (rest >= 0x1000u ? mag + 1 : mag));
  }
  if (x != x) return 0x7e00u;  // NaN
  if (x >= 65504.0f) return 0x7bffu;
  if (x <= -65504.0f) return 0xfbffu;
  const std::uint16_t down = float_to_half(x, false), up = float_to_half(x, true);
  return x - half_to_float(down) <= half_to_float(up) - x ? down : up;
}

/// An upper bound r of |x - half_to_float(h)| for h = float_to_half_nearest(x),
/// from the half's value v alone: half a unit in the last place of v's binade
/// (2^-11 |v| at most), 2^-25 for subnormal halves and zero, and infinity at
/// +-65504 (where values beyond the halves were clamped). v - r and v + r are
/// exact in float.
inline float half_nearest_radius(float v) {
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(v) & 0x7fffffffu;
  if (bits >= 0x477fe000u) return std::numeric_limits<float>::infinity();  // |v| >= 65504
  const float binade = std::bit_cast<float>(bits & 0x7f800000u);           // 2^floor(log2 |v|)
  const float r = binade * 0x1p-11f;
  return r > 0x1p-25f ? r : 0x1p-25f;
}

/// out[i] = half_to_float(in[i]) for i < n, 8 at a time with the F16C
/// instructions where the CPU has them (same values).
void halves_to_floats(const std::uint16_t* in, std::size_t n, float* out);

}  // namespace mocap
