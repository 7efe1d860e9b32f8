#include "dco/tools/json.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

namespace dco::tools {
namespace {

TEST(Json, StringsAreQuotedAndEscaped) {
  EXPECT_EQ(json_string("middlebury2014/Motorcycle"), "\"middlebury2014/Motorcycle\"");
  EXPECT_EQ(json_string("a\"b\\c"), R"("a\"b\\c")");
  EXPECT_EQ(json_string("tab\tnew\nline\r"), R"("tab\tnew\nline\r")");
  EXPECT_EQ(json_string(std::string("\x01\x1f", 2)), R"("\u0001\u001f")");
  EXPECT_EQ(json_string("caf\xc3\xa9"), "\"caf\xc3\xa9\"");  // UTF-8 passes through
  // Bytes that are no UTF-8 (Latin-1, a cut sequence, an overlong form, a surrogate) become
  // U+FFFD: the document stays valid JSON.
  EXPECT_EQ(json_string("caf\xe9"), R"("caf\ufffd")");
  EXPECT_EQ(json_string("\xff\xfe"), R"("\ufffd\ufffd")");
  EXPECT_EQ(json_string("cut\xe2\x82"), R"("cut\ufffd\ufffd")");
  EXPECT_EQ(json_string("\xc0\xaf"), R"("\ufffd\ufffd")");
  EXPECT_EQ(json_string("\xed\xa0\x80"), R"("\ufffd\ufffd\ufffd")");
  EXPECT_EQ(json_string("\xf0\x9f\x98\x80"), "\"\xf0\x9f\x98\x80\"");  // U+1F600
  EXPECT_EQ(json_string(""), "\"\"");
}

TEST(Json, NumbersRoundTripAndNonFiniteIsNull) {
  EXPECT_EQ(json_number(0.0), "0");
  EXPECT_EQ(json_number(100.0), "100");
  EXPECT_EQ(json_number(12.5), "12.5");
  EXPECT_EQ(std::stod(json_number(100.0 / 7)), 100.0 / 7);
  EXPECT_EQ(json_number(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(json_number(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(json_number(-std::numeric_limits<double>::infinity()), "null");
}

}  // namespace
}  // namespace dco::tools
