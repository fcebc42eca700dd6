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

/// The value of half `h` (exact: every half is a float). NaN halves give NaN.
float half_to_float(std::uint16_t h);

/// The largest half <= x (`up` false) or the smallest half >= x (`up` true).
/// Beyond the finite halves (|x| > 65504) that is +-65504 or +-infinity;
/// infinities map to infinities, NaN to a NaN half.
std::uint16_t float_to_half(float x, bool up);

/// The half nearest to x (ties either way), finite: values beyond the
/// finite halves (|x| > 65504, infinities) are clamped to +-65504, NaN gives
/// a NaN half. With half_nearest_radius, [h - r, h + r] holds x: a table of
/// such halves gives bounds that stay sound when evaluated on the intervals.
std::uint16_t float_to_half_nearest(float x);

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
