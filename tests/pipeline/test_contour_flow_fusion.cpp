#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/pipeline/contour/flow_fusion.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"

namespace dco::contour {
namespace {

constexpr int kW = 32, kH = 12;
constexpr int kObjBegin = 10, kObjEnd = 20;  // object columns [10, 20) move, the rest is still

// A flow field where the object columns move by (u, 0) and the background does not.
Image<float> object_flow(float u) {
  Image<float> f(kW, kH, 2);
  f.fill(0.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = kObjBegin; x < kObjEnd; ++x) f.at(x, y, 0) = u;
  return f;
}

TEST(ContourFlowFusion, AmplitudeIsTheLargerSpeedChangeToTheRightOrBelow) {
  Image<float> f(kW, kH, 2), speed(kW, kH), m(kW, kH);
  f.fill(0.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = 10; x < kW; ++x) {
      f.at(x, y, 0) = 3.0f;  // speed 5 from column 10 on
      f.at(x, y, 1) = 4.0f;
    }
  for (int x = 0; x < kW; ++x) f.at(x, 6, 0) = f.at(x, 6, 0) + 1.0f;  // row 6 a bit faster
  flow_amplitude(f.view(), speed.view(), m.view());
  EXPECT_FLOAT_EQ(speed.at(12, 2), 5.0f);
  EXPECT_FLOAT_EQ(m.at(9, 2), 5.0f);  // |r(10) - r(9)|
  EXPECT_FLOAT_EQ(m.at(10, 2), 0.0f);
  EXPECT_FLOAT_EQ(m.at(3, 5), 1.0f);  // |r(3, 6) - r(3, 5)| = 1 - 0
  EXPECT_FLOAT_EQ(m.at(3, 6), 1.0f);  // |r(3, 7) - r(3, 6)|
  EXPECT_NEAR(m.at(20, 5), std::hypot(4.0f, 4.0f) - 5.0f, 1e-5f);
}

TEST(ContourFlowFusion, AmplitudeTreatsTheBorderAsNoChange) {
  Image<float> f(kW, kH, 2), speed(kW, kH), m(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      f.at(x, y, 0) = 2.0f;
      f.at(x, y, 1) = -1.0f;
    }
  flow_amplitude(f.view(), speed.view(), m.view());
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) EXPECT_EQ(m.at(x, y), 0.0f) << x << "," << y;
}

// Fig. 5: the object moves right in the future field (+3) and came from the left in the past one
// (flow -3). Near the object's left edge the future field is the reliable one (that background
// stays visible), near its right edge the past field is.
TEST(ContourFlowFusion, ProjectionContrastSignsFollowFigure5) {
  const Image<float> future = object_flow(3.0f);
  const Image<float> past = object_flow(-3.0f);
  Image<float> cf(kW, kH), cp(kW, kH);
  projection_contrast(future.view(), 2.0f, cf.view());
  projection_contrast(past.view(), 2.0f, cp.view());
  for (const int y : {0, 5, kH - 1}) {
    EXPECT_FLOAT_EQ(cf.at(kObjBegin, y), 3.0f);  // ahead of p still object, behind it background
    EXPECT_FLOAT_EQ(cp.at(kObjBegin, y), -3.0f);
    EXPECT_FLOAT_EQ(cf.at(kObjEnd - 1, y), -3.0f);
    EXPECT_FLOAT_EQ(cp.at(kObjEnd - 1, y), 3.0f);
    EXPECT_FLOAT_EQ(cf.at(15, y), 0.0f);  // deep inside: same flow ahead and behind
    EXPECT_FLOAT_EQ(cf.at(3, y), 0.0f);   // background: no direction
  }
}

TEST(ContourFlowFusion, ProjectionSamplesBilinearlyAndClampsAtTheBorder) {
  Image<float> f(8, 4, 2), c(8, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) {
      f.at(x, y, 0) = 1.0f + 0.5f * static_cast<float>(x);  // u grows linearly along x
      f.at(x, y, 1) = 0.0f;
    }
  projection_contrast(f.view(), 1.5f, c.view());
  EXPECT_NEAR(c.at(3, 1), 0.5f * 3.0f, 1e-5f);           // u(4.5) - u(1.5), interpolated
  EXPECT_NEAR(c.at(0, 1), 0.5f * 1.5f, 1e-5f);           // p0 clamped to x = 0
  EXPECT_NEAR(c.at(7, 1), 0.5f * (7.0f - 5.5f), 1e-5f);  // p1 clamped to x = 7
}

TEST(ContourFlowFusion, FusionTakesTheAmplitudeOfTheLargerContrast) {
  Image<float> ma(3, 1), ca(3, 1), mb(3, 1), cb(3, 1), out(3, 1);
  const float a_m[3] = {1, 2, 3}, a_c[3] = {5, -1, 0}, b_m[3] = {10, 20, 30}, b_c[3] = {4, 0, 0};
  for (int x = 0; x < 3; ++x) {
    ma.at(x, 0) = a_m[x];
    ca.at(x, 0) = a_c[x];
    mb.at(x, 0) = b_m[x];
    cb.at(x, 0) = b_c[x];
  }
  fuse_amplitudes(ma.view(), ca.view(), mb.view(), cb.view(), out.view());
  EXPECT_EQ(out.at(0, 0), 1.0f);   // r_a > r_b
  EXPECT_EQ(out.at(1, 0), 20.0f);  // r_b > r_a
  EXPECT_EQ(out.at(2, 0), 30.0f);  // tie: b
}

TEST(ContourFlowFusion, InvertedFlowSendsEveryPixelBackWhereItCameFrom) {
  // The object [10, 20) moves 3 px right: in the neighbour it covers [13, 23), which flows back by
  // -3 (the object wins over the still background it lands on), and the background it uncovered,
  // [10, 13), takes the still side of its run rather than the object's motion.
  const Image<float> forward = object_flow(3.0f);
  Image<float> backward(kW, kH, 2);
  FlowInversionScratch scratch;
  backward.fill(std::numeric_limits<float>::quiet_NaN());  // every pixel must be written
  invert_flow(forward.view(), scratch, backward.view());
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool object = x >= kObjBegin + 3 && x < kObjEnd + 3;
      EXPECT_EQ(backward.at(x, y, 0), object ? -3.0f : 0.0f) << x << "," << y;
      EXPECT_EQ(backward.at(x, y, 1), 0.0f) << x << "," << y;
    }
  // Moving left, the uncovered run [17, 20) lies right of the object: the still side again.
  invert_flow(object_flow(-3.0f).view(), scratch, backward.view());
  for (int x = 0; x < kW; ++x)
    EXPECT_EQ(backward.at(x, 4, 0), x >= kObjBegin - 3 && x < kObjEnd - 3 ? 3.0f : 0.0f) << x;
}

TEST(ContourFlowFusion, InvertedFlowRoundsSubPixelMotionAndFillsWhatNothingReaches) {
  Image<float> forward(kW, kH, 2), backward(kW, kH, 2);
  FlowInversionScratch scratch;
  forward.fill(0.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      forward.at(x, y, 0) = 2.4f;  // everything 2.4 px right and 0.6 down: lands 2 right, 1 down
      forward.at(x, y, 1) = 0.6f;
    }
  backward.fill(std::numeric_limits<float>::quiet_NaN());
  invert_flow(forward.view(), scratch, backward.view());
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      // The first row and the first two columns receive nothing: the row's run takes its right
      // end, and the first row, with nothing at all, is still.
      const bool empty_row = y == 0;
      EXPECT_EQ(backward.at(x, y, 0), empty_row ? 0.0f : -2.4f) << x << "," << y;
      EXPECT_EQ(backward.at(x, y, 1), empty_row ? 0.0f : -0.6f) << x << "," << y;
    }
  // Flows that are not numbers land nowhere.
  forward.fill(std::numeric_limits<float>::quiet_NaN());
  invert_flow(forward.view(), scratch, backward.view());
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) ASSERT_EQ(backward.at(x, y, 0), 0.0f);
}

// A pixel follows the near field, then the onward field where it lands: the object's pixels
// (3 px right) meet the onward field's object (2 px right, where the object went), the still
// pixels the onward field where they are.
TEST(ContourFlowFusion, ComposedFlowFollowsBothFieldsOneAfterTheOther) {
  const Image<float> near = object_flow(3.0f);
  Image<float> onward(kW, kH, 2), composed(kW, kH, 2);
  onward.fill(0.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = kObjBegin + 3; x < kObjEnd + 3; ++x) onward.at(x, y, 0) = 2.0f;
  compose_flow(near.cview(), onward.cview(), composed.view());
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool object = x >= kObjBegin && x < kObjEnd;
      const bool under_onward_object = x >= kObjBegin + 3 && x < kObjEnd + 3;
      EXPECT_EQ(composed.at(x, y, 0), object                ? 5.0f
                                      : under_onward_object ? 2.0f
                                                            : 0.0f)
          << x << "," << y;
      EXPECT_EQ(composed.at(x, y, 1), 0.0f) << x << "," << y;
    }
}

TEST(ContourFlowFusion, ComposedFlowSamplesBilinearlyAndTakesTheBorderPastTheEdge) {
  Image<float> near(kW, kH, 2), onward(kW, kH, 2), composed(kW, kH, 2);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      onward.at(x, y, 0) = static_cast<float>(x);  // a ramp in each direction
      onward.at(x, y, 1) = static_cast<float>(10 * y);
    }
  near.fill(0.0f);
  near.at(4, 2, 0) = 0.25f;  // lands at (4.25, 2.5)
  near.at(4, 2, 1) = 0.5f;
  near.at(1, 1, 0) = -5.0f;  // past the left and top edges: the corner's value
  near.at(1, 1, 1) = -5.0f;
  near.at(kW - 2, kH - 2, 0) = 9.0f;  // past the right and bottom edges
  near.at(kW - 2, kH - 2, 1) = 9.0f;
  near.at(6, 3, 0) = std::numeric_limits<float>::quiet_NaN();  // no number: the column 0
  compose_flow(near.cview(), onward.cview(), composed.view());
  EXPECT_FLOAT_EQ(composed.at(4, 2, 0), 0.25f + 4.25f);
  EXPECT_FLOAT_EQ(composed.at(4, 2, 1), 0.5f + 25.0f);
  EXPECT_FLOAT_EQ(composed.at(1, 1, 0), -5.0f + 0.0f);
  EXPECT_FLOAT_EQ(composed.at(1, 1, 1), -5.0f + 0.0f);
  EXPECT_FLOAT_EQ(composed.at(kW - 2, kH - 2, 0), 9.0f + static_cast<float>(kW - 1));
  EXPECT_FLOAT_EQ(composed.at(kW - 2, kH - 2, 1), 9.0f + static_cast<float>(10 * (kH - 1)));
  EXPECT_FLOAT_EQ(composed.at(6, 3, 1), 30.0f);
  EXPECT_FLOAT_EQ(composed.at(0, 0, 0), 0.0f);  // a still pixel takes the onward field's own
  EXPECT_FLOAT_EQ(composed.at(7, 3, 0), 7.0f);
}

TEST(ContourFlowFusion, NormaliseDividesByTheMaximumOrTheFloor) {
  Image<float> v(3, 1);
  v.at(0, 0) = 0;
  v.at(1, 0) = 2;
  v.at(2, 0) = 4;
  EXPECT_FLOAT_EQ(normalise_by_max(v.view(), 1.0f), 4.0f);
  EXPECT_FLOAT_EQ(v.at(1, 0), 0.5f);
  EXPECT_FLOAT_EQ(v.at(2, 0), 1.0f);
  v.at(1, 0) = 2;
  v.at(2, 0) = 4;
  EXPECT_FLOAT_EQ(normalise_by_max(v.view(), 8.0f), 8.0f);  // small motion stays small
  EXPECT_FLOAT_EQ(v.at(2, 0), 0.5f);
  Image<float> zero(4, 4);
  zero.fill(0.0f);
  EXPECT_EQ(normalise_by_max(zero.view(), 0.0f), 0.0f);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(zero.at(x, y), 0.0f);
  // A subnormal largest value (no motion) with floor 0: its reciprocal is infinite, and 0 times
  // that NaN; the values stay as they are instead.
  Image<float> still(2, 1);
  still.at(0, 0) = 0.0f;
  still.at(1, 0) = 1e-39f;
  EXPECT_EQ(normalise_by_max(still.view(), 0.0f), 0.0f);
  EXPECT_EQ(still.at(0, 0), 0.0f);
  EXPECT_EQ(still.at(1, 0), 1e-39f);
}

TEST(ContourStereoCue, MarksBothSidesOfADisparityStep) {
  Image<float> d(20, 6), s(20, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 20; ++x) d.at(x, y) = x < 12 ? 10.0f : 11.0f + 0.25f * (x - 12);
  disparity_jump_strength(d.view(), 2.0f, s.view());
  EXPECT_FLOAT_EQ(s.at(11, 3), 0.5f);  // jump of 1 px against a full-strength 2 px
  EXPECT_FLOAT_EQ(s.at(12, 3), 0.5f);
  EXPECT_FLOAT_EQ(s.at(5, 3), 0.0f);     // flat
  EXPECT_FLOAT_EQ(s.at(15, 3), 0.125f);  // slanted: 0.25 px per px
  d.at(5, 3) = 30.0f;
  disparity_jump_strength(d.view(), 2.0f, s.view());
  EXPECT_FLOAT_EQ(s.at(5, 3), 1.0f);  // capped
  EXPECT_FLOAT_EQ(s.at(5, 2), 1.0f);
}

TEST(ContourStereoCue, IgnoresMissingDisparities) {
  Image<float> d(5, 5), s(5, 5);
  d.fill(4.0f);
  d.at(2, 2) = std::numeric_limits<float>::infinity();
  d.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
  disparity_jump_strength(d.view(), 1.0f, s.view());
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) EXPECT_EQ(s.at(x, y), 0.0f) << x << "," << y;
}

}  // namespace
}  // namespace dco::contour
