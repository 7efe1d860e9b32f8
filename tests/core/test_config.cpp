#include "dco/core/config.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

struct Params {
  double lambda_ad = 10;
  int max_disparity = 64;
  bool use_color = false;
  std::string mode = "fast";
  std::string name = "unnamed";
  int threads = 4;
};

class Config : public ::testing::Test {
 protected:
  Config() {
    schema.add("stereo.lambda_ad", &p.lambda_ad, 0.001, 1000, "weight of the absolute difference");
    schema.add("stereo.max_disparity", &p.max_disparity, 1, 256, "largest disparity searched");
    schema.add("stereo.use_color", &p.use_color, "match on colour instead of grey");
    schema.add("stereo.mode", &p.mode, {"fast", "accurate"}, "speed/quality trade-off");
    schema.add("output.name", &p.name, {}, "free text");
    schema.add("threads", &p.threads, 1, 64, "worker threads");
  }

  std::string load_error(const std::string& text) {
    try {
      schema.load_string(text, "dcod.toml");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }

  std::string set_error(const std::string& assignment) {
    try {
      schema.set(assignment);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }

  Params p;
  ConfigSchema schema;
};

TEST_F(Config, LoadsNestedTablesAndDottedKeys) {
  schema.load_string(R"(threads = 8
[stereo]
lambda_ad = 12       # an integer is fine for a double
use_color = true
mode = "accurate"
[output]
name = "left cam"
)",
                     "dcod.toml");
  EXPECT_EQ(p.threads, 8);
  EXPECT_EQ(p.lambda_ad, 12.0);
  EXPECT_TRUE(p.use_color);
  EXPECT_EQ(p.mode, "accurate");
  EXPECT_EQ(p.name, "left cam");
  EXPECT_EQ(p.max_disparity, 64);  // untouched

  schema.load_string("stereo.max_disparity = 128\nstereo.lambda_ad = 0.5\n", "inline");
  EXPECT_EQ(p.max_disparity, 128);
  EXPECT_EQ(p.lambda_ad, 0.5);
}

TEST_F(Config, UnknownKeyNamesFileAndLine) {
  EXPECT_EQ(load_error("threads = 2\n\n[stereo]\nlamda_ad = 3\n"),
            "dcod.toml:4: unknown key 'stereo.lamda_ad'");
  EXPECT_EQ(load_error("[stereo]\n[sterio]\nmode = \"fast\"\n"),
            "dcod.toml:2: unknown section 'sterio'");
  EXPECT_EQ(load_error("[extra]\n"), "dcod.toml:1: unknown section 'extra'");
  EXPECT_EQ(p.threads, 4);  // nothing applied from a rejected file
}

// A quoted "stereo.max_disparity" and max_disparity in [stereo] are two TOML keys for one
// parameter: in either order the file is refused, rather than one of them winning silently.
TEST_F(Config, AQuotedDottedKeyBesideItsTableIsSetTwice) {
  EXPECT_EQ(load_error("\"stereo.max_disparity\" = 10\n[stereo]\nmax_disparity = 20\n"),
            "dcod.toml:1: stereo.max_disparity is set twice (a quoted \"stereo.max_disparity\" "
            "names the same key)");
  EXPECT_NE(load_error("stereo.max_disparity = 20\n\"stereo.max_disparity\" = 30\n")
                .find("stereo.max_disparity is set twice"),
            std::string::npos);
  EXPECT_EQ(p.max_disparity, 64);
  EXPECT_EQ(load_error("\"stereo.max_disparity\" = 10\n"), "");  // alone, it is that key
  EXPECT_EQ(p.max_disparity, 10);
}

TEST_F(Config, TypeErrors) {
  EXPECT_NE(load_error("[stereo]\nmax_disparity = 3.5\n")
                .find("dcod.toml:2: stereo.max_disparity: expects an integer"),
            std::string::npos);
  EXPECT_NE(load_error("[stereo]\nuse_color = \"yes\"\n")
                .find("dcod.toml:2: stereo.use_color: expects true or false"),
            std::string::npos);
  EXPECT_NE(load_error("[stereo]\nlambda_ad = \"10\"\n").find("expects a number"),
            std::string::npos);
  EXPECT_NE(load_error("[stereo]\nmode = 3\n").find("expects a string"), std::string::npos);
  EXPECT_NE(load_error("[stereo]\nlambda_ad = [1, 2]\n")
                .find("dcod.toml:2: stereo.lambda_ad: unsupported"),
            std::string::npos);
  EXPECT_NE(load_error("[stereo.lambda_ad]\nx = 1\n").find("stereo.lambda_ad"), std::string::npos);
  EXPECT_NE(load_error("[stereo]\nlambda_ad = \n").find("dcod.toml:2:"),
            std::string::npos);  // syntax
  EXPECT_EQ(p.lambda_ad, 10.0);
  // A NUL in a string would end the message where it stands; control characters show as '?'.
  EXPECT_EQ(load_error("[stereo]\nmode = \"fast\\u0000junk\"\n"),
            "dcod.toml:2: stereo.mode: \"fast?junk\" is not one of fast, accurate");
  EXPECT_EQ(load_error("threads = \"\\u001b[2J\"\n"),
            "dcod.toml:1: threads: expects an integer, got \"?[2J\"");
}

TEST_F(Config, RangesAreInclusive) {
  EXPECT_EQ(load_error("[stereo]\nlambda_ad = 0.001\nmax_disparity = 256\n"), "");
  EXPECT_EQ(p.lambda_ad, 0.001);
  EXPECT_EQ(p.max_disparity, 256);
  EXPECT_EQ(load_error("[stereo]\nlambda_ad = 1000\nmax_disparity = 1\n"), "");
  EXPECT_EQ(load_error("[stereo]\nlambda_ad = -1\n"),
            "dcod.toml:2: stereo.lambda_ad: value -1 is outside [0.001, 1000]");
  EXPECT_EQ(load_error("[stereo]\nmax_disparity = 257\n"),
            "dcod.toml:2: stereo.max_disparity: value 257 is outside [1, 256]");
  EXPECT_NE(load_error("[stereo]\nlambda_ad = nan\n").find("outside"), std::string::npos);
  EXPECT_NE(load_error("[stereo]\nmode = \"slow\"\n").find("\"slow\" is not one of fast, accurate"),
            std::string::npos);
}

// -0 is stored as 0: no parameter means anything by the sign of zero (a rate of -0 Hz would make
// a period of -inf), and the printed configuration reads back as written.
TEST(ConfigZero, NegativeZeroIsStoredAsZero) {
  double hz = 1;
  ConfigSchema schema;
  schema.add("lcm.preview_hz", &hz, 0.0, 30.0, "rate");
  schema.set("lcm.preview_hz=-0");
  EXPECT_EQ(hz, 0.0);
  EXPECT_FALSE(std::signbit(hz));
  hz = 1;
  schema.load_string("[lcm]\npreview_hz = -0.0\n", "dcod.toml");
  EXPECT_FALSE(std::signbit(hz));
  EXPECT_NE(schema.to_toml().find("preview_hz = 0\n"), std::string::npos) << schema.to_toml();
}

TEST_F(Config, BadFileIsAppliedAllOrNothing) {
  EXPECT_NE(load_error("threads = 16\n[stereo]\nlambda_ad = 5000\n"), "");
  EXPECT_EQ(p.threads, 4);
}

TEST_F(Config, SetOverrides) {
  schema.set("stereo.lambda_ad=12.5");
  schema.set("stereo.use_color=true");
  schema.set("stereo.mode=accurate");
  schema.set("stereo.max_disparity = 128");
  schema.set("output.name=\"a b\"");
  EXPECT_EQ(p.lambda_ad, 12.5);
  EXPECT_TRUE(p.use_color);
  EXPECT_EQ(p.mode, "accurate");
  EXPECT_EQ(p.max_disparity, 128);
  EXPECT_EQ(p.name, "a b");
  schema.set("stereo.use_color=false");
  EXPECT_FALSE(p.use_color);

  EXPECT_EQ(set_error("stereo.lambda_ad=-1"),
            "--set stereo.lambda_ad=-1: value -1 is outside [0.001, 1000]");
  EXPECT_EQ(set_error("stereo.lamda_ad=1"),
            "--set stereo.lamda_ad=1: unknown key 'stereo.lamda_ad'");
  EXPECT_NE(set_error("stereo.lambda_ad").find("expected key=value"), std::string::npos);
  EXPECT_NE(set_error("stereo.lambda_ad=abc").find("not a number"), std::string::npos);
  EXPECT_NE(set_error("stereo.lambda_ad=inf").find("not a number"), std::string::npos);
  EXPECT_NE(set_error("stereo.max_disparity=12x").find("not an integer"), std::string::npos);
  EXPECT_NE(set_error("stereo.max_disparity=1.5").find("not an integer"), std::string::npos);
  EXPECT_NE(set_error("stereo.use_color=yes").find("not true or false"), std::string::npos);
  EXPECT_NE(set_error("stereo.mode=slow").find("not one of"), std::string::npos);
  EXPECT_EQ(p.lambda_ad, 12.5);

  // As a TOML file reads them: a leading '+', and integers too large for any type are out of
  // range rather than "not an integer".
  schema.set("stereo.lambda_ad=+7.5");
  EXPECT_EQ(p.lambda_ad, 7.5);
  schema.set("stereo.max_disparity=+64");
  EXPECT_EQ(p.max_disparity, 64);
  EXPECT_NE(set_error("stereo.max_disparity=+-64").find("not an integer"), std::string::npos);
  EXPECT_NE(set_error("stereo.max_disparity=+").find("not an integer"), std::string::npos);
  EXPECT_EQ(set_error("stereo.max_disparity=99999999999999999999"),
            "--set stereo.max_disparity=99999999999999999999: value 99999999999999999999 is "
            "outside [1, 256]");
  EXPECT_NE(set_error("stereo.lambda_ad=1e999").find("beyond what a double holds"),
            std::string::npos);
}

TEST_F(Config, LoadFile) {
  test::TempDir dir;
  test::write_file(dir / "dcod.toml", "[stereo]\nmax_disparity = 96\n\nbogus = 1\n");
  try {
    schema.load_file(dir / "dcod.toml");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "dcod.toml").string() + ":4: unknown key 'stereo.bogus'");
  }
  test::write_file(dir / "dcod.toml", "[stereo]\nmax_disparity = 96\n");
  schema.load_file(dir / "dcod.toml");
  EXPECT_EQ(p.max_disparity, 96);
  EXPECT_THROW(schema.load_file(dir / "missing.toml"), Error);
}

// What to_toml writes (dcod --print-config) reads back to the same strings: control characters
// are escaped, and a --set cannot bring bytes that no TOML file could hold.
TEST_F(Config, StringsReadBackFromTheirToml) {
  const std::string awkward = "tab\there\nline \"quoted\" back\\slash \x7f \x01 caf\xc3\xa9";
  p.name = awkward;
  const std::string toml = schema.to_toml();
  p.name = "changed";
  schema.load_string(toml, "printed.toml");
  EXPECT_EQ(p.name, awkward);

  EXPECT_EQ(set_error("output.name=caf\xe9"),
            "--set output.name=caf\xe9: the string is not valid UTF-8");
  EXPECT_EQ(p.name, awkward);
}

TEST_F(Config, HasAndDescribe) {
  EXPECT_TRUE(schema.has("stereo.mode"));
  EXPECT_FALSE(schema.has("stereo"));
  EXPECT_FALSE(schema.has("mode"));

  p.lambda_ad = 2.5;
  const std::string text = schema.describe();
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0].rfind("stereo.lambda_ad", 0), 0u);
  EXPECT_NE(lines[0].find("2.5"), std::string::npos);  // current value, not the default
  EXPECT_NE(lines[0].find("[0.001, 1000]"), std::string::npos);
  EXPECT_NE(lines[1].find("[1, 256]"), std::string::npos);
  EXPECT_NE(lines[2].find("true|false"), std::string::npos);
  EXPECT_NE(lines[3].find("fast|accurate"), std::string::npos);
  EXPECT_NE(lines[3].find("\"fast\""), std::string::npos);
  EXPECT_NE(lines[4].find("any string"), std::string::npos);
  // Aligned: every doc string starts in the same column.
  const std::string docs[] = {"weight of", "largest", "match on", "speed/", "free text", "worker"};
  const auto column = lines[0].find(docs[0]);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(lines[i].find(docs[i]), column) << lines[i];
}

}  // namespace
}  // namespace dco
