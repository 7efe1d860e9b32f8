// Runs the dco-depth binary the way a user does: good runs write the files they promise, bad
// input gives one clear error line and a non-zero exit.

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "dco/core/calibration.hpp"
#include "dco/core/disparity_io.hpp"
#include "dco/core/image.hpp"
#include "dco/core/image_io.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

namespace fs = std::filesystem;
using dco::testing::TempDir;
using testing::CliRun;
using ::testing::HasSubstr;

const fs::path kDataDir = DCO_DATA_DIR;
const fs::path kTsukuba = kDataDir / "middlebury2001" / "Tsukuba";
const fs::path kMotorcycle = kDataDir / "middlebury2014" / "Motorcycle";

std::string fmt_name(const std::string& side, int i) {
  return side + "_" + (i < 10 ? "0" : "") + std::to_string(i) + ".png";
}

CliRun run_depth(const TempDir& dir, const std::vector<std::string>& args) {
  return testing::run_cli(DCO_DEPTH_EXE, dir, args);
}

void expect_error(const CliRun& r, int exit_code, const std::string& fragment) {
  testing::expect_one_error_line(r, "dco-depth", exit_code, fragment);
}

// Counts finite (predicted) and +inf (unknown) pixels; anything else is a failure.
struct Coverage {
  long finite = 0, unknown = 0, bad = 0;
};
Coverage coverage(const Image<float>& d) {
  Coverage c;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x) {
      const float v = d.at(x, y);
      if (std::isinf(v) && v > 0)
        ++c.unknown;
      else if (std::isfinite(v) && v > 0)
        ++c.finite;
      else
        ++c.bad;
    }
  return c;
}

TEST(DcoDepthCli, WritesASparseDisparityMapOfTheInputSize) {
  TempDir dir;
  const fs::path out = dir.path() / "d.pfm";
  const CliRun r = run_depth(
      dir, {"--left", (kTsukuba / "im3.png").string(), "--right", (kTsukuba / "im4.png").string(),
            "--max-disp", "16", "--out", out.string(), "--sparse"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image<float> d = read_pfm(out);
  ASSERT_EQ(d.width(), 384);
  ASSERT_EQ(d.height(), 288);
  const Coverage c = coverage(d);
  EXPECT_EQ(c.bad, 0);
  EXPECT_GT(c.finite, 384 * 288 / 2);  // most of the scene is matched
  EXPECT_GT(c.unknown, 0);             // and the map is sparse on purpose
  for (int y = 0; y < d.height(); ++y) {
    for (int x = 0; x < d.width(); ++x) {
      if (std::isfinite(d.at(x, y))) {
        ASSERT_LE(d.at(x, y), 16.5f) << x << "," << y;
      }
    }
  }
}

TEST(DcoDepthCli, DepthOutputFollowsTheCalibration) {
  TempDir dir;
  const fs::path disp = dir.path() / "d.pfm", depth = dir.path() / "z.pfm";
  const CliRun r = run_depth(
      dir, {"--left", (kMotorcycle / "im0.png").string(), "--right",
            (kMotorcycle / "im1.png").string(), "--calib", (kMotorcycle / "calib.txt").string(),
            "--max-disp", "70", "--out", disp.string(), "--depth-out", depth.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image<float> d = read_pfm(disp);
  const Image<float> z = read_pfm(depth);
  const StereoCalibration calib = load_calibration(kMotorcycle / "calib.txt");
  const RectifiedGeometry& g = calib.rectified;
  long checked = 0;
  for (int y = 0; y < d.height(); y += 7)
    for (int x = 0; x < d.width(); x += 7) {
      if (!std::isfinite(d.at(x, y))) {
        EXPECT_TRUE(std::isinf(z.at(x, y)));
        continue;
      }
      const double expected = g.f * g.baseline_m / (d.at(x, y) + g.doffs());
      ASSERT_NEAR(z.at(x, y), expected, 1e-4 * expected);
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  // A .PNG name gets a 16-bit PNG, whatever the case of its extension.
  const fs::path png = dir.path() / "Z.PNG";
  ASSERT_EQ(run_depth(dir, {"--left", (kMotorcycle / "im0.png").string(), "--right",
                            (kMotorcycle / "im1.png").string(), "--calib",
                            (kMotorcycle / "calib.txt").string(), "--max-disp", "70", "--out",
                            disp.string(), "--depth-out", png.string()})
                .exit_code,
            0);
  EXPECT_EQ(dco::testing::read_file(png).substr(1, 3), "PNG");
}

TEST(DcoDepthCli, BatchModeWritesEveryScene) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "pred";
  const CliRun r =
      run_depth(dir, {"--scenes", (kDataDir / "stereo_scenes.tsv").string(), "--data-root",
                      kDataDir.string(), "--out-dir", out_dir.string(), "--sparse"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const Scene& scene : load_scene_manifest(kDataDir / "stereo_scenes.tsv", kDataDir)) {
    const fs::path pfm = out_dir / (scene.file_stem() + ".pfm");
    ASSERT_TRUE(fs::exists(pfm)) << pfm;
    EXPECT_TRUE(fs::exists(out_dir / (scene.file_stem() + ".time_ms")));
    const Image<std::uint8_t> left = load_image(scene.left);
    const Image<float> d = read_pfm(pfm);
    EXPECT_EQ(d.width(), left.width());
    EXPECT_EQ(d.height(), left.height());
    EXPECT_EQ(coverage(d).bad, 0) << scene.name;
    EXPECT_THAT(r.out, HasSubstr(scene.name));
  }
}

TEST(DcoDepthCli, DenseBatchModeAlsoWritesTheSparseMapItWasFilledInFrom) {
  TempDir dir;
  // One small scene of the shared manifest.
  const fs::path manifest = dir.path() / "one.tsv";
  {
    std::ifstream in(kDataDir / "stereo_scenes.tsv");
    std::ofstream out(manifest);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("scene\t", 0) == 0 || line.rfind("middlebury2001/Tsukuba\t", 0) == 0)
        out << line << '\n';
  }
  const fs::path out_dir = dir.path() / "pred";
  const std::vector<std::string> args = {"--scenes",        manifest.string(), "--data-root",
                                         kDataDir.string(), "--out-dir",       out_dir.string()};
  const CliRun dense = run_depth(dir, args);
  ASSERT_EQ(dense.exit_code, 0) << dense.err;
  const Image<float> filled = read_pfm(out_dir / "middlebury2001_Tsukuba.pfm");
  const Image<float> matched = read_pfm(out_dir / "middlebury2001_Tsukuba.sparse.pfm");
  ASSERT_TRUE(filled.view().same_size(matched.view()));
  EXPECT_EQ(coverage(filled).bad, 0);
  EXPECT_EQ(coverage(filled).unknown, 0);
  EXPECT_EQ(coverage(matched).bad, 0);
  EXPECT_GT(coverage(matched).unknown, 0);  // the holes the densifier filled
  // A sparse run into the same folder drops the dense run's sidecar, which no longer fits.
  std::vector<std::string> sparse_args = args;
  sparse_args.push_back("--sparse");
  ASSERT_EQ(run_depth(dir, sparse_args).exit_code, 0);
  EXPECT_FALSE(fs::exists(out_dir / "middlebury2001_Tsukuba.sparse.pfm"));
}

// A PNG cut short is one error line of dco-depth's, with no line of libpng's before it.
TEST(DcoDepthCli, APngCutShortIsOneErrorLine) {
  TempDir dir;
  const fs::path cut = dir.path() / "cut.png";
  fs::copy_file(kTsukuba / "im3.png", cut);
  fs::resize_file(cut, fs::file_size(cut) / 2);
  expect_error(run_depth(dir, {"--left", cut.string(), "--right", (kTsukuba / "im4.png").string(),
                               "--out", (dir.path() / "d.pfm").string()}),
               1, "the PNG is cut short");
}

TEST(DcoDepthCli, MissingInputFileIsNamed) {
  TempDir dir;
  expect_error(
      run_depth(dir, {"--left", "/nonexistent/l.png", "--right", (kTsukuba / "im4.png").string(),
                      "--out", (dir.path() / "d.pfm").string()}),
      1, "/nonexistent/l.png");
}

TEST(DcoDepthCli, AManifestWithoutScenesOrThatIsADirectoryIsRefused) {
  TempDir dir;
  const auto rows = dir.write(
      "no_rows.tsv", "scene\tleft\tright\tgt\tgt_format\tgt_divisor\tnocc_mask\tmax_disp\n");
  expect_error(
      run_depth(dir, {"--scenes", rows.string(), "--out-dir", (dir.path() / "out").string()}), 1,
      "lists no scene");
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
  expect_error(
      run_depth(dir, {"--scenes", dir.path().string(), "--out-dir", (dir.path() / "out").string()}),
      1, "is a directory");
}

// A full disk in the middle of a map (a file size limit here) keeps the map written before.
TEST(DcoDepthCli, AWriteCutShortKeepsTheEarlierMap) {
  TempDir dir;
  const auto out = dir.path() / "d.pfm";
  dir.write("d.pfm", "earlier");
  const std::string cmd = "ulimit -f 100; trap '' XFSZ; '" + std::string(DCO_DEPTH_EXE) +
                          "' --left '" + (kTsukuba / "im3.png").string() + "' --right '" +
                          (kTsukuba / "im4.png").string() + "' --max-disp 16 --out '" +
                          out.string() + "' > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_EQ(dco::testing::read_file(out), "earlier");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 1);
}

TEST(DcoDepthCli, SizeMismatchIsRefused) {
  TempDir dir;
  Image<std::uint8_t> small(100, 80, 3);
  small.fill(128);
  const fs::path right = dir.path() / "small.png";
  save_image(right, small.view());
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right", right.string(),
                               "--out", (dir.path() / "d.pfm").string()}),
               1, "100x80x3");
}

// A calibration of rectified images (Middlebury's) is not applied, but its size still has to be
// the images': its focal length and baseline are for that size.
TEST(DcoDepthCli, RectifiedCalibrationOfAnotherSizeIsRefused) {
  TempDir dir;
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--calib",
                               (kMotorcycle / "calib.txt").string(), "--out",
                               (dir.path() / "d.pfm").string()}),
               1, "left image is 384x288 but the calibration is for 741x497");
}

// A rectified calibration without a size (Karlsruhe's without roi) takes the images', and its
// geometry is then checked against their width: principal points 5000 px apart would make every
// depth a few millimetres.
TEST(DcoDepthCli, AnUnsizedCalibrationIsCheckedAgainstTheImages) {
  TempDir dir;
  const fs::path calib = dir.write(
      "calib.txt",
      "P1_roi: 100 0 30 0 0 100 33 0 0 0 1 0\nP2_roi: 100 0 5030 -10 0 100 33 0 0 0 1 0\n");
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--calib", calib.string(), "--out",
                               (dir.path() / "d.pfm").string(), "--depth-out",
                               (dir.path() / "z.pfm").string()}),
               1, "principal points differ by 5000 px");
  EXPECT_FALSE(fs::exists(dir.path() / "z.pfm"));
  // The same in sequence mode, at its first frame.
  for (const char* name : {"l_000000.png", "l_000001.png"})
    fs::copy_file(kTsukuba / "im3.png", dir.path() / name);
  for (const char* name : {"r_000000.png", "r_000001.png"})
    fs::copy_file(kTsukuba / "im4.png", dir.path() / name);
  expect_error(run_depth(dir, {"--left-pattern", (dir.path() / "l_%06d.png").string(),
                               "--right-pattern", (dir.path() / "r_%06d.png").string(), "--calib",
                               calib.string(), "--out-dir", (dir.path() / "seq").string()}),
               1, "principal points differ by 5000 px");
  // A sensible one of the same form goes through.
  const fs::path good = dir.write(
      "good.txt",
      "P1_roi: 300 0 190 0 0 300 144 0 0 0 1 0\nP2_roi: 300 0 190 -30 0 300 144 0 0 0 1 0\n");
  const CliRun ok = run_depth(
      dir, {"--left", (kTsukuba / "im3.png").string(), "--right", (kTsukuba / "im4.png").string(),
            "--calib", good.string(), "--out", (dir.path() / "d.pfm").string(), "--depth-out",
            (dir.path() / "z.pfm").string()});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
}

TEST(DcoDepthCli, UnreadableCalibrationIsNamed) {
  TempDir dir;
  const fs::path calib = dir.write("broken_calib.txt", "cam0=[not a matrix]\nbaseline=\n");
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--calib", calib.string(), "--out",
                               (dir.path() / "d.pfm").string()}),
               1, "broken_calib.txt");
}

TEST(DcoDepthCli, NonPositiveMaxDisparityIsAUsageError) {
  TempDir dir;
  for (const std::string bad : {"0", "-4"})
    expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                                 (kTsukuba / "im4.png").string(), "--max-disp", bad, "--out",
                                 (dir.path() / "d.pfm").string()}),
                 2, "--max-disp must be positive");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--max-disp", "many", "--out",
                               "d.pfm"}),
               2, "needs an integer");
}

// --max-disp has the range of stereo.max_disparity.
TEST(DcoDepthCli, MaxDisparityAboveTheStagesLimitIsRefused) {
  TempDir dir;
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--max-disp", "1200", "--out",
                               (dir.path() / "d.pfm").string()}),
               2, "--max-disp 1200: value 1200 is outside [1, 1024]");
}

// A manifest's max_disp is held to the same limit as --max-disp.
TEST(DcoDepthCli, ManifestMaxDisparityAboveTheStagesLimitIsRefused) {
  TempDir dir;
  const fs::path manifest = dir.path() / "wide.tsv";
  {
    std::ifstream in(kDataDir / "stereo_scenes.tsv");
    std::ofstream out(manifest);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("scene\t", 0) == 0) out << line << '\n';
      if (line.rfind("middlebury2001/Tsukuba\t", 0) == 0)
        out << line.substr(0, line.rfind('\t')) << "\t2000\n";
    }
  }
  expect_error(run_depth(dir, {"--scenes", manifest.string(), "--data-root", kDataDir.string(),
                               "--out-dir", (dir.path() / "pred").string()}),
               1, "max_disparity must be in 1..1024, not 2000");
}

TEST(DcoDepthCli, MaxDisparityWiderThanTheImageIsRefused) {
  TempDir dir;
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--max-disp", "400", "--out",
                               (dir.path() / "d.pfm").string()}),
               1, "smaller than the image width");
}

TEST(DcoDepthCli, CommandLineMistakesExitWithTwo) {
  TempDir dir;
  expect_error(run_depth(dir, {}), 2, "--left");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png"}), 2, "--out is required");
  expect_error(run_depth(dir, {"--frobnicate"}), 2, "unknown option --frobnicate");
  expect_error(run_depth(dir, {"--scenes", "s.tsv"}), 2, "--out-dir");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm",
                               "--depth-out", "z.pfm"}),
               2, "--depth-out needs --calib");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--right-gain", "9", "--out-dir", "o"}), 2,
               "--right-gain needs a number in [0.25, 4]");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--right-offset", "1x", "--out-dir", "o"}), 2,
               "--right-offset needs a number");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--right-rows", "9", "--out-dir", "o"}), 2,
               "--right-rows needs a number in [-8, 8]");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--right-roll", "1.5", "--out-dir", "o"}), 2,
               "--right-roll needs a number in [-1, 1]");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--lens-falloff", "0.8", "--out-dir", "o"}),
               2, "--lens-falloff needs a number in [0, 0.75]");
  expect_error(run_depth(dir, {"--synthetic", "cats", "--out-dir", "o"}), 2,
               "unknown preset 'cats'");
  // Options of another mode are refused, not ignored.
  expect_error(run_depth(dir, {"--synthetic", "hand", "--first", "5", "--out-dir", "o"}), 2,
               "--first and --count are for --left-pattern");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--calib", "x.txt", "--out-dir", "o"}), 2,
               "--synthetic does not take --calib");
  // The synthetic scene's sides, 16..8192, are the command line's limits.
  expect_error(run_depth(dir, {"--synthetic", "hand", "--size", "8193x16", "--out-dir", "o"}), 2,
               "--size must be at most 8192x8192");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--size", "8x8", "--out-dir", "o"}), 2,
               "--size must be at least 16x16");
  expect_error(run_depth(dir, {"--synthetic", "hand", "--data-root", "d", "--out-dir", "o"}), 2,
               "--data-root needs --scenes");
  expect_error(
      run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm", "--overlays"}), 2,
      "--overlays is for --out-dir");
  for (const char* count : {"0", "-7"})
    expect_error(run_depth(dir, {"--left-pattern", "l%d.png", "--right-pattern", "r%d.png",
                                 "--count", count, "--out-dir", "o"}),
                 2, "--count must be >= 1");
  expect_error(
      run_depth(dir, {"--left-pattern", "l%s.png", "--right-pattern", "r%d.png", "--out-dir", "o"}),
      2, "needs exactly one integer field");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.png"}), 2,
               "--out writes PFM");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm", "--calib",
                               "c.txt", "--depth-out", "z.jpg"}),
               2, "--depth-out writes .pfm or .png");
  // One name for both outputs, neither there yet.
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm", "--calib",
                               "c.txt", "--depth-out", "./d.pfm"}),
               2, "--out and --depth-out name one file");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm", "--set",
                               "nonsense"}),
               2, "--set nonsense: expected key=value");
  expect_error(run_depth(dir, {"--left", "l.png", "--right", "r.png", "--out", "d.pfm", "--set",
                               "densify.plane_window=4"}),
               2, "plane_window must be 0 or odd");
}

// An output that names an input (through a link too) would replace it: refused, the input kept.
TEST(DcoDepthCli, AnOutputOverAnInputIsRefused) {
  TempDir dir;
  const fs::path left = dir.path() / "l.pfm";
  fs::copy_file(kTsukuba / "im3.png", dir.path() / "l.png");
  fs::create_symlink(dir.path() / "l.png", left);
  const auto size = fs::file_size(dir.path() / "l.png");
  expect_error(run_depth(dir, {"--left", left.string(), "--right", (kTsukuba / "im4.png").string(),
                               "--out", left.string()}),
               2, "is an input; the output would replace it");
  EXPECT_EQ(fs::file_size(dir.path() / "l.png"), size);
}

// An open-ended pattern sequence ends at the first frame one of whose images is missing (here
// the right one); a run that fails part-way leaves no frame of an earlier run beside its own.
TEST(DcoDepthCli, APatternSequenceEndsAtAMissingRightImageAndAFailedRunLeavesNoStaleFrames) {
  TempDir dir;
  const fs::path in = dir.path() / "in";
  const fs::path out = dir.path() / "out";
  fs::create_directories(in);
  for (int i = 0; i < 3; ++i) fs::copy_file(kTsukuba / "im3.png", in / fmt_name("L", i));
  for (int i = 0; i < 2; ++i) fs::copy_file(kTsukuba / "im4.png", in / fmt_name("R", i));
  const auto run = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"--left-pattern",  (in / "L_%02d.png").string(),
                                     "--right-pattern", (in / "R_%02d.png").string(),
                                     "--out-dir",       out.string(),
                                     "--max-disp",      "16"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_depth(dir, args);
  };
  const CliRun ok = run({});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("2 frames, max-disp 16,"));
  // An earlier run's frame 5, then a run that fails at its third frame (its right image is
  // missing and --count asks for it).
  fs::copy_file(out / "frame_000000.pfm", out / "frame_000005.pfm");
  expect_error(run({"--count", "3"}), 1, "R_02.png");
  EXPECT_TRUE(fs::exists(out / "frame_000000.pfm"));
  EXPECT_FALSE(fs::exists(out / "frame_000005.pfm"));
}

// A frame too small for the flow cue fails at the first frame, before anything is written.
TEST(DcoDepthCli, ASequenceTooSmallForTheFlowCueFailsBeforeItsFirstFrame) {
  TempDir dir;
  const fs::path out = dir.path() / "tiny";
  expect_error(run_depth(dir, {"--synthetic", "hand", "--size", "64x48", "--frames", "4",
                               "--out-dir", out.string()}),
               1, "too small for DIS optical flow");
  EXPECT_FALSE(fs::exists(out / "frame_000000.pfm"));
}

// A sequence written into the folder of a longer one leaves none of the old frames to be scored
// with the new; a disparity range given with --set holds for a synthetic scene too.
TEST(DcoDepthCli, ASequenceReplacesAnEarlierOneAndKeepsTheRangeItWasGiven) {
  TempDir dir;
  const fs::path out = dir.path() / "seq";
  const auto run = [&](const std::string& frames) {
    return run_depth(dir, {"--synthetic", "hand", "--size", "160x96", "--frames", frames,
                           "--out-dir", out.string(), "--set", "stereo.max_disparity=20"});
  };
  ASSERT_EQ(run("4").exit_code, 0);
  ASSERT_TRUE(fs::exists(out / "frame_000003.pfm"));
  ASSERT_TRUE(fs::exists(out / "gt_000003.pfm"));
  std::ofstream(out / "notes.txt") << "kept\n";
  const CliRun again = run("3");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_THAT(again.out, HasSubstr("removed 2 frame and ground-truth maps of an earlier run"));
  EXPECT_THAT(again.out, HasSubstr("3 frames, max-disp 20,"));
  EXPECT_TRUE(fs::exists(out / "frame_000002.pfm"));
  EXPECT_FALSE(fs::exists(out / "frame_000003.pfm"));
  EXPECT_FALSE(fs::exists(out / "gt_000003.pfm"));
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
}

// A synthetic scene wider than the search reaches (past 7500 px): the search stops at the stage's
// limit, and says so, as dcod does.
TEST(DcoDepthCli, ASyntheticSceneNearerThanTheSearchReachesIsSaid) {
  TempDir dir;
  const CliRun r =
      run_depth(dir, {"--synthetic", "hand", "--size", "8192x16", "--frames", "1", "--out-dir",
                      (dir.path() / "wide").string(), "--set", "contour.use_flow=false"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("the search stops at 1024: nearer surfaces are not measured"));
  EXPECT_THAT(r.out, HasSubstr("max-disp 1024"));
}

TEST(DcoDepthCli, UnknownParameterIsRefused) {
  TempDir dir;
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--out",
                               (dir.path() / "d.pfm").string(), "--set", "stereo.lamda_ad=3"}),
               2, "stereo.lamda_ad");
  const fs::path config = dir.write("bad.toml", "[stereo]\nuniqueness = 0.2\ncensus_widht = 7\n");
  expect_error(run_depth(dir, {"--left", (kTsukuba / "im3.png").string(), "--right",
                               (kTsukuba / "im4.png").string(), "--out",
                               (dir.path() / "d.pfm").string(), "--config", config.string()}),
               1, "bad.toml:3");
}

TEST(DcoDepthCli, HelpAndParameterListExitWithZero) {
  TempDir dir;
  const CliRun help = run_depth(dir, {"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_THAT(help.out, HasSubstr("usage: dco-depth"));
  const CliRun params = run_depth(dir, {"--list-params"});
  EXPECT_EQ(params.exit_code, 0);
  EXPECT_THAT(params.out, HasSubstr("stereo.lambda_ad"));
  EXPECT_THAT(params.out, HasSubstr("stereo.lambda_census"));
}

}  // namespace
}  // namespace dco::tools
