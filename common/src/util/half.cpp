#include "mocap/common/util/half.hpp"

#include <bit>
#include <cmath>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace mocap {

float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t exp = (h >> 10) & 0x1fu, man = h & 0x3ffu;
  if (exp == 0) {  // zero or subnormal: man 2^-24
    const float v = std::ldexp(static_cast<float>(man), -24);
    return sign != 0 ? -v : v;
  }
  const std::uint32_t bits =
      exp == 31 ? (sign | 0x7f800000u | (man << 13)) : (sign | ((exp + 112) << 23) | (man << 13));
  return std::bit_cast<float>(bits);
}

std::uint16_t float_to_half(float x, bool up) {
  if (std::isnan(x)) return 0x7e00u;
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const std::uint16_t sign = (bits >> 31) != 0 ? 0x8000u : 0u;
  const float a = std::fabs(x);
  std::uint16_t mag = 0;  // |x| rounded toward zero
  if (std::isinf(a)) {
    mag = 0x7c00u;
  } else if (a >= 65504.0f) {
    mag = 0x7bffu;
  } else if (a < std::ldexp(1.0f, -14)) {
    mag = static_cast<std::uint16_t>(std::ldexp(a, 24));  // subnormal half: truncates
  } else {
    const std::uint32_t ab = bits & 0x7fffffffu;
    const std::uint32_t e = (ab >> 23) - 127 + 15;
    mag = static_cast<std::uint16_t>((e << 10) | ((ab >> 13) & 0x3ffu));
  }
  const auto h = static_cast<std::uint16_t>(sign | mag);
  if (half_to_float(h) == x) return h;
  // |h| < |x|: the other neighbour is one step away from zero.
  const bool away = sign == 0 ? up : !up;
  return away ? static_cast<std::uint16_t>(h + 1) : h;
}

std::uint16_t float_to_half_nearest(float x) {
  if (std::isnan(x)) return 0x7e00u;
  if (x >= 65504.0f) return 0x7bffu;
  if (x <= -65504.0f) return 0xfbffu;
  const std::uint16_t down = float_to_half(x, false), up = float_to_half(x, true);
  return x - half_to_float(down) <= half_to_float(up) - x ? down : up;
}

#if defined(__x86_64__) && defined(__GNUC__)
namespace {
__attribute__((target("avx,f16c"))) void halves_to_floats_f16c(const std::uint16_t* in,
                                                               std::size_t n, float* out) {
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8)
    _mm256_storeu_ps(out + i,
                     _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i))));
  for (; i < n; ++i) out[i] = half_to_float(in[i]);
}
}  // namespace
#endif

void halves_to_floats(const std::uint16_t* in, std::size_t n, float* out) {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool f16c = __builtin_cpu_supports("f16c") && __builtin_cpu_supports("avx");
  if (f16c) {
    halves_to_floats_f16c(in, n, out);
    return;
  }
#endif
  for (std::size_t i = 0; i < n; ++i) out[i] = half_to_float(in[i]);
}

}  // namespace mocap
