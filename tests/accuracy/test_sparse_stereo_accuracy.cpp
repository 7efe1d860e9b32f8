// The sparse stereo stage on the shared real scenes (Middlebury, KITTI, SceneFlow): it must keep
// most ground-truth pixels and be right on the pixels it keeps, better than SGBM + WLS.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/image_io.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "dco/tools/sgbm_wls.hpp"

namespace dco {
namespace {

const std::filesystem::path kDataDir = DCO_DATA_DIR;

std::vector<tools::SceneMetrics> evaluate_sparse_stage() {
  std::vector<tools::SceneMetrics> results;
  stereo::StereoParams params;
  Image<float> disparity;
  for (const tools::Scene& scene :
       tools::load_scene_manifest(kDataDir / "stereo_scenes.tsv", kDataDir)) {
    params.max_disparity = scene.max_disp;
    const auto matcher = stereo::make_cpu_stereo_matcher(params);
    const Image<std::uint8_t> left = load_image(scene.left);
    const Image<std::uint8_t> right = load_image(scene.right);
    matcher->compute(left.cview(), right.cview(), disparity);
    results.push_back(
        tools::evaluate_disparity(scene.name, disparity.view(), tools::load_ground_truth(scene)));
  }
  return results;
}

class SparseStereoAccuracy : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!std::filesystem::exists(kDataDir / "stereo_scenes.tsv")) return;
    scenes_ = new std::vector<tools::SceneMetrics>(evaluate_sparse_stage());
  }
  static void TearDownTestSuite() {
    delete scenes_;
    scenes_ = nullptr;
  }
  void SetUp() override { ASSERT_NE(scenes_, nullptr) << "no stereo data at " << kDataDir; }
  static std::vector<tools::SceneMetrics>* scenes_;
};
std::vector<tools::SceneMetrics>* SparseStereoAccuracy::scenes_ = nullptr;

TEST_F(SparseStereoAccuracy, MeanOverScenesMeetsTheTargets) {
  ASSERT_EQ(scenes_->size(), 8u);
  const tools::SceneMetrics mean = tools::mean_metrics(*scenes_);
  std::printf("%s", tools::format_metrics_table(*scenes_).c_str());
  EXPECT_GE(mean.density, 60.0);
  EXPECT_LE(mean.pred.bad2, 6.0);
}

TEST_F(SparseStereoAccuracy, EveryScenePredictsAUsefulShareAccurately) {
  // Per scene the margins are wider: KITTI and SceneFlow have large textureless areas the checks
  // reject, and the art/dolls ground truth sits about one pixel off its images. The largest
  // bad-4 is art's: 5.24 % with the default windows (4.91 % with AD-census's arm_short 17 and
  // tau2 6, which keep fewer pixels and give a worse dense map).
  for (const tools::SceneMetrics& m : *scenes_) {
    EXPECT_GE(m.density, 35.0) << m.scene;
    EXPECT_LE(m.pred.bad2, 16.0) << m.scene;
    EXPECT_LE(m.pred.bad4, 5.5) << m.scene;
  }
}

TEST_F(SparseStereoAccuracy, KeptPixelsAreMoreAccurateThanSgbmWls) {
  std::vector<tools::SceneMetrics> baseline;
  for (const tools::Scene& scene :
       tools::load_scene_manifest(kDataDir / "stereo_scenes.tsv", kDataDir)) {
    const Image<std::uint8_t> left = load_image(scene.left);
    const Image<std::uint8_t> right = load_image(scene.right);
    const tools::BaselineResult b = tools::run_sgbm_wls(left.view(), right.view(), scene.max_disp);
    baseline.push_back(
        tools::evaluate_disparity(scene.name, b.disparity.view(), tools::load_ground_truth(scene)));
  }
  const tools::SceneMetrics ours = tools::mean_metrics(*scenes_);
  const tools::SceneMetrics peer = tools::mean_metrics(baseline);
  EXPECT_LT(ours.pred.bad2, 0.5 * peer.pred.bad2);
  EXPECT_LT(ours.pred.avgerr, peer.pred.avgerr);
}

}  // namespace
}  // namespace dco
