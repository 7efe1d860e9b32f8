// Disparity to metric depth: Z = f B / (d + doffs), +inf where a disparity says nothing.

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "dco/core/calibration.hpp"
#include "dco/core/depth_conversion.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"

namespace dco {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

RectifiedGeometry geometry() {
  RectifiedGeometry g;
  g.width = 4;
  g.height = 1;
  g.f = 500;
  g.baseline_m = 0.1;
  g.cx_left = 100;
  g.cx_right = 102;  // doffs 2
  return g;
}

TEST(DisparityToDepth, FollowsTheGeometryAndMarksUnknownAsInfinity) {
  Image<float> d(4, 1), z(4, 1);
  const float values[] = {23.0f, -2.0f, std::nanf(""), kInf};
  for (int x = 0; x < 4; ++x) d.at(x, 0) = values[x];
  disparity_to_depth(d.cview(), geometry(), z.view());
  EXPECT_FLOAT_EQ(z.at(0, 0), 2.0f);  // 500 * 0.1 / (23 + 2)
  EXPECT_EQ(z.at(1, 0), kInf);        // at or beyond infinity
  EXPECT_EQ(z.at(2, 0), kInf);
  EXPECT_EQ(z.at(3, 0), kInf);
  EXPECT_EQ(geometry().depth_from_disparity(std::nan("")), std::numeric_limits<double>::infinity());
  // +inf marks a hole in a sparse map: unknown, not a point at the camera.
  EXPECT_EQ(geometry().depth_from_disparity(std::numeric_limits<double>::infinity()),
            std::numeric_limits<double>::infinity());
}

TEST(DisparityToDepth, RefusesMismatchedImagesAndAnEmptyGeometry) {
  Image<float> d(4, 1), z(4, 1), small(3, 1);
  d.fill(10.0f);
  EXPECT_THROW(disparity_to_depth(d.cview(), geometry(), small.view()), Error);
  // A geometry never filled in would give depth 0 everywhere: nearer than anything.
  EXPECT_THROW(disparity_to_depth(d.cview(), RectifiedGeometry{}, z.view()), Error);
  RectifiedGeometry no_baseline = geometry();
  no_baseline.baseline_m = std::nan("");
  EXPECT_THROW(disparity_to_depth(d.cview(), no_baseline, z.view()), Error);
}

}  // namespace
}  // namespace dco
