// libcamera:// without a camera: the URI is checked before any camera is touched, and a machine
// without cameras gets one clear line. The pairing of two cameras' frames is tested on its own
// with made-up timestamps; capture itself needs a camera.

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "../../drivers/libcamera/frame_pairer.hpp"
#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/drivers/frame_source.hpp"
#include "support/temp_dir.hpp"

namespace dco::drivers {
namespace {

class LibcameraSource : public ::testing::Test {
 protected:
  void SetUp() override {
    // A build without libcamera turns every libcamera:// away before reading the URI.
    try {
      open_source("libcamera://probe?layout=sbs");
    } catch (const Error& e) {
      if (std::string(e.what()).find("not supported by this build") != std::string::npos)
        GTEST_SKIP() << "built without libcamera";
    }
    StereoCalibration c;
    c.left = {CameraModel::kPinhole, 640, 480, 500, 500, 319.5, 239.5, {}};
    c.right = c.left;
    c.translation = {-0.064, 0, 0};
    calib_ = dir_ / "rig.toml";
    save_calibration(calib_, c);
  }

  // The message open_source throws for `uri`, or "" when it opens.
  static std::string error_of(const std::string& uri) {
    try {
      open_source(uri);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }

  std::string with_calib(const std::string& uri) const {
    return uri + (uri.find('?') == std::string::npos ? "?" : "&") + "calib=" + calib_.string();
  }

  dco::testing::TempDir dir_;
  std::filesystem::path calib_;
};

using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST_F(LibcameraSource, NoCameraIsOneClearLine) {
  // Twice: the process-wide camera manager must be made again after the first one went away.
  for (int i = 0; i < 2; ++i) {
    const std::string message = error_of(with_calib("libcamera://cam0,cam1"));
    if (message.rfind("libcamera: no camera '", 0) == 0)
      GTEST_SKIP() << "this machine has cameras: " << message;
    EXPECT_THAT(message, StartsWith("libcamera: no camera found"));
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
}

TEST_F(LibcameraSource, SideBySideWithoutCameraIsOneClearLine) {
  const std::string message = error_of(with_calib("libcamera://cam0?layout=sbs&fps=30"));
  if (message.rfind("libcamera: no camera '", 0) == 0)
    GTEST_SKIP() << "this machine has cameras: " << message;
  EXPECT_THAT(message, StartsWith("libcamera: no camera found"));
}

TEST_F(LibcameraSource, UnknownParameterIsNamed) {
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?exposure=3")),
              HasSubstr("unknown parameter 'exposure'"));
}

TEST_F(LibcameraSource, LayoutMustFitTheIds) {
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?layout=sbs")),
              HasSubstr("layout=sbs takes exactly one camera id, got 2"));
  EXPECT_THAT(error_of(with_calib("libcamera://a?layout=pair")),
              HasSubstr("layout=pair needs two camera ids"));
  EXPECT_THAT(error_of(with_calib("libcamera://a")), HasSubstr("needs layout=sbs"));
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?layout=tb")),
              HasSubstr("layout=tb must be pair or sbs"));
}

TEST_F(LibcameraSource, IdsMustBeOneOrTwoDistinctNames) {
  for (const char* uri : {"libcamera://", "libcamera://a,", "libcamera://,b", "libcamera://a,b,c"})
    EXPECT_THAT(error_of(with_calib(uri)), HasSubstr("expected libcamera://LEFT_ID,RIGHT_ID"))
        << uri;
  EXPECT_THAT(error_of(with_calib("libcamera://a,a")),
              HasSubstr("left and right are the same camera 'a'"));
}

TEST_F(LibcameraSource, CalibrationIsRequired) {
  EXPECT_THAT(error_of("libcamera://a,b"), HasSubstr("calib=FILE is required"));
  EXPECT_THAT(error_of("libcamera://a,b?calib="), HasSubstr("calib=FILE is required"));
  const std::string missing = (dir_ / "none.toml").string();
  EXPECT_THAT(error_of("libcamera://a,b?calib=" + missing), HasSubstr(missing + ": no such file"));
  const std::string bad = dir_.write("bad.toml", "this is not a calibration\n").string();
  EXPECT_THAT(error_of("libcamera://a,b?calib=" + bad), HasSubstr(bad));
}

TEST_F(LibcameraSource, SizeMustMatchTheCalibration) {
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?width=320&height=240")),
              HasSubstr("frames of 320x240 per eye, but the calibration is for 640x480"));
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?height=400")),
              HasSubstr("frames of 640x400 per eye"));
  EXPECT_THAT(error_of(with_calib("libcamera://a?layout=sbs&width=320")),
              HasSubstr("frames of 320x480 per eye"));
}

TEST_F(LibcameraSource, BadNumbersAreNamed) {
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?width=wide")),
              HasSubstr("width=wide must be an integer"));
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?width=4")),
              HasSubstr("width=4 must be an integer in [16, 8192]"));
  EXPECT_THAT(error_of(with_calib("libcamera://a,b?fps=-1")), HasSubstr("fps=-1 must be a number"));
}

// Pairer tests: handles are frame numbers, left from 0 and right from 1000.
using Pairer = FramePairer<int>;
constexpr std::int64_t kPeriod = 33'333'333;  // 30 fps
// Frame i's time; a camera's clock is well past 0, which means "no timestamp".
constexpr std::int64_t at(int i) {
  return 5'000'000'000 + i * kPeriod;
}

struct Released {
  std::vector<int> handles;
  void operator()(int h) { handles.push_back(h); }
};

TEST(LibcameraFramePairer, SameRateCamerasPairEveryFrame) {
  Pairer pairer;
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  for (int i = 0; i < 50; ++i) {
    const std::int64_t t = at(i);
    EXPECT_FALSE(pairer.add(0, {i, t}, release));
    ASSERT_TRUE(pairer.add(1, {1000 + i, t + 12'000'000}, release)) << i;
    const auto pair = pairer.take();
    ASSERT_TRUE(pair);
    EXPECT_EQ((*pair)[0].handle, i);
    EXPECT_EQ((*pair)[1].handle, 1000 + i);
  }
  EXPECT_TRUE(released.handles.empty());
  EXPECT_EQ(pairer.counters().pairs, 50u);
  EXPECT_EQ(pairer.counters().unpaired, 0u);
}

TEST(LibcameraFramePairer, PairsTheClosestFrameAndDropsTheOneWithout) {
  // Right lags by 20 ms, more than half a period: right i belongs with left i + 1.
  Pairer pairer;
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < 10; ++i) {
    pairer.add(0, {i, at(i)}, release);
    pairer.add(1, {1000 + i, at(i) + 20'000'000}, release);
    if (const auto p = pairer.take()) pairs.emplace_back((*p)[0].handle, (*p)[1].handle);
  }
  ASSERT_EQ(pairs.size(), 9u);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(pairs[k].first, static_cast<int>(k) + 1);
    EXPECT_EQ(pairs[k].second, 1000 + static_cast<int>(k));
  }
  EXPECT_EQ(released.handles, std::vector<int>{0});
  EXPECT_EQ(pairer.counters().unpaired, 1u);
}

TEST(LibcameraFramePairer, NewestPairWinsAndTheOvertakenGoBack) {
  Pairer pairer;
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  for (int i = 0; i < 4; ++i) {  // nobody takes
    pairer.add(0, {i, at(i)}, release);
    pairer.add(1, {1000 + i, at(i) + 1'000'000}, release);
  }
  EXPECT_EQ(released.handles, (std::vector<int>{0, 1000, 1, 1001, 2, 1002}));
  EXPECT_EQ(pairer.counters().overtaken, 3u);
  const auto pair = pairer.take();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].handle, 3);
  EXPECT_FALSE(pairer.take());
}

TEST(LibcameraFramePairer, HalfRatePartnerLeavesEveryOtherFrameUnpaired) {
  Pairer pairer;
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  int pairs = 0;
  for (int i = 0; i < 20; ++i) {
    pairer.add(0, {i, at(i)}, release);
    if (i % 2 == 0) pairer.add(1, {1000 + i, at(i) + 2'000'000}, release);
    pairs += pairer.take().has_value();
  }
  EXPECT_EQ(pairs, 10);
  // Left 1, 3, ... 17 went back once the next right frame showed they had no partner.
  EXPECT_EQ(pairer.counters().unpaired, 9u);
  for (int h : released.handles) EXPECT_EQ(h % 2, 1) << h;
}

TEST(LibcameraFramePairer, StalledPartnerHoldsAtMostMaxPendingFrames) {
  Pairer pairer(2);
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  for (int i = 0; i < 10; ++i) pairer.add(0, {i, at(i)}, release);
  EXPECT_EQ(released.handles, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(pairer.unpaired_run(), 8);
  EXPECT_FALSE(pairer.take());
  // The partner comes back: the newest held frame pairs and the run ends.
  EXPECT_TRUE(pairer.add(1, {1000, at(9) + 3'000'000}, release));
  EXPECT_EQ(pairer.unpaired_run(), 0);
  EXPECT_EQ((*pairer.take())[0].handle, 9);
}

TEST(LibcameraFramePairer, UnknownPeriodIsMeasuredPerSensorFrame) {
  Pairer pairer;
  Released released;
  auto release = [&](int h) { released(h); };
  pairer.measure(10, 1'000'000'000);
  EXPECT_EQ(pairer.period(), 0);
  EXPECT_FALSE(pairer.add(0, {0, 1'000'000'000}, release));
  EXPECT_FALSE(pairer.add(1, {1000, 1'000'000'000 + 5'000'000}, release));  // held: no tolerance
  // The sensor dropped two frames (sequence 11 and 12): the gap spans three periods.
  pairer.measure(13, 1'000'000'000 + 3 * kPeriod);
  EXPECT_NEAR(static_cast<double>(pairer.period()), static_cast<double>(kPeriod), 1.0);
  EXPECT_TRUE(pairer.add(0, {1, 1'000'000'000 + 3 * kPeriod}, release));
  EXPECT_EQ((*pairer.take())[0].handle, 0);
  // A fixed period is not overridden by measurements.
  pairer.set_period(2 * kPeriod);
  pairer.measure(14, 1'000'000'000 + 4 * kPeriod);
  EXPECT_EQ(pairer.period(), 2 * kPeriod);
}

// A camera whose driver stamps nothing: its frames cannot be told apart in time, so none is
// paired (pairing by arrival could match frames a period apart for good); each goes back and is
// counted, for the source to say so.
TEST(LibcameraFramePairer, FramesWithoutATimeAreReleasedAndCounted) {
  Pairer pairer;
  pairer.set_period(kPeriod);
  Released released;
  auto release = [&](int h) { released(h); };
  for (int i = 0; i < 4; ++i) {
    EXPECT_FALSE(pairer.add(0, {i, 0}, release));
    EXPECT_FALSE(pairer.add(1, {1000 + i, 0}, release));
  }
  EXPECT_EQ(released.handles, (std::vector<int>{0, 1000, 1, 1001, 2, 1002, 3, 1003}));
  EXPECT_EQ(pairer.counters().untimed, 8u);
  EXPECT_EQ(pairer.counters().pairs, 0u);
  EXPECT_FALSE(pairer.has_pair());
}

TEST(LibcameraFramePairer, SingleCameraNewestWins) {
  Pairer pairer;
  Released released;
  auto release = [&](int h) { released(h); };
  for (int i = 1; i <= 3; ++i) pairer.add_single({i, at(i)}, release);
  EXPECT_EQ(released.handles, (std::vector<int>{1, 2}));
  EXPECT_EQ(pairer.counters().overtaken, 2u);
  EXPECT_EQ((*pairer.take())[0].handle, 3);
}

TEST(LibcameraFramePairer, EveryFrameIsPairedOrReleasedExactlyOnce) {
  // Jittered cameras with a slow, irregular consumer: no handle leaks or goes back twice, and
  // every pair lies within half a period.
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::int64_t> jitter(-2'000'000, 2'000'000);
  std::uniform_int_distribution<int> coin(0, 3);
  Pairer pairer;
  pairer.set_period(kPeriod);
  std::vector<int> seen;
  auto release = [&](int h) { seen.push_back(h); };
  int next[2] = {0, 0};
  const std::int64_t offset = 9'000'000;
  while (next[0] < 300 || next[1] < 300) {
    // Whichever camera's next frame is due first arrives first, as on one callback thread.
    const std::int64_t t0 = next[0] * kPeriod + jitter(rng);
    const std::int64_t t1 = next[1] * kPeriod + offset + jitter(rng);
    const int eye = next[1] >= 300 || (next[0] < 300 && t0 <= t1) ? 0 : 1;
    pairer.add(eye, {eye * 1000 + next[eye], eye == 0 ? t0 : t1}, release);
    ++next[eye];
    if (coin(rng) == 0) {
      if (const auto p = pairer.take()) {
        EXPECT_LE(std::abs((*p)[0].ns - (*p)[1].ns), kPeriod / 2);
        seen.push_back((*p)[0].handle);
        seen.push_back((*p)[1].handle);
      }
    }
  }
  if (const auto p = pairer.take()) {
    seen.push_back((*p)[0].handle);
    seen.push_back((*p)[1].handle);
  }
  const auto& c = pairer.counters();
  EXPECT_GT(c.pairs, 250u);
  EXPECT_GT(c.overtaken, 0u);
  std::sort(seen.begin(), seen.end());
  EXPECT_TRUE(std::adjacent_find(seen.begin(), seen.end()) == seen.end());
  // Frames still waiting for a partner at the end are the only ones unaccounted for.
  EXPECT_GE(seen.size(), 600u - 2 * 2);
}

}  // namespace
}  // namespace dco::drivers
