#include "mocap/common/util/memory.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace mocap {
namespace {

// Small and large (beyond one 2 MiB page) vectors: the values, the size, and
// nothing left of what the vector held before.
TEST(Memory, AssignHugeGivesNCopies) {
  for (const std::size_t n : {std::size_t{0}, std::size_t{5}, std::size_t{3} << 20}) {
    std::vector<float> v(1000, -1.0f);
    assign_huge(v, n, 2.5f);
    ASSERT_EQ(v.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(v[i], 2.5f) << n << " " << i;
  }
  std::vector<std::uint16_t> h;
  assign_huge(h, std::size_t{5} << 20, std::uint16_t{7});
  ASSERT_EQ(h.size(), std::size_t{5} << 20);
  EXPECT_EQ(h.front(), 7u);
  EXPECT_EQ(h.back(), 7u);
  // Shrinking reallocates too and keeps only the new values.
  assign_huge(h, 3, std::uint16_t{1});
  EXPECT_EQ(h, std::vector<std::uint16_t>(3, 1));
}

// Advice only: ranges without a whole huge page, a null pointer and a range
// over memory already written leave the memory as it was.
TEST(Memory, AdviseHugePagesKeepsContents) {
  std::vector<int> v(std::size_t{3} << 20);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<int>(i);
  advise_huge_pages(nullptr, 1 << 22);
  advise_huge_pages(v.data(), 100);
  advise_huge_pages(v.data() + 1, v.size() * sizeof(int) - 8);
  for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(v[i], static_cast<int>(i));
}

}  // namespace
}  // namespace mocap
