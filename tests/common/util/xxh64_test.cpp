// XXH64 against the reference implementation's published vectors (the
// xxhsum sanity check: seeds 0 and 2654435761 over a fixed pseudo-random
// buffer, and well-known strings), and streaming against one-shot hashing.
#include "mocap/common/util/xxh64.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace mocap {
namespace {

constexpr std::uint64_t kPrime32 = 2654435761u;
constexpr std::uint64_t kPrime64 = 11400714785074694797ull;

/// The reference sanity-check buffer: byte i is the top byte of
/// kPrime32 * kPrime64^i (mod 2^64).
std::vector<unsigned char> sanity_buffer(std::size_t bytes) {
  std::vector<unsigned char> out(bytes);
  std::uint64_t gen = kPrime32;
  for (auto& b : out) {
    b = static_cast<unsigned char>(gen >> 56);
    gen *= kPrime64;
  }
  return out;
}

struct Vector {
  std::size_t bytes;
  std::uint64_t seed;
  std::uint64_t expected;
};

TEST(Xxh64, ReferenceVectors) {
  // Lengths 0, 1, 4, 14 exercise the tail only; 222 the four 32-byte lanes.
  const Vector vectors[] = {
      {0, 0, 0xEF46DB3751D8E999ull},          {0, kPrime32, 0xAC75FDA2929B17EFull},
      {1, 0, 0xE934A84ADB052768ull},          {1, kPrime32, 0x5014607643A9B4C3ull},
      {4, 0, 0x9136A0DCA57457EEull},          {14, 0, 0x8282DCC4994E35C8ull},
      {14, kPrime32, 0xC3BD6BF63DEB6DF0ull},  {222, 0, 0xB641AE8CB691C174ull},
      {222, kPrime32, 0x20CB8AB7AE10C14Aull},
  };
  const std::vector<unsigned char> buffer = sanity_buffer(222);
  for (const Vector& v : vectors) {
    EXPECT_EQ(xxh64(v.bytes ? buffer.data() : nullptr, v.bytes, v.seed), v.expected)
        << v.bytes << " bytes, seed " << v.seed;
    // The same bytes one at a time through the streaming state.
    Xxh64 h(v.seed);
    for (std::size_t i = 0; i < v.bytes; ++i) h.update(buffer.data() + i, 1);
    EXPECT_EQ(h.digest(), v.expected) << v.bytes << " bytes one by one, seed " << v.seed;
  }
}

TEST(Xxh64, KnownStrings) {
  // xxhsum -H1 of the strings (seed 0).
  EXPECT_EQ(hex64(xxh64("", 0)), "ef46db3751d8e999");
  EXPECT_EQ(hex64(xxh64("a", 1)), "d24ec4f1a98c6e5b");
  EXPECT_EQ(hex64(xxh64("abc", 3)), "44bc2cf5ad770999");
  const std::string fox = "The quick brown fox jumps over the lazy dog";  // > 32 bytes
  EXPECT_EQ(hex64(xxh64(fox.data(), fox.size())), "0b242d361fda71bc");
}

TEST(Xxh64, StreamingEqualsOneShot) {
  std::string s;
  for (int i = 0; i < 1000; ++i) s += static_cast<char>('a' + (i * 7) % 26);
  const std::uint64_t whole = xxh64(s.data(), s.size());
  for (std::size_t split : {0ul, 1ul, 31ul, 32ul, 33ul, 500ul, 999ul}) {
    Xxh64 h;
    h.update(s.data(), split);
    EXPECT_EQ(h.digest(), xxh64(s.data(), split)) << "digest does not end the stream";
    h.update(s.data() + split, s.size() - split);
    EXPECT_EQ(h.digest(), whole) << "split at " << split;
  }
}

TEST(Xxh64, HexIsSixteenLowercaseDigits) {
  EXPECT_EQ(hex64(0), "0000000000000000");
  EXPECT_EQ(hex64(0xEF46DB3751D8E999ull), "ef46db3751d8e999");
  EXPECT_EQ(hex64(~0ull), "ffffffffffffffff");
}

}  // namespace
}  // namespace mocap
