// Runs the dco-bench binary the way a user does, on short sequences: the JSON object carries the
// promised fields with consistent values, the text names every measurement, bad input gives one
// clear error line and a non-zero exit.

#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

namespace fs = std::filesystem;
using dco::testing::TempDir;
using testing::CliRun;
using ::testing::HasSubstr;

const fs::path kKarlsruhe =
    fs::path(DCO_DATA_DIR) / "karlsruhe_sequences" / "2010_03_09_drive_0023";

CliRun run_bench(const TempDir& dir, const std::vector<std::string>& args) {
  return testing::run_cli(DCO_BENCH_EXE, dir, args);
}

// The first value of `"key": number` in a JSON text; fails the test when there is none.
double json_value(const std::string& json, const std::string& key) {
  const std::regex pattern("\"" + key + "\": (-?[0-9.eE+-]+)");
  std::smatch m;
  if (!std::regex_search(json, m, pattern)) {
    ADD_FAILURE() << "no number \"" << key << "\" in " << json;
    return -1;
  }
  return std::stod(m[1].str());
}

TEST(DcoBenchCli, JsonHasThroughputLatencyAndThePeer) {
  TempDir dir;
  const CliRun r = run_bench(dir, {"--sequence", "synthetic", "--size", "320x180", "--frames", "3",
                                   "--paced-frames", "8", "--fps", "60", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::StartsWith("{"));
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one object on one line";
  const double ours = json_value(r.out, "ms_per_frame");
  const double peer = json_value(r.out, "peer_ms_per_frame");
  EXPECT_GT(ours, 0);
  EXPECT_GT(peer, 0);
  EXPECT_NEAR(json_value(r.out, "ratio"), peer / ours, 1e-6 * peer / ours);
  const double p50 = json_value(r.out, "latency_p50_ms");
  EXPECT_GT(p50, 0);
  EXPECT_GE(json_value(r.out, "latency_p99_ms"), p50);
  EXPECT_EQ(json_value(r.out, "width"), 320);
  EXPECT_EQ(json_value(r.out, "frames"), 3);
  EXPECT_EQ(json_value(r.out, "paced_frames"), 8);
  EXPECT_EQ(json_value(r.out, "published") + json_value(r.out, "dropped"), 8);
  EXPECT_GT(json_value(r.out, "stereo_ms"), 0);
  EXPECT_THAT(r.out, HasSubstr("\"sequences\": [{\"name\": \"synthetic hand 320x180\""));
}

TEST(DcoBenchCli, TextNamesEveryMeasurementOnTheKarlsruheClip) {
  if (!fs::is_directory(kKarlsruhe / "images")) GTEST_SKIP() << "no Karlsruhe clip in the data";
  TempDir dir;
  const CliRun r = run_bench(dir, {"--sequence", "karlsruhe", "--frames", "2", "--paced-frames",
                                   "3", "--set", "runtime.threads=3"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("karlsruhe 2010_03_09_drive_0023: 2 frames of 1344x372"));
  EXPECT_THAT(r.out, HasSubstr("max-disp 96, 3 stage thread(s)"));
  EXPECT_THAT(r.out, HasSubstr("ms/frame"));
  EXPECT_THAT(r.out, HasSubstr("stereo"));
  EXPECT_THAT(r.out, HasSubstr("latency  p50"));
  EXPECT_THAT(r.out, HasSubstr("of 3 frames dropped"));
  EXPECT_THAT(r.out, HasSubstr("OpenCV StereoSGBM 3-way + WLS"));
}

TEST(DcoBenchCli, BadCommandLinesExitWithTwo) {
  TempDir dir;
  const auto expect_usage = [&](const std::vector<std::string>& args, const std::string& what) {
    testing::expect_one_error_line(run_bench(dir, args), "dco-bench", 2, what);
  };
  expect_usage({"--frames", "0"}, "--frames");
  expect_usage({"--size", "320by180"}, "--size");
  expect_usage({"--size", "32x32"}, "at least 64x64");
  expect_usage({"--fps", "fast"}, "--fps");
  expect_usage({"--sequence", "kitti"}, "'kitti'");
  expect_usage({"--paced-frames", "-1"}, "--paced-frames");
  expect_usage({"--frobnicate"}, "unknown option --frobnicate");
}

TEST(DcoBenchCli, BadDataAndParametersExitWithOne) {
  TempDir dir;
  const auto expect_data = [&](const std::vector<std::string>& args, const std::string& what) {
    testing::expect_one_error_line(run_bench(dir, args), "dco-bench", 1, what);
  };
  expect_data({"--sequence", "karlsruhe", "--karlsruhe", (dir.path() / "missing").string()},
              "missing");
  expect_data({"--sequence", "synthetic", "--set", "runtime.threads=9"}, "runtime.threads");
  expect_data({"--sequence", "synthetic", "--set", "runtime.affinity=0,0"}, "listed twice");
  expect_data({"--sequence", "synthetic", "--synthetic", "cats"}, "cats");
}

TEST(DcoBenchCli, HelpDescribesTheRuns) {
  TempDir dir;
  const CliRun r = run_bench(dir, {"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("usage: dco-bench"));
  EXPECT_THAT(r.out, HasSubstr("--paced-frames"));
  EXPECT_THAT(r.out, HasSubstr("--json"));
}

}  // namespace
}  // namespace dco::tools
