// Real pairs through a lens fall-off: both views of two shared scenes darkened towards their
// corners as one lens model would; the stereo stage's fall-off correction must win back the
// matches it costs.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "dco/core/image_io.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "support/fall_off.hpp"

namespace dco {
namespace {

const std::filesystem::path kDataDir = DCO_DATA_DIR;

struct FalloffRun {
  double bad2 = 0;  // of the sparse map, over every GT pixel (a missing value counts as bad)
  double falloff = 0;
};

FalloffRun sparse_run(const tools::Scene& scene, const Image<std::uint8_t>& left,
                      const Image<std::uint8_t>& right, bool correct) {
  stereo::StereoParams params;
  params.max_disparity = scene.max_disp;
  params.lens_falloff = correct;
  const auto matcher = stereo::make_stereo_matcher({}, params);
  Image<float> disparity;
  matcher->compute(left.cview(), right.cview(), disparity);
  const tools::SceneMetrics m =
      tools::evaluate_disparity(scene.name, disparity.view(), tools::load_ground_truth(scene));
  return {m.all.bad2, matcher->last_correction().falloff};
}

TEST(LensFalloffAccuracy, TheCorrectionWinsBackTheMatchesAFalloffCosts) {
  if (!std::filesystem::exists(kDataDir / "stereo_scenes.tsv"))
    GTEST_FAIL() << "no stereo data at " << kDataDir;
  constexpr double kFalloff = 0.3;  // 30 % darker in the corners
  int checked = 0;
  for (const tools::Scene& scene :
       tools::load_scene_manifest(kDataDir / "stereo_scenes.tsv", kDataDir)) {
    if (scene.name != "middlebury2014/Motorcycle" && scene.name != "middlebury2005/dolls") continue;
    ++checked;
    const Image<std::uint8_t> left = load_image(scene.left), right = load_image(scene.right);
    Image<std::uint8_t> dark_left = left, dark_right = right;
    testing::fall_off(dark_left, kFalloff);
    testing::fall_off(dark_right, kFalloff);
    const FalloffRun given = sparse_run(scene, left, right, true);
    const FalloffRun plain = sparse_run(scene, dark_left, dark_right, false);
    const FalloffRun corrected = sparse_run(scene, dark_left, dark_right, true);
    std::printf(
        "%s: sparse bad-2 over all GT pixels %.2f %% as given (fall-off k %.3f found), %.2f %% "
        "with k %.1f added to both views, %.2f %% with the correction (k %.3f found)\n",
        scene.name.c_str(), given.bad2, given.falloff, plain.bad2, kFalloff, corrected.bad2,
        corrected.falloff);
    // Matched through the correction, the darkened pair scores within a point of the pair as
    // given, and at least 2 points better than without it.
    EXPECT_LT(corrected.bad2, plain.bad2 - 2.0) << scene.name;
    EXPECT_LT(corrected.bad2, given.bad2 + 1.0) << scene.name;
    EXPECT_NEAR(corrected.falloff - given.falloff, kFalloff, 0.1) << scene.name;
  }
  EXPECT_EQ(checked, 2);
}

}  // namespace
}  // namespace dco
