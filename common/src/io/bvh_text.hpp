#pragma once
// BVH text (internal to the BVH reader, writer and export layout): byte
// classes, bytes quoted for messages, the number parser, and the clip checks
// before writing.
#include <cstdint>
#include <string>
#include <string_view>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap::detail {

// Blanks inside a line. '\r' counts as one so that CRLF files need no special case.
inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}
inline bool is_space(char c) {
  return is_blank(c) || c == '\n';
}
// The first byte at or after p that is not a blank (end when there is none).
inline const char* after_blanks(const char* p, const char* end) {
  while (p < end && is_blank(*p)) ++p;
  return p;
}
// Bytes that never occur in a text file: control characters other than blanks, DEL.
inline bool is_binary(char c) {
  const auto u = static_cast<unsigned char>(c);
  return (u < 0x20 && !is_space(c)) || u == 0x7f;
}

/// `s` in single quotes for an error message: at most 40 bytes ("..." after
/// them), binary bytes as \xNN.
std::string show(std::string_view s);

/// std::from_chars for what parse_double's fast path does not take ('+'
/// skipped here); nullptr when [p, end) does not start with a number.
[[gnu::noinline]] const char* parse_double_slow(const char* p, const char* end, double& out);

// Parses one number at p (a leading '+' is allowed; from_chars does not take it).
// Returns the end of the number, or nullptr when there is none.
//
// Fast path (Clinger): a decimal "[+-]digits[.digits][e[+-]digits]" whose
// digits form an integer m <= 2^53 and whose value is m * 10^s with |s| <= 22
// is one IEEE multiplication or division of two exact doubles, which is
// correctly rounded, so the result equals from_chars'. Everything else (long
// mantissas, big exponents, inf/nan, garbage) goes to std::from_chars. The fast
// path took set 2 from ~230 to ~300 MB/s: libstdc++'s from_chars was 40% of
// the parse time.
[[gnu::always_inline]] inline const char* parse_double(const char* p, const char* end,
                                                       double& out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                      1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* q = p;
  bool negative = false;
  if (q < end && (*q == '+' || *q == '-')) {
    negative = *q == '-';
    ++q;
  }
  std::uint64_t m = 0;
  int digits = 0;
  while (q < end && static_cast<unsigned char>(*q - '0') < 10 && digits < 18) {
    m = m * 10 + static_cast<std::uint64_t>(*q - '0');
    ++digits;
    ++q;
  }
  int fraction = 0;
  if (q < end && *q == '.') {
    ++q;
    while (q < end && static_cast<unsigned char>(*q - '0') < 10 && digits < 18) {
      m = m * 10 + static_cast<std::uint64_t>(*q - '0');
      ++digits;
      ++fraction;
      ++q;
    }
  }
  int exponent = 0;
  if (q < end && (*q == 'e' || *q == 'E') && digits > 0) {
    const char* e = q + 1;
    bool exp_negative = false;
    if (e < end && (*e == '+' || *e == '-')) {
      exp_negative = *e == '-';
      ++e;
    }
    int exp_digits = 0;
    while (e < end && static_cast<unsigned char>(*e - '0') < 10 && exp_digits < 4) {
      exponent = exponent * 10 + (*e - '0');
      ++exp_digits;
      ++e;
    }
    if (exp_digits == 0 || exp_digits == 4) {
      digits = 0;  // malformed or huge exponent: slow path decides
    } else {
      if (exp_negative) exponent = -exponent;
      q = e;
    }
  }
  const bool more =
      q < end && (static_cast<unsigned char>(*q - '0') < 10 || *q == '.' || *q == 'e' ||
                  *q == 'E' || *q == 'n' || *q == 'N' || *q == 'i' || *q == 'I');
  const int scale = exponent - fraction;  // value = m * 10^scale
  if (digits > 0 && !more && m <= (std::uint64_t{1} << 53) && scale >= -22 && scale <= 22) {
    const double v = scale < 0 ? static_cast<double>(m) / kPow10[-scale]
                               : static_cast<double>(m) * kPow10[scale];
    out = negative ? -v : v;
    return q;
  }
  return parse_double_slow(p, end, out);
}

/// Checks the invariants the writer relies on (a hand-built clip may break
/// them). Its shape is the calling code's, so a broken one (no joint, a
/// parent after its child, channels past the frame row or more than 6 on a
/// joint, values not frame_count x channel_count) throws std::invalid_argument;
/// what it holds may come from input, so a joint name BVH cannot hold or a
/// frame time that is not positive and finite throws
/// InputError(clip.source, 0, ...).
void check_clip(const RawClip& clip);

}  // namespace mocap::detail
