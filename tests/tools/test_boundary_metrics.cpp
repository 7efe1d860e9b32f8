#include "dco/tools/boundary_metrics.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr int kWidth = 40, kHeight = 20, kEdge = 20;

// Background (10) left of `edge`, foreground (30) from it on. With the GT's edge at 20 the only
// plane with anything in front of it sits at 20, and its GT boundary is columns 19 and 20.
Image<float> step(int edge = kEdge) {
  Image<float> d(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) d.at(x, y) = x < edge ? 10.0f : 30.0f;
  return d;
}

TEST(BoundaryAccuracy, ExactPredictionIsPerfect) {
  const BoundaryAccuracy b = boundary_accuracy(step().view(), step().view());
  EXPECT_EQ(b.recall, 100.0);
  EXPECT_EQ(b.precision, 100.0);
}

TEST(BoundaryAccuracy, ShiftedEdgeMatchesOnlyWithinTheTolerance) {
  // Predicted boundary columns 21 and 22 against GT columns 19 and 20: distances 1 and 2.
  const Image<float> gt = step(), by2 = step(kEdge + 2);
  EXPECT_EQ(boundary_accuracy(by2.view(), gt.view(), 2).recall, 100.0);
  EXPECT_EQ(boundary_accuracy(by2.view(), gt.view(), 2).precision, 100.0);
  EXPECT_EQ(boundary_accuracy(by2.view(), gt.view(), 1).recall, 50.0);  // column 20 only
  EXPECT_EQ(boundary_accuracy(by2.view(), gt.view(), 1).precision, 50.0);
  EXPECT_EQ(boundary_accuracy(by2.view(), gt.view(), 0).recall, 0.0);
  // Shifted by 3 (columns 22 and 23), no edge pixel is within 1 px of the other map's.
  const Image<float> by3 = step(kEdge + 3);
  EXPECT_EQ(boundary_accuracy(by3.view(), gt.view(), 1).recall, 0.0);
  EXPECT_EQ(boundary_accuracy(by3.view(), gt.view(), 1).precision, 0.0);
  EXPECT_EQ(boundary_accuracy(by3.view(), gt.view(), 3).recall, 100.0);
}

TEST(BoundaryAccuracy, SpuriousEdgeLowersPrecisionOnly) {
  // A 4x4 foreground block far from the true edge: its 12 border pixels and the 16 background
  // pixels around it are predicted boundary pixels without a GT one nearby.
  Image<float> pred = step();
  for (int y = 8; y < 12; ++y)
    for (int x = 4; x < 8; ++x) pred.at(x, y) = 30.0f;
  const BoundaryAccuracy b = boundary_accuracy(pred.view(), step().view());
  EXPECT_EQ(b.recall, 100.0);
  EXPECT_DOUBLE_EQ(b.precision, 100.0 * 40 / (40 + 12 + 16));
}

TEST(BoundaryAccuracy, MissingPredictionIsNeverABoundaryMatch) {
  // A hole along GT column 20: columns 19 and 21 border it, column 20 itself matches nothing.
  Image<float> pred = step();
  for (int y = 0; y < kHeight; ++y) pred.at(kEdge, y) = std::numeric_limits<float>::quiet_NaN();
  const BoundaryAccuracy b = boundary_accuracy(pred.view(), step().view(), 0);
  EXPECT_EQ(b.recall, 50.0);
  EXPECT_EQ(b.precision, 50.0);
}

TEST(BoundaryAccuracy, PixelsWithoutGroundTruthMakeNoBoundary) {
  // GT unknown around the edge: neither map's edge there is counted.
  Image<float> gt = step();
  for (int y = 0; y < kHeight; ++y)
    for (int x = kEdge - 2; x < kEdge + 2; ++x)
      gt.at(x, y) = std::numeric_limits<float>::infinity();
  const BoundaryAccuracy b = boundary_accuracy(step().view(), gt.view());
  EXPECT_TRUE(std::isnan(b.recall));
  EXPECT_TRUE(std::isnan(b.precision));
}

TEST(BoundaryAccuracy, MeanSkipsUndefinedEntries) {
  const std::vector<BoundaryAccuracy> maps = {{100, 50}, {50, kUndefined}, {kUndefined, 100}};
  const BoundaryAccuracy mean = mean_boundary_accuracy(maps);
  EXPECT_EQ(mean.recall, 75.0);
  EXPECT_EQ(mean.precision, 75.0);
  EXPECT_TRUE(std::isnan(mean_boundary_accuracy({}).recall));
}

TEST(GapPlanes, SitInTheWidestEmptyDisparityIntervals) {
  // Surfaces at 10..12 (a slanted wall), 30 and 50: the gaps are (12, 30) and (30, 50).
  Image<float> gt(30, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 30; ++x) gt.at(x, y) = x < 10 ? 10.0f + 0.2f * x : (x < 20 ? 30.0f : 50.0f);
  const std::vector<double> planes = gap_planes(gt.view(), 3);
  ASSERT_EQ(planes.size(), 2u);
  EXPECT_NEAR(planes[0], 21.0, 0.5);
  EXPECT_NEAR(planes[1], 40.0, 0.5);
  EXPECT_EQ(gap_planes(gt.view(), 1).size(), 1u);
  // A wall alone has no gap, so no silhouette plane.
  Image<float> wall(30, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 30; ++x) wall.at(x, y) = 10.0f + 0.2f * x;
  EXPECT_TRUE(gap_planes(wall.view()).empty());
  // A gap is as wide as the values either side of it say, not a count of empty bins: 2.2 px.
  Image<float> step(30, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 30; ++x) step.at(x, y) = x < 15 ? 10.0f : 12.2f;
  const std::vector<double> step_planes = gap_planes(step.view(), 3, 2.0);
  ASSERT_EQ(step_planes.size(), 1u);
  EXPECT_NEAR(step_planes[0], 11.1, 1e-6);
  EXPECT_TRUE(gap_planes(step.view(), 3, 2.3).empty());
}

TEST(BoundaryAccuracy, GapPlanesIgnoreASlantedSurfaceAndSeeTheSilhouette) {
  // A slanted wall with a near block: with the default quantile planes the wall's iso-lines are
  // boundaries, with gap planes only the block's outline is. A prediction with the wall off by
  // half a pixel keeps the silhouette perfect.
  Image<float> gt(60, 40), pred(60, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 60; ++x) {
      const bool block = x >= 20 && x < 40 && y >= 10 && y < 30;
      gt.at(x, y) = block ? 60.0f : 10.0f + 0.1f * x;
      pred.at(x, y) = block ? 60.0f : 10.5f + 0.1f * x;
    }
  const std::vector<double> planes = gap_planes(gt.view());
  const BoundaryAccuracy silhouette = boundary_accuracy(pred.view(), gt.view(), planes, 0);
  EXPECT_DOUBLE_EQ(silhouette.recall, 100.0);
  EXPECT_DOUBLE_EQ(silhouette.precision, 100.0);
  EXPECT_LT(boundary_accuracy(pred.view(), gt.view(), 0).recall, 100.0);
}

TEST(BoundaryAccuracy, RejectsBadInput) {
  const Image<float> gt = step();
  EXPECT_THROW(boundary_accuracy(Image<float>(10, 10).view(), gt.view()), Error);
  EXPECT_THROW(boundary_accuracy(Image<float>(kWidth, kHeight, 3).view(), gt.view()), Error);
  EXPECT_THROW(boundary_accuracy(gt.view(), gt.view(), -1), Error);
}

}  // namespace
}  // namespace dco::tools
