#pragma once
// IEEE 754 binary16 ("half") storage for tables of bounds: a box stored as
// halves rounded outwards (its minima down, its maxima up) still holds every
// value it held, in half the bytes. Conversions are exact where a half can
// represent the value; nothing here rounds to nearest.
#include <cstddef>
#include <cstdint>

namespace mocap {

/// The value of half `h` (exact: every half is a float). NaN halves give NaN.
float half_to_float(std::uint16_t h);

/// The largest half <= x (`up` false) or the smallest half >= x (`up` true).
/// Beyond the finite halves (|x| > 65504) that is +-65504 or +-infinity;
/// infinities map to infinities, NaN to a NaN half.
std::uint16_t float_to_half(float x, bool up);

/// out[i] = half_to_float(in[i]) for i < n, 8 at a time with the F16C
/// instructions where the CPU has them (same values).
void halves_to_floats(const std::uint16_t* in, std::size_t n, float* out);

}  // namespace mocap
