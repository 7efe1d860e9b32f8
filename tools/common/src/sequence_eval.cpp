#include "dco/tools/sequence_eval.hpp"

#include <functional>

#include <fmt/format.h>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/tools/gt_noise.hpp"

namespace dco::tools {

namespace fs = std::filesystem;

fs::path sequence_frame_path(const fs::path& dir, std::string_view prefix, int index) {
  return dir / fmt::format("{}{:06d}.pfm", prefix, index);
}

int count_sequence_frames(const fs::path& dir, std::string_view prefix) {
  int n = 0;
  while (fs::exists(sequence_frame_path(dir, prefix, n))) ++n;
  return n;
}

namespace {

void require_directory(const fs::path& dir, std::string_view what) {
  if (!fs::is_directory(dir))
    throw Error(fmt::format("{} directory '{}' does not exist", what, dir.string()));
}

// Reads one frame and checks it against the first prediction frame (`like`, empty for that one).
Image<float> read_frame(const fs::path& path, ImageView<const float> like) {
  Image<float> frame = read_pfm(path);
  if (frame.channels() != 1 || (!like.empty() && !frame.view().same_size(like)))
    throw Error(fmt::format("'{}' is {}x{}x{}, the sequence is {}x{}x1", path.string(),
                            frame.width(), frame.height(), frame.channels(),
                            like.empty() ? frame.width() : like.width,
                            like.empty() ? frame.height() : like.height));
  return frame;
}

// Prediction frame `index`, checked against the first one (`like`, empty for frame 0).
using PredictionReader = std::function<Image<float>(int index, ImageView<const float> like)>;

// count_sequence_frames, refusing a sequence of fewer than 2 frames.
int count_sequence_of_two_or_more(const fs::path& dir, std::string_view prefix) {
  const int frames = count_sequence_frames(dir, prefix);
  if (frames < 2)
    throw Error(fmt::format("'{}' holds {} frame(s) numbered from {}; a sequence needs at least 2",
                            dir.string(), frames, sequence_frame_path({}, prefix, 0).string()));
  return frames;
}

// The GT frames must be as many as the prediction's.
void require_gt_frames(const fs::path& gt_dir, int frames) {
  require_directory(gt_dir, "ground-truth");
  const int gt_frames = count_sequence_frames(gt_dir, kGroundTruthFramePrefix);
  if (gt_frames != frames)
    throw Error(fmt::format("'{}' holds {} frame(s) numbered from {}, the prediction {}",
                            gt_dir.string(), gt_frames,
                            sequence_frame_path({}, kGroundTruthFramePrefix, 0).string(), frames));
}

SequenceReport evaluate_frames(int frames, const PredictionReader& read_prediction,
                               const std::optional<fs::path>& gt_dir, int boundary_tolerance) {
  constexpr auto frame = sequence_frame_path;
  SequenceReport report;
  report.frames = frames;
  report.has_gt = gt_dir.has_value();
  report.boundary_tolerance = boundary_tolerance;

  // With GT, its first frame fixes the planes for both meters, so the two flicker rates compare.
  const Image<float> first = read_prediction(0, {});
  GroundTruth truth;
  if (gt_dir)
    truth.disparity = read_frame(frame(*gt_dir, kGroundTruthFramePrefix, 0), first.view());
  FlickerMeter flicker =
      gt_dir ? FlickerMeter(occlusion_planes(truth.disparity.view())) : FlickerMeter();
  FlickerMeter gt_flicker(flicker.planes());  // used with GT only

  for (int i = 0; i < report.frames; ++i) {
    const Image<float> pred = i == 0 ? first : read_prediction(i, first.view());
    flicker.add(pred.view());
    if (!gt_dir) continue;
    if (i > 0)
      truth.disparity = read_frame(frame(*gt_dir, kGroundTruthFramePrefix, i), first.view());
    gt_flicker.add(truth.disparity.view());
    report.frame_metrics.push_back(
        evaluate_disparity(fmt::format("{}{:06d}", kPredictionFramePrefix, i), pred.view(), truth));
    report.frame_boundary.push_back(
        boundary_accuracy(pred.view(), truth.disparity.view(), boundary_tolerance));
    const std::vector<double> gaps = gap_planes(truth.disparity.view());
    report.frame_silhouette.push_back(
        boundary_accuracy(pred.view(), truth.disparity.view(), gaps, boundary_tolerance));
  }
  report.planes = flicker.planes();
  report.flicker = flicker.flip_rate();
  if (gt_dir) {
    report.gt_flicker = gt_flicker.flip_rate();
    report.boundary = mean_boundary_accuracy(report.frame_boundary);
    report.silhouette = mean_boundary_accuracy(report.frame_silhouette);
  }
  return report;
}

}  // namespace

SequenceReport evaluate_sequence(const fs::path& pred_dir, const std::optional<fs::path>& gt_dir,
                                 int boundary_tolerance) {
  require_directory(pred_dir, "sequence");
  const int frames = count_sequence_of_two_or_more(pred_dir, kPredictionFramePrefix);
  if (gt_dir) require_gt_frames(*gt_dir, frames);
  const PredictionReader read = [&](int i, ImageView<const float> like) {
    return read_frame(sequence_frame_path(pred_dir, kPredictionFramePrefix, i), like);
  };
  return evaluate_frames(frames, read, gt_dir, boundary_tolerance);
}

SequenceReport evaluate_noisy_gt_sequence(const fs::path& gt_dir, double sigma_px,
                                          int boundary_tolerance) {
  require_directory(gt_dir, "ground-truth");
  const int frames = count_sequence_of_two_or_more(gt_dir, kGroundTruthFramePrefix);
  const PredictionReader read = [&](int i, ImageView<const float> like) {
    const Image<float> gt =
        read_frame(sequence_frame_path(gt_dir, kGroundTruthFramePrefix, i), like);
    return noisy_ground_truth(gt.view(), sigma_px, static_cast<std::uint64_t>(i) + 1);
  };
  return evaluate_frames(frames, read, gt_dir, boundary_tolerance);
}

}  // namespace dco::tools
