// Text from outside as messages quote it: no control character reaches a log line or a terminal.

#include "dco/core/printable.hpp"

#include <gtest/gtest.h>

namespace dco {
namespace {

TEST(Printable, ControlCharactersBecomeQuestionMarks) {
  EXPECT_EQ(printable("a\nb\tc\x1b[2Jd\x7f"), "a?b?c?[2Jd?");
  // C1 controls in UTF-8 (CSI is U+009B): both bytes become one mark.
  EXPECT_EQ(printable("x\xc2\x9b"
                      "31mred\xc2\x85y"),
            "x?31mred?y");
  // Other UTF-8 stays as it is, the C2 lead byte of a printable character included.
  EXPECT_EQ(printable("caf\xc3\xa9 \xc2\xa9 \xe2\x82\xac"), "caf\xc3\xa9 \xc2\xa9 \xe2\x82\xac");
  EXPECT_EQ(printable("end\xc2"), "end\xc2");
  EXPECT_EQ(printable(""), "");
}

}  // namespace
}  // namespace dco
