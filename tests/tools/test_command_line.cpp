#include "dco/tools/command_line.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace dco::tools {
namespace {

using ::testing::HasSubstr;

TEST(ParseImageSize, ReadsWidthAndHeight) {
  const ImageSize size = parse_image_size("--size", "1280x720");
  EXPECT_EQ(size.width, 1280);
  EXPECT_EQ(size.height, 720);
}

TEST(ParseImageSize, RefusesMalformedAndTooSmallSizes) {
  for (const char* bad : {"", "1280", "1280x", "x720", "1280x720x3", "12a0x720", "1280 x720"}) {
    try {
      parse_image_size("--size", bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const UsageError& e) {
      EXPECT_THAT(e.what(), HasSubstr("--size needs WIDTHxHEIGHT")) << bad;
    }
  }
  try {
    parse_image_size("--size", "32x720", 64);
    ADD_FAILURE() << "accepted a width below the minimum";
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("at least 64x64"));
  }
  try {
    parse_image_size("--size", "8193x16", 16, 8192);
    ADD_FAILURE() << "accepted a width above the maximum";
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--size must be at most 8192x8192, not 8193x16"));
  }
  EXPECT_EQ(parse_image_size("--size", "8192x16", 16, 8192).width, 8192);
}

TEST(OneLine, KeepsAMessageOnOneLineWithoutEscapes) {
  EXPECT_EQ(one_line("cannot read 'a\nb.png'\n"), "cannot read 'a b.png'");
  EXPECT_EQ(one_line("x\r\ty\x1b[2J\x7f"), "x  y?[2J?");
  EXPECT_EQ(one_line("plain"), "plain");
}

}  // namespace
}  // namespace dco::tools
