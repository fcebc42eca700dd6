// Edit distances between names (mocap/common/util/edit_distance.hpp).
#include "mocap/common/util/edit_distance.hpp"

#include <gtest/gtest.h>

namespace mocap {
namespace {

TEST(EditDistance, EmptyAndEqualStrings) {
  EXPECT_EQ(edit_distance("", ""), 0u);
  EXPECT_EQ(edit_distance("", "top"), 3u);
  EXPECT_EQ(edit_distance("top", ""), 3u);
  EXPECT_EQ(edit_distance("relative", "relative"), 0u);
}

TEST(EditDistance, CountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(edit_distance("relatve", "relative"), 1u);  // an insertion
  EXPECT_EQ(edit_distance("tops", "top"), 1u);          // a deletion
  EXPECT_EQ(edit_distance("tap", "top"), 1u);           // a substitution
  EXPECT_EQ(edit_distance("styel", "style"), 2u);       // a swap is two
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("Top", "top"), 1u);  // case counts
}

TEST(EditDistance, LowerCaseFoldsAsciiLettersOnly) {
  EXPECT_EQ(ascii_lower("Top_Frame-2"), "top_frame-2");
  EXPECT_EQ(ascii_lower(""), "");
  EXPECT_EQ(ascii_lower("\xc3\x89t\xc3\xa9"), "\xc3\x89t\xc3\xa9");  // UTF-8 bytes kept
  EXPECT_EQ(edit_distance(ascii_lower("Top"), ascii_lower("top")), 0u);
}

TEST(ClosestName, NearestWithinTheLimitAnyCase) {
  const std::vector<std::string> names = {"LeftFoot", "LeftToe", "RightFoot", "Hips"};
  EXPECT_EQ(closest_name("", {}), "");
  EXPECT_EQ(closest_name("LeftFooot", names), "LeftFoot");
  EXPECT_EQ(closest_name("leftfoot", names), "LeftFoot");  // case only: distance 0
  EXPECT_EQ(closest_name("Tail", names), "");
  EXPECT_EQ(closest_name("Hipsss", names, 1), "");
  EXPECT_EQ(closest_name("Hipsss", names, 2), "Hips");
  EXPECT_EQ(closest_name("LeftFoo", {"LeftFoot", "LeftFoo1"}), "LeftFoot");  // first of equals
}

}  // namespace
}  // namespace mocap
