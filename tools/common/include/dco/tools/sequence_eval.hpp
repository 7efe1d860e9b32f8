#pragma once

#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include "dco/tools/boundary_metrics.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/temporal_metrics.hpp"

// A disparity sequence stored as numbered PFM frames, DIR/<prefix>000000.pfm, <prefix>000001.pfm,
// ... (same value conventions as single predictions: +inf / NaN / <= 0 = no value), scored for
// temporal stability and, with ground-truth frames, for accuracy.
namespace dco::tools {

inline constexpr std::string_view kPredictionFramePrefix = "frame_";
inline constexpr std::string_view kGroundTruthFramePrefix = "gt_";

// DIR/<prefix><index, 6 digits>.pfm
std::filesystem::path sequence_frame_path(const std::filesystem::path& dir, std::string_view prefix,
                                          int index);
// How many consecutive frames exist from index 0 on (a gap ends the sequence).
int count_sequence_frames(const std::filesystem::path& dir, std::string_view prefix);

struct SequenceReport {
  int frames = 0;
  bool has_gt = false;
  FlickerMeter::Planes planes{};   // what flicker is measured against: prediction or GT frame 0
  double flicker = kUndefined;     // FlickerMeter::flip_rate of the prediction
  double gt_flicker = kUndefined;  // the same on the GT frames (with GT only)
  // With GT only: one entry per frame (scene "frame_000000", ...), then the means over frames.
  std::vector<SceneMetrics> frame_metrics;
  std::vector<BoundaryAccuracy> frame_boundary;
  BoundaryAccuracy boundary;
  // Against planes in the depth gaps of each GT frame (gap_planes): object silhouettes only.
  std::vector<BoundaryAccuracy> frame_silhouette;
  BoundaryAccuracy silhouette;
  int boundary_tolerance = kBoundaryTolerance;
};

// Reads the frames one at a time. Throws dco::Error naming the file or directory when a directory
// is missing, the prediction has fewer than 2 frames, the GT has a different number of frames, or
// a frame is not a one-channel map of the first prediction frame's size.
SequenceReport evaluate_sequence(const std::filesystem::path& pred_dir,
                                 const std::optional<std::filesystem::path>& gt_dir,
                                 int boundary_tolerance = kBoundaryTolerance);

// The same with GT + N(0, sigma_px²) (noisy_ground_truth, seeded by the frame number) as the
// prediction: what a matcher whose only error is that noise scores on the sequence. Throws
// dco::Error as above, and for fewer than 2 GT frames or a bad sigma.
SequenceReport evaluate_noisy_gt_sequence(const std::filesystem::path& gt_dir, double sigma_px,
                                          int boundary_tolerance = kBoundaryTolerance);

}  // namespace dco::tools
