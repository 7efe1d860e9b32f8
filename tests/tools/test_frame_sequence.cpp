#include "dco/tools/frame_sequence.hpp"

#include <chrono>
#include <climits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

using dco::testing::TempDir;
using ::testing::HasSubstr;

std::string pattern_error(const std::string& pattern) {
  try {
    expand_pattern(pattern, 7);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ExpandPattern, OneIntegerField) {
  EXPECT_EQ(expand_pattern("I1_%06d.png", 42), "I1_000042.png");
  EXPECT_EQ(expand_pattern("frames/%d/left.png", 7), "frames/7/left.png");
  EXPECT_EQ(expand_pattern("%3d.png", 5), "  5.png");
  EXPECT_EQ(expand_pattern("%020d", INT_MAX), "00000000002147483647");
}

TEST(ExpandPattern, AnythingElseIsRefused) {
  for (const std::string bad :
       {"left.png", "%06d_%06d.png", "%s.png", "%06d%%.png", "100%.png", "%06x.png", "%-6d.png"})
    EXPECT_THAT(pattern_error(bad), HasSubstr("needs exactly one integer field")) << bad;
}

// A field of two billion digits took seconds to pad into the path buffer.
TEST(ExpandPattern, WideFieldsAreRefusedAtOnce) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(pattern_error("l%02000000000d.png"), HasSubstr("wider than 20 characters"));
  EXPECT_THAT(pattern_error("l%021d.png"), HasSubstr("wider than 20 characters"));
  EXPECT_THAT(pattern_error("l%099999999999999999999d.png"), HasSubstr("wider than 20"));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(500));
}

class PatternSequenceTest : public ::testing::Test {
 protected:
  void write_pair(int index) {
    Image<std::uint8_t> image(16, 12, 1);
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 16; ++x) image.at(x, y) = static_cast<std::uint8_t>(x * 9 + y + index);
    save_image(dir.path() / expand_pattern("l_%04d.png", index), image.cview());
    save_image(dir.path() / expand_pattern("r_%04d.png", index), image.cview());
  }
  std::string left() const { return (dir.path() / "l_%04d.png").string(); }
  std::string right() const { return (dir.path() / "r_%04d.png").string(); }

  TempDir dir;
};

TEST_F(PatternSequenceTest, RunsUntilTheFirstMissingLeftImage) {
  for (int i = 3; i <= 5; ++i) write_pair(i);
  write_pair(7);
  auto sequence = make_pattern_sequence(left(), right(), 3, -1, std::nullopt);
  StereoInput frame;
  std::vector<int> seen;
  while (sequence->next(frame)) {
    seen.push_back(frame.index);
    EXPECT_EQ(frame.left.width(), 16);
    EXPECT_EQ(frame.left.at(1, 0), static_cast<std::uint8_t>(9 + frame.index));
  }
  EXPECT_EQ(seen, (std::vector<int>{3, 4, 5}));
}

TEST_F(PatternSequenceTest, ACountReadsThatManyAndAMissingOneIsAnError) {
  write_pair(0);
  write_pair(1);
  auto two = make_pattern_sequence(left(), right(), 0, 2, std::nullopt);
  StereoInput frame;
  EXPECT_TRUE(two->next(frame));
  EXPECT_TRUE(two->next(frame));
  EXPECT_FALSE(two->next(frame));
  auto three = make_pattern_sequence(left(), right(), 0, 3, std::nullopt);
  EXPECT_TRUE(three->next(frame));
  EXPECT_TRUE(three->next(frame));
  EXPECT_THROW(three->next(frame), Error);
}

// first + count beyond an int, and numbering past the largest int, end the sequence instead of
// overflowing.
TEST_F(PatternSequenceTest, NumbersStopAtTheLargestInt) {
  write_pair(INT_MAX);
  auto sequence = make_pattern_sequence(left(), right(), INT_MAX, INT_MAX, std::nullopt);
  StereoInput frame;
  ASSERT_TRUE(sequence->next(frame));
  EXPECT_EQ(frame.index, INT_MAX);
  EXPECT_FALSE(sequence->next(frame));
  EXPECT_THROW(make_pattern_sequence(left(), right(), -1, 2, std::nullopt), Error);
}

}  // namespace
}  // namespace dco::tools
