// dcod's daemon with the INDEMIND driver on a simulated module: depth from the camera's own
// fisheye calibration reaches a client through the ring, and DCO_STATUS-bound state comes from the
// driver; a USB capture of the module replays through dcod's own source URI.

#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <thread>
#include <vector>

#include "dco/client.hpp"
#include "dco/daemon/daemon.hpp"
#include "dco/drivers/indemind_source.hpp"
#include "dco/drivers/usb_capture.hpp"
#include "indemind_sim.hpp"

namespace dco::daemon {
namespace {

using testing::SimulatedIndemind;

float median_depth(const dco::client::FrameView& v, int x0, int y0, int size) {
  std::vector<float> d;
  for (int y = y0; y < y0 + size; ++y)
    for (int x = x0; x < x0 + size; ++x) d.push_back(v.depth_row(static_cast<std::uint32_t>(y))[x]);
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

struct Seen {
  int status = -1;
  std::uint32_t width = 0;
  float box = 0, wall = 0;
  long frames = 0;
  std::string client_error;
};

// Runs the daemon on `source` until it exits, reading depth from its ring meanwhile; `after` runs
// before the daemon (and the source it opened) is destroyed.
Seen run_daemon(const std::string& source, std::vector<std::string> sets,
                const Daemon::SourceOpener& opener, const std::function<void()>& after = {},
                const std::optional<std::filesystem::path>& config_file = {}) {
  block_service_signals();  // as dcod's main does, before any thread starts

  const auto dir =
      std::filesystem::temp_directory_path() / ("dco_daemon_indemind_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string ring = (dir / "depth.shm").string();
  ConfigSources sources;
  sources.sets = {"lcm.url=memq://", "ring.path=" + ring, "stereo.max_disparity=64"};
  sources.sets.insert(sources.sets.end(), sets.begin(), sets.end());
  sources.source = source;
  sources.file = config_file;
  LoadedConfig config = load_config(sources);
  Logger log;
  Daemon daemon(sources, std::move(config), log, opener);

  std::atomic<bool> done{false};
  Seen seen;
  std::thread client([&] {
    try {
      while (!done && !std::filesystem::exists(ring))
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      dco::client::Options options;
      options.path = ring;
      dco::client::Client c(options);
      for (int i = 0; i < 400 && !done; ++i) {
        auto v = c.wait_next(std::chrono::milliseconds(50));
        if (!v) continue;
        // Rectified 640x400 with f = 250 px: the box (0.9 m) covers the centre, the wall (3 m) the
        // upper left.
        const float b = median_depth(*v, 290, 195, 20), w = median_depth(*v, 60, 60, 20);
        const std::uint32_t width = v->info().width;
        if (c.still_valid(*v)) {
          seen.width = width;
          seen.box = b;
          seen.wall = w;
          ++seen.frames;
        }
      }
    } catch (const std::exception& e) {
      // The client ends with "writer stopped" when the daemon closes the ring.
      seen.client_error = e.what();
    }
  });
  seen.status = daemon.run();
  done = true;
  client.join();
  if (after) after();
  std::filesystem::remove_all(dir);
  return seen;
}

TEST(DaemonIndemind, SimulatedModuleDeliversDepthEndToEnd) {
  SimulatedIndemind* sim = nullptr;
  std::uint64_t flash_writes = 1;
  const Seen seen = run_daemon(
      "indemind://", {"service.max_frames=12"},
      [&](std::string_view uri) {
        SimulatedIndemind::Options o;
        o.pace_real_time = true;  // capture times on CLOCK_MONOTONIC, as from the real module
        auto owned = std::make_unique<SimulatedIndemind>(o);
        sim = owned.get();
        drivers::IndemindOptions io;
        io.fps = 25;
        io.clock = [s = sim] { return s->now_ns(); };
        return drivers::open_indemind(std::move(owned), io, std::string(uri));
      },
      [&] {
        ASSERT_NE(sim, nullptr);
        flash_writes = sim->record().flash_writes;
      });
  EXPECT_EQ(seen.status, 0);
  EXPECT_EQ(seen.width, 640u) << seen.client_error;
  EXPECT_NEAR(seen.box, SimulatedIndemind::kBoxDepthM, 0.1 * SimulatedIndemind::kBoxDepthM);
  EXPECT_NEAR(seen.wall, SimulatedIndemind::kWallDepthM, 0.2 * SimulatedIndemind::kWallDepthM);
  EXPECT_EQ(flash_writes, 0u);
}

// The daemon on a simulated module streaming in real time at 25 fps; once the module has sent ten
// whole frames, `action` runs on a thread of its own (a replug, a reload). The thread is joined
// while the module lives (the daemon owns it), and at the latest on the way out. dcod's log and
// the streams the module committed come back with what the client saw.
struct ModuleRun {
  Seen seen;
  std::string log;
  std::uint64_t commits = 0;
  bool acted = false;
};

ModuleRun run_with_module_action(const std::vector<std::string>& sets,
                                 const std::function<void(SimulatedIndemind&)>& action,
                                 const std::optional<std::filesystem::path>& config = {}) {
  block_service_signals();  // before the action's thread, so a SIGHUP reaches the daemon only
  std::atomic<SimulatedIndemind*> sim{nullptr};
  std::atomic<bool> quit{false}, acted{false};
  std::thread actor;
  const auto stop_actor = [&] {
    quit = true;
    if (actor.joinable()) actor.join();
  };
  struct Join {
    std::function<void()> f;
    ~Join() { f(); }
  } join_on_exit{stop_actor};
  ModuleRun run;
  ::testing::internal::CaptureStderr();
  run.seen = run_daemon(
      "indemind://", sets,
      [&](std::string_view uri) {
        SimulatedIndemind::Options o;
        o.pace_real_time = true;
        auto owned = std::make_unique<SimulatedIndemind>(o);
        sim = owned.get();
        drivers::IndemindOptions io;
        io.fps = 25;
        io.clock = [s = owned.get()] { return s->now_ns(); };
        auto source = drivers::open_indemind(std::move(owned), io, std::string(uri));
        actor = std::thread([s = sim.load(), &quit, &acted, &action] {
          while (!quit && s->record().frames_intact < 10)
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
          if (quit) return;
          action(*s);
          acted = true;
        });
        return source;
      },
      [&] {
        stop_actor();
        if (sim.load() != nullptr) run.commits = sim.load()->record().commits;
      },
      config);
  run.log = ::testing::internal::GetCapturedStderr();
  run.acted = acted;
  return run;
}

// A replug is a gap in the camera's frames: dcod finishes the frames before it and starts a new
// sequence, and says so. In deterministic mode, where dcod's own pace holds the camera up and
// makes gaps of its own, the frames run on as one sequence.
TEST(DaemonIndemind, AReplugStartsANewSequenceUnlessDeterministic) {
  for (const bool deterministic : {false, true}) {
    SCOPED_TRACE(deterministic);
    // The cable out for half a second.
    const ModuleRun run =
        run_with_module_action({"service.max_frames=30", std::string("runtime.deterministic=") +
                                                             (deterministic ? "true" : "false")},
                               [](SimulatedIndemind& s) {
                                 s.set_present(false);
                                 std::this_thread::sleep_for(std::chrono::milliseconds(500));
                                 s.set_present(true);
                               });
    EXPECT_EQ(run.seen.status, 0) << run.log;
    EXPECT_TRUE(run.acted);
    const bool cut =
        run.log.find("gap(s) in the camera's frames since the last report") != std::string::npos;
    EXPECT_EQ(cut, !deterministic) << run.log;
    EXPECT_GE(run.seen.frames, 10) << run.seen.client_error;
  }
}

// A reload that restarts the stage threads keeps the camera streaming: the module's stream is
// committed once, not stopped and negotiated afresh, and depth flows on after the reload.
TEST(DaemonIndemind, AReloadThatRestartsTheStagesKeepsTheCameraStreaming) {
  const auto config = std::filesystem::temp_directory_path() /
                      ("dco_daemon_reload_" + std::to_string(getpid()) + ".toml");
  std::ofstream(config) << "[densify]\nlambda_s = 1.2\n";
  // A new densify.lambda_s, then a reload.
  const ModuleRun run = run_with_module_action(
      {"service.max_frames=30"},
      [&](SimulatedIndemind&) {
        std::ofstream(config) << "[densify]\nlambda_s = 1.3\n";
        kill(getpid(), SIGHUP);
      },
      config);
  std::filesystem::remove(config);
  EXPECT_EQ(run.seen.status, 0) << run.log;
  EXPECT_TRUE(run.acted);
  EXPECT_NE(run.log.find("restarted the pipeline for densify.lambda_s"), std::string::npos)
      << run.log;
  EXPECT_EQ(run.commits, 1u);
  EXPECT_GE(run.seen.frames, 10) << run.seen.client_error;
}

TEST(DaemonIndemind, RecordedUsbCaptureReplaysThroughTheDaemon) {
  // Two seconds of the simulated module at 25 fps, recorded at the transport seam.
  const std::string capture = (std::filesystem::temp_directory_path() /
                               ("dco_daemon_capture_" + std::to_string(getpid()) + ".usbcap"))
                                  .string();
  {
    auto owned = std::make_unique<SimulatedIndemind>();
    SimulatedIndemind* sim = owned.get();
    drivers::IndemindOptions io;
    io.fps = 25;
    io.clock = [sim] { return sim->now_ns(); };
    auto source = drivers::open_indemind(
        drivers::make_recording_transport(std::move(owned), capture, io.clock), io, "indemind://");
    struct Count final : drivers::FrameSink {
      std::atomic<int> n{0};
      void on_frame(const drivers::StereoFrame&) override { ++n; }
      void on_end() override {}
      void on_error(const std::string&) override {}
    } sink;
    source->start(sink);
    while (sim->record().frames_intact < 50)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    source->stop();
  }
  // dcod's own URI, no simulator: every recorded frame goes through the pipeline, then dcod exits.
  const Seen seen = run_daemon("indemind://?fps=25&replay=" + capture,
                               {"runtime.deterministic=true"}, drivers::open_source);
  std::filesystem::remove(capture);
  EXPECT_EQ(seen.status, 0);
  EXPECT_EQ(seen.width, 640u) << seen.client_error;
  EXPECT_GE(seen.frames, 10);
  EXPECT_NEAR(seen.box, SimulatedIndemind::kBoxDepthM, 0.1 * SimulatedIndemind::kBoxDepthM);
  EXPECT_NEAR(seen.wall, SimulatedIndemind::kWallDepthM, 0.2 * SimulatedIndemind::kWallDepthM);
}

}  // namespace
}  // namespace dco::daemon
