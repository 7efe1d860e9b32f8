#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/tools/scene_manifest.hpp"

// Accuracy of a predicted disparity map against ground truth, with the occlusion-oriented numbers
// a mixed-reality compositor cares about (is a real pixel in front of or behind a virtual object?).
//
// Conventions
//   - A GT pixel is one whose GT disparity is finite and > 0. A prediction exists where the
//     predicted disparity is finite and > 0 (+inf, NaN, 0 and negatives mean "no prediction").
//   - "all" numbers run over every GT pixel; a missing prediction counts as bad for every bad-N
//     and as |err| = GT disparity for avgerr (as if the method had predicted 0, i.e. infinity).
//   - "pred" numbers run over the GT pixels that have a prediction only.
//   - "nocc" numbers run over GT pixels whose nocc mask is 255 (only when the scene has a mask).
//   - Occlusion: virtual fronto-parallel planes are placed at the 20/35/50/65/80 % quantiles of the
//     GT disparities (nearest rank). Each plane sits halfway between the quantile value and the
//     next larger distinct GT disparity (the next smaller one when the quantile is the largest), so
//     no GT pixel lies exactly on it: with integer GT (e.g. Tsukuba) a whole surface would
//     otherwise be a coin flip. Only a GT of one value has its planes on it. A pixel is in front
//     of a plane when its disparity is larger than the plane's.
//       occErr   % of GT pixels whose predicted side is wrong (missing prediction = wrong),
//       bandErr  the same over GT pixels within Chebyshev distance 3 (a 7x7 dilation) of the GT
//                occlusion boundary, i.e. GT pixels whose side differs from a 4-neighbour's;
//       bandFront / bandBehind  the part of bandErr predicted in front of the plane where the
//                truth is behind it (real surfaces fattened: a halo that hides virtual content
//                around real objects) and behind where the truth is in front (virtual content
//                showing through the rims of real objects); the rest of bandErr is missing
//                predictions;
//       bandEdge / bandSurface  bandErr split by where the band pixel is: within 3 px of a GT
//                depth edge (4-neighbours whose GT disparities differ by more than 1.5 px, an
//                object outline) or not (the plane crosses a smooth, slanted surface, where a
//                sub-pixel disparity error moves the crossing by pixels); they add up to bandErr;
//       the "pred" variants count predicted pixels only. Each is the mean over the planes where
//       it is defined (a plane with nothing in front of it has no boundary and no band).
//   - Matches: when the sparse map the prediction was densified from comes with it, the GT
//     pixels that map left empty are "filled" (fill%), and bad-N runs separately over the matched
//     and the filled ones (bad2M, bad2F): whether the error comes from the matcher or the fill;
//     bandErr splits the same way (bandM, bandF: they add up to bandErr).
//   - Rates are percentages. A number over zero pixels is NaN ("not defined"); means over scenes
//     skip NaN entries.
namespace dco::tools {

inline constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();
inline constexpr std::array<double, 5> kOcclusionPlaneQuantiles = {0.20, 0.35, 0.50, 0.65, 0.80};
inline constexpr int kOcclusionBandRadius = 3;
inline constexpr float kDepthEdgeJump = 1.5f;  // px of GT disparity between 4-neighbours

struct ErrorStats {
  std::int64_t pixels = 0;   // pixels these numbers are over
  double bad1 = kUndefined;  // % with |err| > 1 px
  double bad2 = kUndefined;
  double bad4 = kUndefined;
  double avgerr = kUndefined;  // mean |err| in px
};

struct SceneMetrics {
  std::string scene;
  int width = 0, height = 0;          // 0 in a mean
  std::int64_t gt_pixels = 0;         // summed in a mean
  std::int64_t predicted_pixels = 0;  // GT pixels with a prediction
  double density = kUndefined;        // % of GT pixels with a prediction

  ErrorStats all;   // every GT pixel
  ErrorStats pred;  // predicted GT pixels only
  bool has_nocc = false;
  ErrorStats nocc;       // mask == 255
  ErrorStats nocc_pred;  // mask == 255 and predicted

  std::array<double, kOcclusionPlaneQuantiles.size()> planes{};  // plane disparities; NaN in a mean
  double occ_err = kUndefined;
  double occ_err_pred = kUndefined;
  double band_err = kUndefined;
  double band_err_pred = kUndefined;
  double band_front = kUndefined;    // of bandErr: predicted in front, truly behind
  double band_behind = kUndefined;   // of bandErr: predicted behind, truly in front
  double band_edge = kUndefined;     // of bandErr: near a GT depth edge
  double band_surface = kUndefined;  // of bandErr: elsewhere (planes crossing smooth surfaces)

  bool has_matches = false;          // the sparse map was given
  double filled = kUndefined;        // % of GT pixels the sparse map left empty
  ErrorStats matched, filled_err;    // of the prediction, over GT pixels with / without a match
  double band_matched = kUndefined;  // of bandErr: where the sparse map has a value
  double band_filled = kUndefined;   // of bandErr: where it has none (the rest)

  double time_ms = kUndefined;  // filled by whoever timed the method; NaN when unknown
};

// True for a usable disparity (finite and > 0), for predictions and decoded GT alike.
inline bool is_valid_disparity(float d) {
  return d > 0 && d < std::numeric_limits<float>::infinity();
}

// The virtual planes' disparities for a GT map (see above); NaN when the map has no GT pixel.
std::array<double, kOcclusionPlaneQuantiles.size()> occlusion_planes(ImageView<const float> gt);

// Scores one prediction; `matches`, when not empty, is the sparse map it was filled in from (same
// size; a value where the matcher kept one). Throws dco::Error when a size differs from the GT's
// or a map is not single-channel.
SceneMetrics evaluate_disparity(std::string scene, ImageView<const float> prediction,
                                const GroundTruth& gt, ImageView<const float> matches = {});

// Unweighted mean over scenes of every number (each scene counts the same, whatever its size);
// pixel counts are summed. The result's scene is "mean". The mean time is NaN unless every scene
// has a time, so that two methods' times always cover the same scenes.
SceneMetrics mean_metrics(std::span<const SceneMetrics> scenes);

// Fixed-width table: a header, one row per scene, a "mean" row and a one-line legend.
std::string format_metrics_table(std::span<const SceneMetrics> scenes);

// {"scenes": [...], "mean": {...}} with every number of the struct; NaN becomes null.
std::string format_metrics_json(std::span<const SceneMetrics> scenes);

// The headline numbers of two methods side by side: difference = a - b, ratio = a / b.
struct KeyComparison {
  std::string metric;  // e.g. "bad2_pred"
  std::string label;   // e.g. "bad-2 pred %"
  double a = kUndefined, b = kUndefined, difference = kUndefined, ratio = kUndefined;
};
// density, bad-2 over predicted pixels, bad-2 over all GT pixels, occErr, bandErr, time.
std::vector<KeyComparison> compare_key_metrics(const SceneMetrics& a, const SceneMetrics& b);
std::string format_comparison_table(std::span<const KeyComparison> rows, std::string_view a_name,
                                    std::string_view b_name);
// {"<metric>": {"<a_name>": x, "<b_name>": y, "difference": d, "ratio": r}, ...}
std::string format_comparison_json(std::span<const KeyComparison> rows, std::string_view a_name,
                                   std::string_view b_name);

}  // namespace dco::tools
