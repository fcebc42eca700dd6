// Tests for common/src/util/frame_range.cpp: "S-E" accepted as written and
// everything else refused with what was expected.
#include "mocap/common/util/frame_range.hpp"

#include <gtest/gtest.h>

#include <string>

#include "test_support.hpp"

namespace mocap {
namespace {

TEST(FrameRangeTest, RefusesWhatIsNotSE) {
  for (const char* bad : {"", "5", "-", "a-b", "5-", "-5", "1-2-3", " 1-2", "1-2 ", "+1-2", "1--2",
                          "99999999999999999999999-1"}) {
    const std::string e =
        test::input_error_message([&] { (void)parse_frame_range(bad, "--frames"); });
    EXPECT_NE(e.find("--frames: expected S-E"), std::string::npos) << bad << ": " << e;
  }
  const std::string e =
      test::input_error_message([] { (void)parse_frame_range("40-10", "--frames"); });
  EXPECT_NE(e.find("first frame 40 is after last frame 10"), std::string::npos) << e;
  const FrameRange one = parse_frame_range("7-7", "--frames");
  EXPECT_EQ(one.first, 7u);
  EXPECT_EQ(one.last, 7u);
  const FrameRange r = parse_frame_range("10-40", "--frames");
  EXPECT_EQ(r.first, 10u);
  EXPECT_EQ(r.last, 40u);
}

}  // namespace
}  // namespace mocap
