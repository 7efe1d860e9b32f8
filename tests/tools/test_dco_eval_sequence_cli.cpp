// dco-eval's sequence and Sintel-flow modes, and how the modes exclude each other, run the way a
// user runs them.

#include <cmath>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "dco/core/disparity_io.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

namespace fs = std::filesystem;
using dco::testing::TempDir;
using testing::CliRun;
using ::testing::HasSubstr;
using ::testing::Not;

const fs::path kSintel = fs::path(DCO_DATA_DIR) / "sintel_flow";

CliRun run_eval(const TempDir& dir, const std::vector<std::string>& args) {
  return testing::run_cli(DCO_EVAL_EXE, dir, args);
}

void expect_one_error_line(const CliRun& r, int exit_code, const std::string& fragment) {
  testing::expect_one_error_line(r, "dco-eval", exit_code, fragment);
}

// A 64x48 step whose foreground (30) starts at column 20 + index and moves right one column per
// frame over a background of 10. Frame 0's quantiles are 10 and 30 (the largest value), so every
// plane lies halfway between them, at 20: each pair of frames flips one 48-pixel column across
// all five, 48 * 5 of 64 * 48 * 5 comparisons, 1.5625 %.
Image<float> moving_step(int index) {
  Image<float> d(64, 48);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) d.at(x, y) = x < 20 + index ? 10.0f : 30.0f;
  return d;
}

fs::path write_frames(const TempDir& dir, const std::string& prefix, int count) {
  for (int i = 0; i < count; ++i)
    write_pfm(dir.path() / fmt::format("{}{:06d}.pfm", prefix, i), moving_step(i).view());
  return dir.path();
}

int count_of(const std::string& text, const std::string& fragment) {
  int n = 0;
  for (auto at = text.find(fragment); at != std::string::npos; at = text.find(fragment, at + 1))
    ++n;
  return n;
}

TEST(DcoEvalSequenceCli, FlickerOfAPredictionAlone) {
  TempDir dir;
  const std::string seq = write_frames(dir, "frame_", 3).string();
  const CliRun text = run_eval(dir, {"--sequence", seq});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_EQ(text.err, "");
  EXPECT_THAT(text.out, HasSubstr("(3 frames)"));
  EXPECT_THAT(text.out,
              HasSubstr("planes from prediction frame 0: 20.00 20.00 20.00 20.00 20.00 px"));
  EXPECT_THAT(text.out, HasSubstr("flicker: 1.56 %"));
  EXPECT_THAT(text.out, Not(HasSubstr("boundary")));

  const CliRun json = run_eval(dir, {"--sequence", seq, "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr(R"("frames": 3, "planes": [20, 20, 20, 20, 20])"));
  EXPECT_THAT(json.out, HasSubstr(R"("planes_from": "prediction frame 0", "flicker": 1.5625})"));
  EXPECT_THAT(json.out, Not(HasSubstr("ground_truth")));
}

TEST(DcoEvalSequenceCli, GroundTruthAsPredictionIsPerfectAndFlickersAlike) {
  // dco-depth writes frame_* and gt_* into one folder; both options may name it.
  TempDir dir;
  write_frames(dir, "frame_", 4);
  const std::string seq = write_frames(dir, "gt_", 4).string();
  const CliRun text = run_eval(dir, {"--sequence", seq, "--gt-dir", seq});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("planes from ground-truth frame 0"));
  EXPECT_THAT(text.out, HasSubstr("recall 100.00 %, precision 100.00 %"));
  EXPECT_THAT(text.out, HasSubstr("frame_000003"));
  EXPECT_THAT(text.out, HasSubstr("\nmean "));

  const CliRun json = run_eval(dir, {"--sequence", seq, "--gt-dir", seq, "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_EQ(count_of(json.out, R"("flicker": 1.5625})"), 2) << json.out;  // prediction and GT
  EXPECT_THAT(json.out, HasSubstr(R"("mean": {"recall": 100, "precision": 100})"));
  // Boundary: the mean and 4 frames; silhouettes: the mean.
  EXPECT_EQ(count_of(json.out, R"({"recall": 100, "precision": 100})"), 6);
  EXPECT_THAT(
      json.out,
      HasSubstr(R"("silhouette": {"tolerance_px": 2, "mean": {"recall": 100, "precision": 100}})"));
  const std::string mean = json.out.substr(json.out.find(R"("mean": {"scene": "mean")"));
  EXPECT_THAT(mean, HasSubstr(R"("bad1": 0, "bad2": 0, "bad4": 0, "avgerr": 0})"));
  EXPECT_THAT(mean, HasSubstr(R"("occ_err": 0)"));
}

TEST(DcoEvalSequenceCli, NoiseFloorScoresTheGroundTruthFramesWithNoise) {
  TempDir dir;
  write_frames(dir, "frame_", 4);
  const std::string seq = write_frames(dir, "gt_", 4).string();
  const std::vector<std::string> args = {"--sequence",    seq, "--gt-dir",      seq,
                                         "--noise-floor", "0", "--noise-floor", "4"};
  const CliRun text = run_eval(dir, args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("noise floor"));

  std::vector<std::string> json_args = args;
  json_args.push_back("--json");
  const CliRun json = run_eval(dir, json_args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const std::size_t floors = json.out.find(R"("noise_floor": [{"sigma_px": 0, "flicker": )");
  ASSERT_NE(floors, std::string::npos) << json.out;
  // No noise: the GT's own flicker. Noise of 4 px moves pixels across the planes from frame to
  // frame, and puts some off by more than 2 px.
  std::vector<double> flicker;
  for (std::size_t at = json.out.find(R"("flicker": )", floors); at != std::string::npos;
       at = json.out.find(R"("flicker": )", at + 1))
    flicker.push_back(std::stod(json.out.substr(at + 11)));
  ASSERT_EQ(flicker.size(), 2u);
  EXPECT_DOUBLE_EQ(flicker[0], 1.5625);
  // Every pixel lies 10 px (2.5 sigma) from the planes: noise puts it on the other side in 0.6 % of
  // frames, about 1.2 points of flicker on top of the moving edge's.
  EXPECT_GT(flicker[1], 2.0);
  EXPECT_THAT(json.out.substr(floors),
              HasSubstr(R"("bad1": 0, "bad2": 0, "bad4": 0, "avgerr": 0})"));

  expect_one_error_line(run_eval(dir, {"--sequence", seq, "--noise-floor", "1"}), 2,
                        "--noise-floor needs --gt-dir");
  expect_one_error_line(run_eval(dir, {"--flow-sintel", seq, "--noise-floor", "1"}), 2,
                        "--noise-floor goes with --scenes or --sequence");
}

TEST(DcoEvalSequenceCli, PredictionIsMeasuredAgainstTheGroundTruthPlanes) {
  // A frozen prediction does not flicker, the moving GT does; its edge drifts out of tolerance.
  TempDir dir;
  const fs::path gt = write_frames(dir, "gt_", 5);
  for (int i = 0; i < 5; ++i)
    write_pfm(gt / fmt::format("frame_{:06d}.pfm", i), moving_step(0).view());
  const CliRun json = run_eval(dir, {"--sequence", gt.string(), "--gt-dir", gt.string(), "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr(R"("planes_from": "ground-truth frame 0", "flicker": 0})"));
  EXPECT_THAT(json.out, HasSubstr(R"("ground_truth": {"dir": )"));
  EXPECT_THAT(json.out, HasSubstr(R"("flicker": 1.5625})"));
  // Edges 0..4 px apart, tolerance 2: recall 100, 100, 100, 50, 0 per frame.
  EXPECT_THAT(json.out, HasSubstr(R"("mean": {"recall": 70, "precision": 70})"));
}

TEST(DcoEvalSequenceCli, MissingOrShortSequencesAreRuntimeErrors) {
  TempDir dir;
  expect_one_error_line(run_eval(dir, {"--sequence", (dir.path() / "nowhere").string()}), 1,
                        "nowhere");
  const std::string seq = write_frames(dir, "frame_", 1).string();
  expect_one_error_line(run_eval(dir, {"--sequence", seq}), 1,
                        "holds 1 frame(s) numbered from frame_000000.pfm");
  // Numbering stops at the first gap.
  write_pfm(dir.path() / "frame_000002.pfm", moving_step(2).view());
  expect_one_error_line(run_eval(dir, {"--sequence", seq}), 1, "holds 1 frame(s)");

  write_pfm(dir.path() / "frame_000001.pfm", moving_step(1).view());
  write_frames(dir, "gt_", 2);
  expect_one_error_line(run_eval(dir, {"--sequence", seq, "--gt-dir", seq}), 1,
                        "holds 2 frame(s) numbered from gt_000000.pfm, the prediction 3");
  expect_one_error_line(
      run_eval(dir, {"--sequence", seq, "--gt-dir", (dir.path() / "no-gt").string()}), 1,
      "ground-truth directory");

  Image<float> small(8, 8);
  small.fill(5.0f);
  write_pfm(dir.path() / "frame_000001.pfm", small.view());
  expect_one_error_line(run_eval(dir, {"--sequence", seq}), 1,
                        "frame_000001.pfm' is 8x8x1, the sequence is 64x48x1");
}

TEST(DcoEvalSequenceCli, ModesExcludeEachOther) {
  TempDir dir;
  expect_one_error_line(run_eval(dir, {}), 2, "give one of --scenes, --sequence or --flow-sintel");
  expect_one_error_line(run_eval(dir, {"--sequence"}), 2, "--sequence needs a value");
  expect_one_error_line(run_eval(dir, {"--gt-dir", "g"}), 2, "give one of --scenes");
  expect_one_error_line(run_eval(dir, {"--sequence", "s", "--flow-sintel", "f"}), 2,
                        "--sequence and --flow-sintel are separate modes");
  expect_one_error_line(run_eval(dir, {"--scenes", "t.tsv", "--sequence", "s"}), 2,
                        "--scenes and --sequence are separate modes");
  expect_one_error_line(run_eval(dir, {"--scenes", "t.tsv", "--pred-dir", "p", "--gt-dir", "g"}), 2,
                        "--gt-dir goes with --sequence, not with --scenes");
  expect_one_error_line(run_eval(dir, {"--sequence", "s", "--pred-dir", "p"}), 2,
                        "--pred-dir goes with --scenes, not with --sequence");
  expect_one_error_line(run_eval(dir, {"--dis-preset", "fast", "--sequence", "s"}), 2,
                        "--dis-preset goes with --flow-sintel, not with --sequence");
  expect_one_error_line(run_eval(dir, {"--flow-sintel", "f", "--only", "x"}), 2,
                        "--only goes with --scenes");
  expect_one_error_line(run_eval(dir, {"--flow-sintel", "f", "--dis-preset", "slow"}), 2,
                        "unknown DIS preset 'slow' (known: ultrafast, fast, medium)");
  expect_one_error_line(run_eval(dir, {"--sequence", "s", "extra"}), 2, "unexpected argument");
}

TEST(DcoEvalSintelCli, FourSequencesWithFiniteEndPointErrors) {
  TempDir dir;
  const CliRun text = run_eval(dir, {"--flow-sintel", kSintel.string()});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("(DIS preset fast, 4 sequences)"));
  for (const char* seq : {"clean/easy", "clean/medium", "final/easy", "final/medium", "mean"})
    EXPECT_THAT(text.out, HasSubstr(std::string("\n") + seq + " ")) << seq;

  const CliRun json =
      run_eval(dir, {"--flow-sintel", kSintel.string(), "--dis-preset", "ultrafast", "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr(R"("dis_preset": "ultrafast")"));
  const std::regex row(
      R"re(\{"sequence": "([a-z/]+)", "epe_all": ([^,]+), "epe_noc": ([^}]+)\})re");
  int rows = 0;
  for (auto it = std::sregex_iterator(json.out.begin(), json.out.end(), row);
       it != std::sregex_iterator(); ++it, ++rows) {
    const double all = std::stod((*it)[2]), noc = std::stod((*it)[3]);
    EXPECT_TRUE(std::isfinite(all) && all > 0 && all < 10) << (*it)[0];
    EXPECT_TRUE(std::isfinite(noc) && noc > 0 && noc <= all) << (*it)[0];
  }
  EXPECT_EQ(rows, 5) << json.out;  // four sequences and the mean
}

TEST(DcoEvalSintelCli, MissingOrEmptyFolderIsARuntimeError) {
  TempDir dir;
  expect_one_error_line(run_eval(dir, {"--flow-sintel", (dir.path() / "none").string()}), 1,
                        "Sintel directory");
  fs::create_directories(dir.path() / "clean" / "easy");
  expect_one_error_line(run_eval(dir, {"--flow-sintel", dir.path().string()}), 1,
                        "holds no <pass>/<sequence>/ folder");
}

TEST(DcoEvalCli, HelpDocumentsEveryMode) {
  TempDir dir;
  const CliRun r = run_eval(dir, {"-h"});
  EXPECT_EQ(r.exit_code, 0);
  for (const char* usage : {"dco-eval --scenes TSV", "dco-eval --sequence DIR [--gt-dir DIR]",
                            "dco-eval --flow-sintel DIR [--dis-preset NAME]", "frame_000000.pfm",
                            "gt_000000.pfm", "ultrafast, fast (default) or medium"})
    EXPECT_THAT(r.out, HasSubstr(usage));
}

}  // namespace
}  // namespace dco::tools
