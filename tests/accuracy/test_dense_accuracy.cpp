// The whole depth pipeline (stereo, contours, densify) with its default settings: on the shared
// real scenes against SGBM + WLS, and on a moving synthetic hand at the headset's 1280x720, where
// the silhouettes of the fingers must stay where the ground truth has them.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/image_io.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"
#include "dco/tools/boundary_metrics.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "dco/tools/sgbm_wls.hpp"
#include "dco/tools/temporal_metrics.hpp"

namespace dco {
namespace {

const std::filesystem::path kDataDir = DCO_DATA_DIR;

// One pair through the offline pipeline: frame 0 comes out at finish().
Image<float> dense_disparity(const pipeline::PipelineParams& params,
                             const Image<std::uint8_t>& left, const Image<std::uint8_t>& right) {
  pipeline::DepthPipeline depth(params);
  pipeline::DepthResult out;
  if (!depth.push(left.cview(), right.cview(), out)) {
    EXPECT_TRUE(depth.finish(out));
  }
  return std::move(out.dense);
}

// A shared scene's pair, ground truth and the default parameters with its search range.
struct LoadedScene {
  std::string name;
  pipeline::PipelineParams params;
  Image<std::uint8_t> left, right;
  tools::GroundTruth gt;
};

std::vector<LoadedScene> shared_scenes() {
  std::vector<LoadedScene> scenes;
  for (const tools::Scene& scene :
       tools::load_scene_manifest(kDataDir / "stereo_scenes.tsv", kDataDir)) {
    LoadedScene& s = scenes.emplace_back();
    s.name = scene.name;
    s.params.stereo.max_disparity = scene.max_disp;
    s.left = load_image(scene.left);
    s.right = load_image(scene.right);
    s.gt = tools::load_ground_truth(scene);
  }
  return scenes;
}

TEST(DenseDepthAccuracy, SharedScenesMeetTheOcclusionTargetAndBeatSgbmWls) {
  ASSERT_TRUE(std::filesystem::exists(kDataDir / "stereo_scenes.tsv"))
      << "no stereo data at " << kDataDir;
  std::vector<tools::SceneMetrics> ours, peer;
  for (const LoadedScene& s : shared_scenes()) {
    ours.push_back(
        tools::evaluate_disparity(s.name, dense_disparity(s.params, s.left, s.right).view(), s.gt));
    const tools::BaselineResult b =
        tools::run_sgbm_wls(s.left.view(), s.right.view(), s.params.stereo.max_disparity);
    peer.push_back(tools::evaluate_disparity(s.name, b.disparity.view(), s.gt));
  }
  ASSERT_EQ(ours.size(), 8u);
  std::printf("%s", tools::format_metrics_table(ours).c_str());
  const tools::SceneMetrics m = tools::mean_metrics(ours);
  const tools::SceneMetrics p = tools::mean_metrics(peer);
  EXPECT_DOUBLE_EQ(m.density, 100.0);  // dense: every pixel set
  EXPECT_LE(m.occ_err, 6.0);
  // 16.7 % against 27.2 % today; with densify.color_sigma 4 (before 2026-11-25) 17.1 % failed this.
  EXPECT_LT(m.all.bad2, 0.62 * p.all.bad2);
  EXPECT_LT(m.band_err, p.band_err);
  // Where the peer predicts, it is no better at the boundaries either.
  EXPECT_LT(m.band_err, p.band_err_pred + 3.0);
}

// The right image with every level times `gain`: a right camera that runs a brighter exposure.
Image<std::uint8_t> brighter(const Image<std::uint8_t>& image, double gain) {
  Image<std::uint8_t> out(image.width(), image.height(), image.channels());
  const int n = image.width() * image.channels();
  for (int y = 0; y < image.height(); ++y)
    for (int i = 0; i < n; ++i)
      out.view().row(y)[i] =
          static_cast<std::uint8_t>(std::min(255L, std::lround(gain * image.view().row(y)[i])));
  return out;
}

TEST(DenseDepthAccuracy, MoreGainOrARowOfDriftOnOneCameraCostsLittleWithTheCameraAlignment) {
  ASSERT_TRUE(std::filesystem::exists(kDataDir / "stereo_scenes.tsv"))
      << "no stereo data at " << kDataDir;
  std::vector<tools::SceneMetrics> equal, balanced, unbalanced, aligned, unaligned;
  for (const LoadedScene& s : shared_scenes()) {
    const pipeline::PipelineParams& params = s.params;
    const Image<std::uint8_t>& right = s.right;
    const Image<std::uint8_t> bright = brighter(right, 1.1);
    Image<std::uint8_t> lower;  // the right camera's scene a row lower
    stereo::shift_rows(right.cview(), -1.0, lower);
    const auto score = [&](const pipeline::PipelineParams& p, const Image<std::uint8_t>& r) {
      return tools::evaluate_disparity(s.name, dense_disparity(p, s.left, r).view(), s.gt);
    };
    equal.push_back(score(params, right));
    balanced.push_back(score(params, bright));
    aligned.push_back(score(params, lower));
    pipeline::PipelineParams off = params;
    off.stereo.exposure_balance = false;
    unbalanced.push_back(score(off, bright));
    off = params;
    off.stereo.vertical_alignment = false;
    unaligned.push_back(score(off, lower));
  }
  const auto bad2 = [](const std::vector<tools::SceneMetrics>& m) {
    return tools::mean_metrics(m).all.bad2;
  };
  const double e = bad2(equal);
  std::printf(
      "bad-2 of the dense map: cameras equal %.2f %%; right gain 1.1: %.2f %% with the "
      "exposure balance, %.2f %% without; right scene a row lower: %.2f %% with the "
      "vertical alignment, %.2f %% without\n",
      e, bad2(balanced), bad2(unbalanced), bad2(aligned), bad2(unaligned));
  EXPECT_LT(bad2(balanced), e + 1.0);                 // 15.70 against 15.55 % on 2026-11-30
  EXPECT_GT(bad2(unbalanced), bad2(balanced) + 4.0);  // 23.96 %
  EXPECT_LT(bad2(aligned), e + 1.0);                  // 15.95 %
  EXPECT_GT(bad2(unaligned), bad2(aligned) + 4.0);    // 25.45 %
}

// Mean silhouette recall / precision over the first frames of a synthetic scene at 1280x720.
tools::BoundaryAccuracy silhouettes_of(const char* scene, pipeline::PipelineParams params) {
  const synthetic::SceneConfig config = synthetic::preset(scene, 1280, 720);
  const synthetic::SceneRenderer renderer(config);
  params.stereo.max_disparity = synthetic::covering_max_disparity(config);
  pipeline::DepthPipeline depth(params);
  constexpr int kFrames = 6;
  std::vector<synthetic::StereoSample> samples(kFrames);
  std::vector<tools::BoundaryAccuracy> silhouettes;
  pipeline::DepthResult out;
  const auto score = [&](const pipeline::DepthResult& r) {
    const Image<float>& truth = samples[static_cast<std::size_t>(r.index)].disparity;
    silhouettes.push_back(
        tools::boundary_accuracy(r.dense.view(), truth.view(), tools::gap_planes(truth.view())));
  };
  for (int i = 0; i < kFrames; ++i) {
    renderer.render(i, samples[static_cast<std::size_t>(i)]);
    const auto& s = samples[static_cast<std::size_t>(i)];
    if (depth.push(s.left.cview(), s.right.cview(), out)) score(out);
  }
  while (depth.finish(out)) score(out);
  EXPECT_EQ(silhouettes.size(), static_cast<std::size_t>(kFrames));
  return tools::mean_boundary_accuracy(silhouettes);
}

tools::BoundaryAccuracy hand_silhouettes(pipeline::PipelineParams params) {
  return silhouettes_of("hand", std::move(params));
}

struct OnAndOff {
  tools::BoundaryAccuracy on, off;
};

// The hand's silhouettes with `with` and with `without` (the same, a step turned off), both
// printed.
OnAndOff hand_silhouettes_with_and_without(const char* step, pipeline::PipelineParams with,
                                           pipeline::PipelineParams without) {
  const OnAndOff r{hand_silhouettes(std::move(with)), hand_silhouettes(std::move(without))};
  std::printf(
      "hand silhouettes with %s: recall %.2f %%, precision %.2f %%; without: %.2f %%, %.2f %%\n",
      step, r.on.recall, r.on.precision, r.off.recall, r.off.precision);
  return r;
}

TEST(DenseDepthAccuracy, HandSilhouettesAtFullHeadsetSize) {
  const tools::BoundaryAccuracy mean = hand_silhouettes({});
  std::printf("hand silhouettes within %d px: recall %.2f %%, precision %.2f %%\n",
              tools::kBoundaryTolerance, mean.recall, mean.precision);
  // Dropping both sides of every disparity jump erased the thinnest fingers (86 % recall);
  // without the boundary refinement at input resolution the half-size matching leaves it at 93 %.
  // Precision: 97.2 % on these frames, 94.2 % without the output median.
  EXPECT_GE(mean.recall, 95.0);
  EXPECT_GE(mean.precision, 95.0);
}

TEST(DenseDepthAccuracy, OutputMedianClearsSpecksOffTheHandsSilhouettes) {
  // Where a hole of the 2x2 matcher grid meets a depth edge the solve leaves single pixels
  // between the two surfaces: each is a speck of wrong occlusion against some virtual plane.
  pipeline::PipelineParams without;
  without.densify.median_size = 0;
  const auto [on, off] = hand_silhouettes_with_and_without("the output median", {}, without);
  // The 5x5 median: precision 94.2 -> 97.2 %, recall 98.4 -> 97.9 % (it rounds the fingertips).
  EXPECT_GT(on.precision, off.precision + 2.0);
  EXPECT_GE(on.recall, off.recall - 0.8);
}

TEST(DenseDepthAccuracy, BoxOutlinesStepWhereTheBoxesBegin) {
  // Left of each box the stereo stage leaves the strip the box hides from the right camera and
  // often the box's first pixels: the strip goes to the background, the rim past it to the box.
  // With the rim left to the hole hint, which draws it to the background, these frames scored
  // 92.4 % precision (95.5 % with the rule, both before the output median; 97.3 % with the
  // 5x5 one).
  const tools::BoundaryAccuracy mean = silhouettes_of("boxes", {});
  std::printf("boxes silhouettes within %d px: recall %.2f %%, precision %.2f %%\n",
              tools::kBoundaryTolerance, mean.recall, mean.precision);
  EXPECT_GE(mean.recall, 97.0);
  EXPECT_GE(mean.precision, 96.5);
}

TEST(DenseDepthAccuracy, FingerRimsLostByTheChecksGetTheFingersValue) {
  // Holes beyond the refinement's 2 px reach of a depth edge, decided along their row: without
  // that search they take the background's fill and leave islands inside the fingers' outlines.
  // Measured with the output median off, which clears part of those islands too: with the
  // default 5x5 median these six frames show the search 0.4 point (1.2 points over 30 frames).
  pipeline::PipelineParams with;
  with.densify.median_size = 0;
  pipeline::PipelineParams without = with;
  without.stereo.boundary_hole_reach = 0;
  const auto [on, off] = hand_silhouettes_with_and_without("the row search", with, without);
  EXPECT_GT(on.precision, off.precision + 1.0);  // 1.5 points on these frames
  EXPECT_GE(on.recall, off.recall - 0.2);
}

// % of pixels that change side of the virtual planes between consecutive frames over the first
// frames of the hand at 1280x720 (planes from the first ground-truth frame, as dco-eval sets them).
double hand_flicker(pipeline::PipelineParams params) {
  const synthetic::SceneConfig config = synthetic::preset("hand", 1280, 720);
  const synthetic::SceneRenderer renderer(config);
  params.stereo.max_disparity = synthetic::covering_max_disparity(config);
  pipeline::DepthPipeline depth(params);
  synthetic::StereoSample first;
  renderer.render(0, first);
  tools::FlickerMeter flicker(tools::occlusion_planes(first.disparity.view()));
  pipeline::DepthResult out;
  constexpr int kFrames = 8;
  for (int i = 0; i < kFrames; ++i) {
    synthetic::StereoSample s;
    renderer.render(i, s);
    if (depth.push(s.left.cview(), s.right.cview(), out)) flicker.add(out.dense.view());
  }
  while (depth.finish(out)) flicker.add(out.dense.view());
  return flicker.flip_rate();
}

TEST(DenseDepthAccuracy, MatchPlanesSteadyTheOcclusionOfASlantedWall) {
  // The matches' sub-pixel noise moves the crossing of a virtual plane with the hand's slanted
  // wall from frame to frame; smoothed along their local planes, they hold it still.
  pipeline::PipelineParams without;
  without.densify.plane_window = 0;
  const double off = hand_flicker(without);
  const double on = hand_flicker({});
  std::printf("hand flicker: %.2f %% with the match planes, %.2f %% without\n", on, off);
  EXPECT_LT(on, 0.75 * off);
}

}  // namespace
}  // namespace dco
