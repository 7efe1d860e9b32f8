#include "dco/tools/temporal_metrics.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// 10x10, column x holds disparity x + 1: the planes fall at 2.5, 4.5, 5.5, 7.5 and 8.5.
Image<float> columns() {
  Image<float> d(10, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) d.at(x, y) = static_cast<float>(x + 1);
  return d;
}

TEST(FlickerMeter, IdenticalFramesDoNotFlicker) {
  FlickerMeter meter;
  const Image<float> frame = columns();
  meter.add(frame.view());
  EXPECT_TRUE(std::isnan(meter.flip_rate()));  // nothing to compare yet
  meter.add(frame.view());
  EXPECT_EQ(meter.frames(), 2);
  EXPECT_EQ(meter.flip_rate(), 0.0);
  EXPECT_THAT(meter.planes(), ElementsAre(2.5, 4.5, 5.5, 7.5, 8.5));
}

TEST(FlickerMeter, RegionMovingAcrossPlanesFlipsExactlyItsPixels) {
  FlickerMeter meter;
  Image<float> frame = columns();
  meter.add(frame.view());
  // 10 pixels of disparity 1 move to 5: in front of planes 2.5 and 4.5 now, still behind 5.5.
  for (int y = 0; y < 10; ++y) frame.at(0, y) = 5.0f;
  meter.add(frame.view());
  EXPECT_DOUBLE_EQ(meter.flip_rate(), 100.0 * (10 * 2) / (100 * 5));
}

// A first frame with no valid disparity gives no planes, so no side and no flip rate.
TEST(FlickerMeter, NoPlanesNoFlipRate) {
  FlickerMeter meter;
  Image<float> empty(10, 10);
  empty.fill(std::numeric_limits<float>::infinity());
  meter.add(empty.view());
  meter.add(columns().view());
  EXPECT_TRUE(std::isnan(meter.planes()[0]));
  EXPECT_TRUE(std::isnan(meter.flip_rate()));
}

TEST(FlickerMeter, HolesCountAsFlipsWhenTheyComeOrGo) {
  FlickerMeter meter;
  Image<float> frame = columns();
  meter.add(frame.view());
  frame.at(3, 3) = std::numeric_limits<float>::quiet_NaN();
  frame.at(4, 4) = std::numeric_limits<float>::infinity();
  frame.at(5, 5) = 0.0f;
  frame.at(6, 6) = -2.0f;
  meter.add(frame.view());
  EXPECT_DOUBLE_EQ(meter.flip_rate(), 100.0 * (4 * 5) / (100 * 5));
  // The same holes again: they have no side to change, and are not compared.
  meter.add(frame.view());
  EXPECT_DOUBLE_EQ(meter.flip_rate(), 100.0 * (4 * 5) / (100 * 5 + 96 * 5));
  frame.at(3, 3) = 1.0f;  // one hole filled: a flip again
  meter.add(frame.view());
  EXPECT_DOUBLE_EQ(meter.flip_rate(), 100.0 * (4 * 5 + 5) / (100 * 5 + 96 * 5 + 97 * 5));
}

// A ground truth with fixed gaps, frame after frame, does not flicker.
TEST(FlickerMeter, FixedGapsDoNotFlicker) {
  FlickerMeter meter;
  Image<float> frame = columns();
  for (int y = 0; y < frame.height(); ++y) frame.at(0, y) = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i) meter.add(frame.view());
  EXPECT_DOUBLE_EQ(meter.flip_rate(), 0.0);
}

TEST(FlickerMeter, FixedPlanesOverrideTheFirstFrame) {
  // Everything moves from 1..10 to 11..20: across all of the first frame's planes, across none
  // of the planes fixed above both.
  Image<float> near = columns();
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) near.at(x, y) += 10.0f;
  FlickerMeter own;
  FlickerMeter fixed({30, 31, 32, 33, 34});
  for (FlickerMeter* meter : {&own, &fixed}) {
    meter->add(columns().view());
    meter->add(near.view());
  }
  EXPECT_THAT(fixed.planes(), ElementsAre(30, 31, 32, 33, 34));
  EXPECT_EQ(fixed.flip_rate(), 0.0);
  // Per plane, the columns behind it flip: 2, 4, 5, 7 and 8 of 10.
  EXPECT_DOUBLE_EQ(own.flip_rate(), 100.0 * (2 + 4 + 5 + 7 + 8) / 50);
}

TEST(FlickerMeter, RejectsASizeChangeAndNonMaps) {
  FlickerMeter meter;
  meter.add(columns().view());
  Image<float> small(5, 5);
  small.fill(1.0f);
  try {
    meter.add(small.view());
    FAIL() << "a smaller frame was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("frame 1 is 5x5, the first frame 10x10"));
  }
  EXPECT_THROW(meter.add(Image<float>(10, 10, 3).view()), Error);
  EXPECT_THROW(meter.add(ImageView<const float>{}), Error);
}

}  // namespace
}  // namespace dco::tools
