// Runs the dco-eval binary the way a user does and checks exit codes, stderr and output.

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "dco/core/disparity_io.hpp"
#include "dco/core/image_io.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

using dco::testing::TempDir;
using ::testing::HasSubstr;
using ::testing::StartsWith;

const std::filesystem::path kDataDir = DCO_DATA_DIR;
const std::filesystem::path kManifest = kDataDir / "stereo_scenes.tsv";

using EvalRun = testing::CliRun;

EvalRun run_eval(const TempDir& dir, const std::vector<std::string>& args) {
  return testing::run_cli(DCO_EVAL_EXE, dir, args);
}

// Writes every scene's GT as its prediction, so every error is 0.
std::filesystem::path write_gt_predictions(const TempDir& dir) {
  const auto pred_dir = dir.path() / "pred";
  std::filesystem::create_directories(pred_dir);
  for (const Scene& scene : load_scene_manifest(kManifest, kDataDir))
    write_pfm(pred_dir / (scene.file_stem() + ".pfm"), load_ground_truth(scene).disparity.view());
  return pred_dir;
}

std::vector<std::string> eval_args(const std::filesystem::path& pred_dir) {
  return {"--scenes",        kManifest.string(), "--data-root",
          kDataDir.string(), "--pred-dir",       pred_dir.string()};
}

void expect_one_error_line(const EvalRun& r, int exit_code, const std::string& fragment) {
  testing::expect_one_error_line(r, "dco-eval", exit_code, fragment);
}

TEST(DcoEvalCli, GroundTruthAsPredictionScoresZeroOnEveryScene) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  const EvalRun text = run_eval(dir, eval_args(pred_dir));
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_EQ(text.err, "");
  for (const Scene& scene : load_scene_manifest(kManifest, kDataDir))
    EXPECT_THAT(text.out, HasSubstr(scene.name));
  EXPECT_THAT(text.out, HasSubstr("\nmean "));

  std::vector<std::string> args = eval_args(pred_dir);
  args.push_back("--json");
  const EvalRun json = run_eval(dir, args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr(R"("prediction": {"pred_dir": )"));
  EXPECT_THAT(json.out, HasSubstr(R"("mean": {"scene": "mean")"));
  // The mean row: full density, no error anywhere.
  const std::string mean = json.out.substr(json.out.find(R"("mean": {)"));
  EXPECT_THAT(mean, HasSubstr(R"("density": 100)"));
  EXPECT_THAT(mean, HasSubstr(R"("bad1": 0, "bad2": 0, "bad4": 0, "avgerr": 0})"));
  EXPECT_THAT(mean, HasSubstr(R"("occ_err": 0, "occ_err_pred": 0, "band_err": 0)"));
}

TEST(DcoEvalCli, MissingOrMisSizedPredictionIsARuntimeError) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  std::filesystem::remove(pred_dir / "middlebury2003_Teddy.pfm");
  expect_one_error_line(run_eval(dir, eval_args(pred_dir)), 1, "middlebury2003_Teddy.pfm");

  Image<float> small(10, 10);
  small.fill(1.0f);
  write_pfm(pred_dir / "middlebury2003_Teddy.pfm", small.view());
  expect_one_error_line(run_eval(dir, eval_args(pred_dir)), 1, "10x10x1");

  expect_one_error_line(run_eval(dir, eval_args(dir.path() / "nowhere")), 1, "nowhere");
}

TEST(DcoEvalCli, ASparseSidecarSplitsTheErrorIntoMatchedAndFilledPixels) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  // Tsukuba's sparse map: its left half matched (with the true values), the rest left empty; the
  // dense prediction is the truth, 3 px off on the right half.
  const Scene tsukuba = load_scene_manifest(kManifest, kDataDir)[2];
  ASSERT_EQ(tsukuba.name, "middlebury2001/Tsukuba");
  const Image<float> truth = load_ground_truth(tsukuba).disparity;
  Image<float> dense(truth.width(), truth.height()), sparse(truth.width(), truth.height());
  for (int y = 0; y < truth.height(); ++y)
    for (int x = 0; x < truth.width(); ++x) {
      const bool left_half = x < truth.width() / 2;
      sparse.at(x, y) = left_half ? truth.at(x, y) : std::numeric_limits<float>::infinity();
      dense.at(x, y) = left_half ? truth.at(x, y) : truth.at(x, y) + 3.0f;
    }
  write_pfm(pred_dir / "middlebury2001_Tsukuba.pfm", dense.view());
  write_pfm(pred_dir / "middlebury2001_Tsukuba.sparse.pfm", sparse.view());
  std::vector<std::string> args = eval_args(pred_dir);
  for (const char* a : {"--only", "Tsukuba", "--json"}) args.push_back(a);
  const EvalRun json = run_eval(dir, args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  // Every error sits in the filled half, none in the matched one.
  EXPECT_THAT(json.out, HasSubstr(R"("matched": {"pixels": )"));
  EXPECT_THAT(json.out,
              HasSubstr(R"("bad1": 0, "bad2": 0, "bad4": 0, "avgerr": 0}, "filled_err")"));
  EXPECT_THAT(json.out, HasSubstr(R"("bad1": 100, "bad2": 100, "bad4": 0, "avgerr": 3})"));
  // Scenes without a sidecar have no split.
  args.pop_back();
  args[args.size() - 1] = "Teddy";
  const EvalRun teddy = run_eval(dir, args);
  ASSERT_EQ(teddy.exit_code, 0) << teddy.err;
  args.push_back("--json");
  EXPECT_THAT(run_eval(dir, args).out, HasSubstr(R"("matches": null)"));
  // A sidecar of another size is refused, naming it.
  Image<float> small(10, 10);
  small.fill(1.0f);
  write_pfm(pred_dir / "middlebury2001_Tsukuba.sparse.pfm", small.view());
  expect_one_error_line(run_eval(dir, eval_args(pred_dir)), 1, "sparse map is 10x10x1");
}

TEST(DcoEvalCli, OnlyFilterBaselineAndTimeSidecar) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  std::ofstream(pred_dir / "middlebury2001_Tsukuba.time_ms") << "12.5\n";
  std::vector<std::string> args = eval_args(pred_dir);
  for (const char* a : {"--only", "Tsukuba", "--baseline", "sgbm-wls"}) args.push_back(a);

  const EvalRun text = run_eval(dir, args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("middlebury2001/Tsukuba"));
  EXPECT_THAT(text.out, ::testing::Not(HasSubstr("Teddy")));
  EXPECT_THAT(text.out, HasSubstr("baseline: sgbm-wls (1 scenes)"));
  EXPECT_THAT(text.out, HasSubstr("comparison of the means"));
  EXPECT_THAT(text.out, HasSubstr("bad-2 pred %"));

  args.push_back("--json");
  const EvalRun json = run_eval(dir, args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr(R"("baseline": {"name": "sgbm-wls")"));
  EXPECT_THAT(json.out, HasSubstr(R"("comparison": {)"));
  EXPECT_THAT(json.out, HasSubstr(R"("time_ms": {"prediction": 12.5, "sgbm-wls": )"));

  // A sidecar holding more than one time is no time.
  std::ofstream(pred_dir / "middlebury2001_Tsukuba.time_ms") << "12abc\n";
  expect_one_error_line(run_eval(dir, eval_args(pred_dir)), 1,
                        "does not hold a time in milliseconds");
}

// The offset each scene's GT needs to match its own images. art's GT is known to sit about
// 0.85 px below what its images show (it scores every matcher worse); Teddy's lines up.
TEST(DcoEvalCli, GroundTruthAlignmentFindsEachScenesOffsetAndScoresAgainstTheMovedGt) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  std::vector<std::string> args = eval_args(pred_dir);
  for (const char* a : {"--only", "middlebury200", "--gt-alignment"}) args.push_back(a);
  const EvalRun text = run_eval(dir, args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("ground-truth alignment"));

  args.push_back("--json");
  const EvalRun json = run_eval(dir, args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const std::string aligned = json.out.substr(json.out.find(R"("gt_alignment")"));
  // The number after `key` that follows `anchor` in the alignment's JSON.
  const auto number_after = [&](const std::string& anchor, const std::string& key) {
    const std::size_t at = aligned.find(anchor);
    const std::size_t value = at == std::string::npos ? at : aligned.find(key, at);
    EXPECT_NE(value, std::string::npos) << anchor << " " << key;
    return value == std::string::npos ? 99.0 : std::stod(aligned.substr(value + key.size()));
  };
  EXPECT_NEAR(number_after(R"({"scene": "middlebury2005/art", "offset_px")", R"("offset_px": )"),
              0.85, 0.2);
  EXPECT_NEAR(number_after(R"({"scene": "middlebury2003/Teddy", "offset_px")", R"("offset_px": )"),
              0.0, 0.1);
  // The GT itself as the prediction scores 0 against the GT as given; against art's moved GT
  // every pixel is its offset away.
  const double art_offset =
      number_after(R"({"scene": "middlebury2005/art", "offset_px")", R"("offset_px": )");
  EXPECT_NEAR(number_after(R"({"scene": "middlebury2005/art", "width")", R"("avgerr": )"),
              art_offset, 0.01);
  EXPECT_GT(number_after(R"("mean": {"scene": "mean")", R"("band_err": )"), 0.0);

  expect_one_error_line(run_eval(dir, {"--sequence", dir.path().string(), "--gt-alignment"}), 2,
                        "--gt-alignment goes with --scenes");
}

TEST(DcoEvalCli, NoiseFloorScoresTheGroundTruthWithGaussianNoise) {
  TempDir dir;
  const std::vector<std::string> base = {"--scenes",        kManifest.string(), "--data-root",
                                         kDataDir.string(), "--only",           "middlebury2003"};
  std::vector<std::string> args = base;
  for (const char* a : {"--noise-floor", "0.25", "--noise-floor", "1"}) args.push_back(a);
  const EvalRun text = run_eval(dir, args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("noise floor"));
  EXPECT_THAT(text.out, HasSubstr("sigma 0.25 px"));
  EXPECT_THAT(text.out, HasSubstr("sigma 1.00 px"));

  args.push_back("--json");
  const EvalRun json = run_eval(dir, args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const std::size_t floors = json.out.find(R"("noise_floor": [{"sigma_px": 0.25)");
  ASSERT_NE(floors, std::string::npos) << json.out;
  // Teddy's band error for each sigma, in order: noise alone puts band pixels on the wrong
  // side, the more the larger it is, long before bad-2 counts an error.
  std::vector<double> band;
  for (std::size_t at = json.out.find(R"("band_err": )", floors); at != std::string::npos;
       at = json.out.find(R"("band_err": )", at + 1))
    band.push_back(std::stod(json.out.substr(at + 12)));
  ASSERT_EQ(band.size(), 4u);  // the scene and the mean, per sigma
  EXPECT_GT(band[0], 2.0);
  // The seed follows the scene's place in the manifest, not in what --only left: Teddy scores
  // as in the whole manifest's run (bench/RESULTS.md, "what the band goal asks").
  EXPECT_NEAR(band[0], 9.45, 0.005);
  EXPECT_GT(band[2], band[0] + 2.0);

  expect_one_error_line(run_eval(dir, {"--scenes", kManifest.string(), "--noise-floor", "-1"}), 2,
                        "--noise-floor");
  expect_one_error_line(run_eval(dir, {"--scenes", kManifest.string(), "--noise-floor", "x"}), 2,
                        "--noise-floor");
}

TEST(DcoEvalCli, ErrorMapsPicturePerSceneAndPlane) {
  TempDir dir;
  const auto pred_dir = write_gt_predictions(dir);
  // Teddy's prediction: the GT with its left half moved 3 px nearer.
  const Scene teddy = load_scene_manifest(kManifest, kDataDir)[1];
  ASSERT_EQ(teddy.name, "middlebury2003/Teddy");
  Image<float> nearer = load_ground_truth(teddy).disparity;
  for (int y = 0; y < nearer.height(); ++y)
    for (int x = 0; x < nearer.width() / 2; ++x) nearer.at(x, y) += 3.0f;
  write_pfm(pred_dir / (teddy.file_stem() + ".pfm"), nearer.view());

  std::vector<std::string> args = eval_args(pred_dir);
  const auto maps = dir.path() / "maps";
  for (const std::string& a :
       std::vector<std::string>{"--only", "middlebury200", "--error-maps", maps.string()})
    args.push_back(a);
  const EvalRun r = run_eval(dir, args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("error maps: "));
  // Red (predicted in front) pixels: none where the prediction is the GT, many on Teddy.
  const auto red_pixels = [](const std::filesystem::path& png) {
    const Image<std::uint8_t> map = load_image(png);
    EXPECT_EQ(map.channels(), 3);
    int red = 0;
    for (int y = 0; y < map.height(); ++y)
      for (int x = 0; x < map.width(); ++x)
        red += map.at(x, y, 2) >= 150 && map.at(x, y, 0) == 0 && map.at(x, y, 1) == 0;
    return red;
  };
  for (const char* q : {"20", "35", "50", "65", "80"}) {
    EXPECT_EQ(red_pixels(maps / fmt::format("middlebury2001_Tsukuba.plane{}.png", q)), 0) << q;
    EXPECT_GT(red_pixels(maps / fmt::format("middlebury2003_Teddy.plane{}.png", q)), 500) << q;
  }
  EXPECT_FALSE(std::filesystem::exists(maps / "middlebury2014_Motorcycle.plane50.png"));

  expect_one_error_line(run_eval(dir, {"--scenes", kManifest.string(), "--baseline", "sgbm-wls",
                                       "--error-maps", maps.string()}),
                        2, "--error-maps needs --pred-dir");
  const auto file = dir.write("not_a_dir", "");
  std::vector<std::string> into_file = eval_args(pred_dir);
  for (const std::string& a : std::vector<std::string>{"--error-maps", file.string()})
    into_file.push_back(a);
  expect_one_error_line(run_eval(dir, into_file), 1, "not_a_dir");
}

TEST(DcoEvalCli, UsageErrorsExitWithTwo) {
  TempDir dir;
  const std::string scenes = kManifest.string();
  expect_one_error_line(run_eval(dir, {}), 2, "give one of --scenes");
  expect_one_error_line(run_eval(dir, {"--scenes", scenes}), 2, "--pred-dir");
  expect_one_error_line(run_eval(dir, {"--scenes", scenes, "--frobnicate"}), 2,
                        "unknown option --frobnicate");
  expect_one_error_line(run_eval(dir, {"--scenes"}), 2, "--scenes needs a value");
  expect_one_error_line(run_eval(dir, {"--scenes", scenes, "--baseline", "bm"}), 2,
                        "unknown baseline 'bm'");
  expect_one_error_line(run_eval(dir, {"--scenes", scenes, "--json=yes", "--baseline=sgbm-wls"}), 2,
                        "--json takes no value");
  expect_one_error_line(run_eval(dir, {"--scenes", scenes, "stray"}), 2, "unexpected argument");
  expect_one_error_line(
      run_eval(dir, {"--scenes", scenes, "--pred-dir", "/tmp", "--only", "no-such-scene"}), 2,
      "no scene name contains 'no-such-scene'");
}

TEST(DcoEvalCli, BadManifestIsARuntimeError) {
  TempDir dir;
  expect_one_error_line(
      run_eval(dir, {"--scenes", (dir.path() / "none.tsv").string(), "--pred-dir", "/tmp"}), 1,
      "none.tsv");
  const auto tsv = dir.write("bad.tsv",
                             "scene\tleft\tright\tgt\tgt_format\tgt_divisor\tnocc_mask\tmax_disp\n"
                             "a\tl.png\tr.png\tg.exr\texr\t1\t-\t64\n");
  expect_one_error_line(run_eval(dir, {"--scenes", tsv.string(), "--pred-dir", "/tmp"}), 1,
                        "bad.tsv:2: unknown gt_format 'exr'");
  const auto rows = dir.write(
      "no_rows.tsv", "scene\tleft\tright\tgt\tgt_format\tgt_divisor\tnocc_mask\tmax_disp\n");
  expect_one_error_line(run_eval(dir, {"--scenes", rows.string(), "--pred-dir", "/tmp"}), 1,
                        "lists no scene");
}

TEST(DcoEvalCli, HelpGoesToStdout) {
  TempDir dir;
  const EvalRun r = run_eval(dir, {"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, StartsWith("usage: dco-eval"));
  EXPECT_EQ(r.err, "");
}

}  // namespace
}  // namespace dco::tools
