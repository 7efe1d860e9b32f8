#pragma once

#include <span>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/tools/metrics.hpp"

// Where a prediction puts the occlusion edges of virtual objects, compared with the ground truth.
// occErr/bandErr (metrics.hpp) count wrong sides; these numbers ask whether each GT edge has a
// predicted edge nearby (recall) and whether each predicted edge has a GT edge nearby (precision),
// so a blurred or displaced edge and a spurious one are told apart.
//
// For each virtual plane of occlusion_planes(gt), over pairs of 4-neighbours that both have GT:
//   - a GT boundary pixel is one whose GT side differs from its neighbour's;
//   - a predicted boundary pixel is one with a prediction whose predicted side differs from its
//     neighbour's, where "no prediction" is a side of its own. A pixel without a prediction is
//     never a boundary pixel itself, so a hole at a true edge cannot match it, while the edges a
//     hole makes around itself do count.
// A boundary pixel matches when the other map has a boundary pixel within Chebyshev distance
// `tolerance`. Planes without a GT boundary pixel are skipped (as for bandErr); each number is the
// mean over the remaining planes where it is defined (precision needs a predicted boundary pixel).
namespace dco::tools {

inline constexpr int kBoundaryTolerance = 2;

struct BoundaryAccuracy {
  double recall = kUndefined;     // % of GT boundary pixels matched by a predicted one
  double precision = kUndefined;  // % of predicted boundary pixels matched by a GT one
};

// Throws dco::Error when the maps differ in size, are not single-channel or tolerance < 0.
BoundaryAccuracy boundary_accuracy(ImageView<const float> prediction, ImageView<const float> gt,
                                   int tolerance = kBoundaryTolerance);

// The same for caller-chosen plane disparities.
BoundaryAccuracy boundary_accuracy(ImageView<const float> prediction, ImageView<const float> gt,
                                   std::span<const double> planes,
                                   int tolerance = kBoundaryTolerance);

// Planes in the empty space between the scene's surfaces: the centres of the `count` widest
// disparity intervals (at least `min_gap` px wide, inside the GT's range) that no GT pixel falls
// in. A virtual object placed there is cut only by object silhouettes, never by a surface it
// intersects, so boundary accuracy against these planes measures the silhouettes alone.
std::vector<double> gap_planes(ImageView<const float> gt, int count = 3, double min_gap = 2.0);

// Mean of each number over maps (e.g. the frames of a sequence), skipping undefined entries.
BoundaryAccuracy mean_boundary_accuracy(std::span<const BoundaryAccuracy> maps);

}  // namespace dco::tools
