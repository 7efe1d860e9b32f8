// Runs the dco-bench binary the way a user does, on short sequences: the JSON object carries the
// promised fields with consistent values, the text names every measurement, bad input gives one
// clear error line and a non-zero exit.

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
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
  const CliRun r = run_bench(dir, {"--sequence",
                                   "synthetic",
                                   "--size",
                                   "320x180",
                                   "--frames",
                                   "3",
                                   "--paced-frames",
                                   "8",
                                   "--fps",
                                   "60",
                                   "--rounds",
                                   "3",
                                   "--json",
                                   "--set",
                                   "contour.parallel_flow=off",
                                   "--set",
                                   "stereo.row_threads=1",
                                   "--set",
                                   "contour.row_threads=1",
                                   "--set",
                                   "densify.row_threads=1",
                                   "--set",
                                   "runtime.opencv_threads=3",
                                   "--set",
                                   "runtime.release_latency_ms=100",
                                   "--set",
                                   "runtime.release_priority=0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::StartsWith("{"));
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one object on one line";
  const double ours = json_value(r.out, "ms_per_frame");
  const double peer = json_value(r.out, "peer_ms_per_frame");
  EXPECT_GT(ours, 0);
  EXPECT_GT(peer, 0);
  // Each round's ratio is its peer / dco; the headline figures are the rounds' medians.
  const std::regex round_pattern(
      "\\{\"ms_per_frame\": ([0-9.eE+-]+), \"peer_ms_per_frame\": ([0-9.eE+-]+), "
      "\"ratio\": ([0-9.eE+-]+), \"steady_ms\": ([0-9.eE+-]+)\\}");
  const std::string first_sequence = r.out.substr(0, r.out.find("\"sequences\""));
  std::vector<double> dco_ms, peer_ms, ratios, steady_ms;
  for (std::sregex_iterator it(first_sequence.begin(), first_sequence.end(), round_pattern), end;
       it != end; ++it) {
    dco_ms.push_back(std::stod((*it)[1].str()));
    peer_ms.push_back(std::stod((*it)[2].str()));
    ratios.push_back(std::stod((*it)[3].str()));
    steady_ms.push_back(std::stod((*it)[4].str()));
    EXPECT_GT(steady_ms.back(), 0);
    EXPECT_NEAR(ratios.back(), peer_ms.back() / dco_ms.back(), 1e-6 * ratios.back());
  }
  ASSERT_EQ(ratios.size(), 3u) << r.out;
  const auto middle = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[1];
  };
  EXPECT_DOUBLE_EQ(ours, middle(dco_ms));
  EXPECT_DOUBLE_EQ(peer, middle(peer_ms));
  EXPECT_DOUBLE_EQ(json_value(r.out, "ratio"), middle(ratios));
  // The interval between the first and the last result, without the filling of the pipeline.
  EXPECT_DOUBLE_EQ(json_value(r.out, "steady_ms"), middle(steady_ms));
  const double p50 = json_value(r.out, "latency_p50_ms");
  EXPECT_GT(p50, 0);
  EXPECT_GE(json_value(r.out, "latency_p99_ms"), p50);
  EXPECT_EQ(json_value(r.out, "width"), 320);
  EXPECT_EQ(json_value(r.out, "frames"), 3);
  EXPECT_EQ(json_value(r.out, "warmup_frames"), 3) << "the default 8, at most the frames";
  EXPECT_GT(json_value(r.out, "first_result_ms"), 0);
  const double planes_share = json_value(r.out, "planes_on_stereo_thread");
  EXPECT_GE(planes_share, 0.0);
  EXPECT_LE(planes_share, 1.0);
  const double early_contour_share = json_value(r.out, "early_contour_on_stereo_thread");
  EXPECT_GE(early_contour_share, 0.0);
  EXPECT_LE(early_contour_share, 1.0);
  const double next_contour_share = json_value(r.out, "next_contour_on_stereo_thread");
  EXPECT_GE(next_contour_share, 0.0);
  EXPECT_LE(next_contour_share, 1.0);
  EXPECT_EQ(json_value(r.out, "paced_frames"), 8);
  // Only the timed frames' results count, not those of the warm-up frames before them.
  const double published = json_value(r.out, "published");
  EXPECT_GE(published, 1);
  EXPECT_LE(published, 8);
  EXPECT_EQ(published + json_value(r.out, "dropped"), 8);
  EXPECT_GT(json_value(r.out, "stereo_ms"), 0);
  EXPECT_THAT(r.out, HasSubstr("\"sequences\": [{\"name\": \"synthetic hand 320x180\""));
  EXPECT_THAT(r.out, HasSubstr("\"parallel_flow\": false"));
  EXPECT_EQ(json_value(r.out, "stereo_row_threads"), 1);
  EXPECT_EQ(json_value(r.out, "contour_row_threads"), 1);
  EXPECT_EQ(json_value(r.out, "densify_row_threads"), 1);
  EXPECT_EQ(json_value(r.out, "opencv_threads"), 3);
  EXPECT_EQ(json_value(r.out, "release_latency_ms"), 100);
  EXPECT_THAT(r.out, HasSubstr("\"release_realtime\": false"));
}

// A range asked for is the range both dco and the peer search, not each sequence's own.
TEST(DcoBenchCli, AMaxDisparityAskedForIsTheOneSearched) {
  TempDir dir;
  const std::vector<std::string> args = {
      "--sequence", "synthetic", "--size", "320x180",        "--frames", "3",     "--warmup",
      "1",          "--rounds",  "1",      "--paced-frames", "3",        "--json"};
  const CliRun own = run_bench(dir, args);
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_GT(json_value(own.out, "max_disparity"), 16);
  std::vector<std::string> asked = args;
  for (const char* a : {"--set", "stereo.max_disparity=16"}) asked.push_back(a);
  const CliRun set = run_bench(dir, asked);
  ASSERT_EQ(set.exit_code, 0) << set.err;
  EXPECT_EQ(json_value(set.out, "max_disparity"), 16);
}

TEST(DcoBenchCli, TheReleaseLineSaysHowTheReleaseThreadIsScheduled) {
  TempDir dir;
  const CliRun r =
      run_bench(dir, {"--sequence", "synthetic", "--size", "160x96", "--frames", "2", "--warmup",
                      "1", "--paced-frames", "4", "--rounds", "1", "--set",
                      "runtime.release_latency_ms=80", "--set", "runtime.release_priority=2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("release  at capture + 80 ms"));
  // Either it got the priority, or it says why not; never silently a normal thread.
  EXPECT_THAT(r.out, ::testing::AnyOf(HasSubstr("release thread at SCHED_FIFO 2"),
                                      HasSubstr("release thread a normal one (SCHED_FIFO not "
                                                "allowed here)")));
}

TEST(DcoBenchCli, TextNamesEveryMeasurementOnTheKarlsruheClip) {
  if (!fs::is_directory(kKarlsruhe / "images")) GTEST_SKIP() << "no Karlsruhe clip in the data";
  TempDir dir;
  const CliRun r = run_bench(dir, {"--sequence",     "karlsruhe",
                                   "--frames",       "2",
                                   "--warmup",       "1",
                                   "--paced-frames", "3",
                                   "--set",          "runtime.threads=3",
                                   "--set",          "contour.parallel_flow=on",
                                   "--set",          "stereo.row_threads=3",
                                   "--set",          "contour.row_threads=1",
                                   "--set",          "densify.row_threads=2",
                                   "--set",          "runtime.opencv_threads=2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("karlsruhe 2010_03_09_drive_0023: 2 frames of 1344x372"));
  EXPECT_THAT(r.out,
              HasSubstr("max-disp 96, 3 stage thread(s) (+ a flow worker) (rows on 3 / 1 / 2 "
                        "threads in stereo / contour / densify), OpenCV's loops on 2 thread(s), "
                        "each run after an untimed "
                        "pass over the first 1"));
  EXPECT_THAT(r.out, HasSubstr("a new runtime's first result after"));
  EXPECT_THAT(r.out, HasSubstr("ms/frame"));
  EXPECT_THAT(r.out, HasSubstr("stereo"));
  EXPECT_THAT(r.out, HasSubstr("latency  p50"));
  // Every round's warm-up and timed frames: 3 rounds of 1 + 2.
  EXPECT_THAT(r.out, ::testing::MatchesRegex(
                         ".*match planes ran on the stereo thread for [0-9] of 9 frames.*"));
  EXPECT_THAT(r.out, HasSubstr("of 3 frames dropped"));
  EXPECT_THAT(r.out, HasSubstr("OpenCV StereoSGBM 3-way + WLS"));
  EXPECT_THAT(r.out, HasSubstr("median of 3 rounds"));
  EXPECT_THAT(r.out, HasSubstr("round 3  dco"));
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
  expect_usage({"--fps", "1e-10"}, "--fps needs a rate in [0.01, 1000]");
  expect_usage({"--sequence", "kitti"}, "'kitti'");
  expect_usage({"--paced-frames", "-1"}, "--paced-frames");
  expect_usage({"--paced-frames", "2147483647"}, "--paced-frames must be within 1..100000");
  expect_usage({"--warmup", "-1"}, "--warmup");
  expect_usage({"--rounds", "0"}, "--rounds");
  expect_usage({"--frobnicate"}, "unknown option --frobnicate");
  expect_usage({"--sequence", "synthetic", "--synthetic", "cats"}, "unknown preset 'cats'");
}

TEST(DcoBenchCli, BadDataAndParametersExitWithOne) {
  TempDir dir;
  const auto expect_data = [&](const std::vector<std::string>& args, const std::string& what) {
    testing::expect_one_error_line(run_bench(dir, args), "dco-bench", 1, what);
  };
  expect_data({"--sequence", "karlsruhe", "--karlsruhe", (dir.path() / "missing").string()},
              "missing");
  const fs::path config = dir.path() / "bad.toml";
  std::ofstream(config) << "[runtime]\naffinity = \"0,0\"\n";
  expect_data({"--sequence", "synthetic", "--config", config.string()}, "listed twice");
}

// Parameters given on the command line alone are command-line mistakes (status 2), as dcod's.
TEST(DcoBenchCli, BadSetsAndBackendsExitWithTwo) {
  TempDir dir;
  const auto expect_usage = [&](const std::vector<std::string>& args, const std::string& what) {
    testing::expect_one_error_line(run_bench(dir, args), "dco-bench", 2, what);
  };
  expect_usage({"--sequence", "synthetic", "--set", "runtime.threads=9"}, "runtime.threads");
  expect_usage({"--sequence", "synthetic", "--set", "runtime.affinity=0,0"}, "listed twice");
  expect_usage({"--sequence", "synthetic", "--set", "foo.bar=1"}, "unknown key 'foo.bar'");
  expect_usage({"--backend", "foo"}, "--backend foo: not one of auto, cpu, cuda");
  // Frames held in memory beyond half of it: said, not a bad_alloc or the OOM killer.
  expect_usage({"--sequence", "synthetic", "--frames", "99999"},
               "more than half of this machine's");
}

// The ipc benchmark sends udpm multicast, so it runs only where a private network namespace can
// be made (it makes its own); elsewhere the test is skipped.
bool private_netns_available() {
  const std::string unshare = geteuid() == 0 ? "unshare -n" : "unshare -rn";
  return std::system((unshare + " sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo' "
                                ">/dev/null 2>&1")
                         .c_str()) == 0;
}

TEST(DcoBenchCli, IpcJsonCountsEveryFrameOfEveryClient) {
  if (!private_netns_available()) GTEST_SKIP() << "cannot make a private network namespace";
  TempDir dir;
  constexpr int kFrames = 20;
  const CliRun r = run_bench(dir, {"ipc", "--clients", "1,3", "--rates", "60", "--frames",
                                   std::to_string(kFrames), "--size", "320x180", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one object on one line";
  const double p99 = json_value(r.out, "p99_us");
  const double inline_p99 = json_value(r.out, "inline_p99_us");
  EXPECT_GT(p99, 0);
  EXPECT_GT(inline_p99, 0);
  EXPECT_GE(json_value(r.out, "lost"), 0);
  EXPECT_GT(json_value(r.out, "ratio"), 0);
  EXPECT_EQ(json_value(r.out, "poll_us"), 2000) << "clients poll through the write by default";
  EXPECT_GT(json_value(r.out, "client_cpu_us_per_frame"), 0);
  // Per run: every frame a client got or lost is counted once, and the percentiles are ordered.
  const std::regex run_pattern(
      "\"clients\": ([0-9]+), \"rate_hz\": 60, \"received\": ([0-9]+), \"p50_us\": ([0-9.eE+-]+), "
      "\"p99_us\": ([0-9.eE+-]+), \"max_us\": ([0-9.eE+-]+), \"lost\": ([0-9]+), .*?"
      "\"inline_received\": ([0-9]+), \"inline_p50_us\": ([0-9.eE+-]+), "
      "\"inline_p99_us\": ([0-9.eE+-]+), \"inline_max_us\": ([0-9.eE+-]+), "
      "\"inline_lost\": ([0-9]+), .*?\"ratio\": ([0-9.eE+-]+)\\}");
  std::vector<int> clients;
  double worst_p99 = 0, smallest_ratio = 1e300;
  for (auto it = std::sregex_iterator(r.out.begin(), r.out.end(), run_pattern);
       it != std::sregex_iterator(); ++it) {
    const std::smatch& m = *it;
    const int n = std::stoi(m[1].str());
    clients.push_back(n);
    EXPECT_EQ(std::stol(m[2].str()) + std::stol(m[6].str()), n * kFrames) << m[0];
    EXPECT_LE(std::stod(m[3].str()), std::stod(m[4].str()));
    EXPECT_LE(std::stod(m[4].str()), std::stod(m[5].str()));
    EXPECT_EQ(std::stol(m[7].str()) + std::stol(m[11].str()), n * kFrames) << m[0];
    EXPECT_LE(std::stod(m[8].str()), std::stod(m[9].str()));
    EXPECT_LE(std::stod(m[9].str()), std::stod(m[10].str()));
    EXPECT_NEAR(std::stod(m[12].str()), std::stod(m[9].str()) / std::stod(m[4].str()),
                1e-3 * std::stod(m[12].str()));
    worst_p99 = std::max(worst_p99, std::stod(m[4].str()));
    smallest_ratio = std::min(smallest_ratio, std::stod(m[12].str()));
  }
  EXPECT_EQ(clients, (std::vector<int>{1, 3})) << r.out;
  EXPECT_DOUBLE_EQ(p99, worst_p99);
  EXPECT_NEAR(json_value(r.out, "ratio"), smallest_ratio, 1e-9 * smallest_ratio);
}

TEST(DcoBenchCli, IpcBadCommandLinesExitWithTwo) {
  TempDir dir;
  const auto expect_usage = [&](const std::vector<std::string>& args, const std::string& what) {
    testing::expect_one_error_line(run_bench(dir, args), "dco-bench ipc", 2, what);
  };
  expect_usage({"ipc", "--clients", "0"}, "--clients");
  expect_usage({"ipc", "--clients", "1,x"}, "--clients");
  expect_usage({"ipc", "--rates", "fast"}, "--rates");
  expect_usage({"ipc", "--frames", "1"}, "--frames");
  expect_usage({"ipc", "--poll-us", "100001"}, "--poll-us");
  expect_usage({"ipc", "--poll-us", "-1"}, "--poll-us");
  expect_usage({"ipc", "--size", "8x8"}, "--size");
  expect_usage({"ipc", "--sequence", "synthetic"}, "unknown option --sequence");
}

TEST(DcoBenchCli, HelpDescribesTheRuns) {
  TempDir dir;
  const CliRun r = run_bench(dir, {"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("usage: dco-bench"));
  EXPECT_THAT(r.out, HasSubstr("--paced-frames"));
  EXPECT_THAT(r.out, HasSubstr("--json"));
  EXPECT_THAT(r.out, HasSubstr("dco-bench ipc --help"));
  const CliRun ipc = run_bench(dir, {"ipc", "--help"});
  EXPECT_EQ(ipc.exit_code, 0);
  EXPECT_THAT(ipc.out, HasSubstr("usage: dco-bench ipc"));
  EXPECT_THAT(ipc.out, HasSubstr("--clients"));
  EXPECT_THAT(ipc.out, HasSubstr("inline p99 / ring p99"));
}

}  // namespace
}  // namespace dco::tools
