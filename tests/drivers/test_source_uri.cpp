#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/source_uri.hpp"

namespace dco::drivers {
namespace {

std::string error_of(std::string_view uri) {
  try {
    open_source(uri);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(SourceUri, SplitsSchemePathAndTypedParameters) {
  SourceUri uri("replay:///data/clip?fps=12.5&loop=1&frames=3");
  EXPECT_EQ(uri.scheme(), "replay");
  EXPECT_EQ(uri.path(), "/data/clip");
  EXPECT_DOUBLE_EQ(uri.number("fps", 30, 0, 100), 12.5);
  EXPECT_TRUE(uri.flag("loop", false));
  EXPECT_EQ(uri.integer("frames", 0, 0, 10), 3);
  EXPECT_EQ(uri.integer("absent", 7, 0, 10), 7);
  EXPECT_NO_THROW(uri.finish());
}

TEST(SourceUri, RejectsMalformedAndUnreadParameters) {
  EXPECT_THROW(SourceUri("no-scheme"), Error);
  EXPECT_THROW(SourceUri("://x"), Error);
  EXPECT_THROW(SourceUri("synthetic://hand?fps"), Error);
  EXPECT_THROW(SourceUri("synthetic://hand?fps=1&fps=2"), Error);
  SourceUri out_of_range("synthetic://hand?fps=5000");
  EXPECT_THROW(out_of_range.number("fps", 30, 0, 1000), Error);
  SourceUri not_a_number("synthetic://hand?width=wide");
  EXPECT_THROW(not_a_number.integer("width", 640, 32, 8192), Error);
  SourceUri unread("synthetic://hand?widht=3");
  EXPECT_THROW(unread.finish(), Error);
}

TEST(OpenSource, NamesTheProblemAndNeverFallsBack) {
  EXPECT_NE(error_of("synthetic://hand?widht=320").find("unknown parameter 'widht'"),
            std::string::npos);
  EXPECT_NE(error_of("synthetic://teapot").find("teapot"), std::string::npos);
  // No module is attached here: a clear error, never another source.
  const std::string no_camera = error_of("indemind://");
  EXPECT_TRUE(no_camera.find("no INDEMIND module") != std::string::npos ||
              no_camera.find("USB unavailable") != std::string::npos)
      << no_camera;
  EXPECT_NE(error_of("indemind://?fps=60").find("fps"), std::string::npos);
  EXPECT_NE(error_of("indemind://?imu_hz=300").find("imu_hz must divide 1000"), std::string::npos);
  EXPECT_NE(error_of("lcmlog:///nonexistent/x.log").find("cannot open the LCM log"),
            std::string::npos);
  EXPECT_NE(error_of("lcmlog://?fps=0").find("no LCM log file named"), std::string::npos)
      << error_of("lcmlog://?fps=0");
  EXPECT_NE(error_of("lcmlog:///tmp?fps=0").find("/tmp: not an LCM log file"), std::string::npos)
      << error_of("lcmlog:///tmp?fps=0");
  EXPECT_NE(error_of("webcam://0").find("unknown scheme 'webcam'"), std::string::npos);
  EXPECT_NE(error_of("replay:///nonexistent/dir").find("no such directory"), std::string::npos);
}

// Checked before any USB: the URI alone says what is wrong with it.
TEST(OpenSource, IndemindSizeAndImuRateAreCheckedFromTheUri) {
  auto no_module = [](const std::string& e) {
    return e.find("no INDEMIND module") != std::string::npos ||
           e.find("USB unavailable") != std::string::npos;
  };
  // A width or height alone takes the other from its mode.
  EXPECT_TRUE(no_module(error_of("indemind://?width=1280"))) << error_of("indemind://?width=1280");
  EXPECT_TRUE(no_module(error_of("indemind://?height=800&fps=100")))
      << error_of("indemind://?height=800&fps=100");
  EXPECT_NE(error_of("indemind://?width=1000").find("no mode 1000 wide"), std::string::npos)
      << error_of("indemind://?width=1000");
  // The IMU's rate divider holds 255 at most: 4 Hz is the slowest rate.
  for (const char* uri : {"indemind://?imu_hz=1", "indemind://?imu_hz=2"})
    EXPECT_NE(error_of(uri).find("imu_hz must divide 1000 and be at least 4"), std::string::npos)
        << error_of(uri);
  EXPECT_TRUE(no_module(error_of("indemind://?imu_hz=4"))) << error_of("indemind://?imu_hz=4");
  EXPECT_TRUE(no_module(error_of("indemind://?imu_hz=0"))) << error_of("indemind://?imu_hz=0");
}

}  // namespace
}  // namespace dco::drivers
