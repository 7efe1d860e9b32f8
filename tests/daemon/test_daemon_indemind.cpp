// dcod's daemon with the INDEMIND driver on a simulated module: depth from the camera's own
// fisheye calibration reaches a client through the ring, and DCO_STATUS-bound state comes from the
// driver.

#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <thread>
#include <vector>

#include "dco/client.hpp"
#include "dco/daemon/daemon.hpp"
#include "dco/drivers/indemind_source.hpp"
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

TEST(DaemonIndemind, SimulatedModuleDeliversDepthEndToEnd) {
  // The daemon reads SIGTERM/SIGINT/SIGHUP from a signalfd: block them before any thread starts.
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGTERM);
  sigaddset(&mask, SIGINT);
  sigaddset(&mask, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &mask, nullptr);

  const auto dir =
      std::filesystem::temp_directory_path() / ("dco_daemon_indemind_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string ring = (dir / "depth.shm").string();
  ConfigSources sources;
  sources.sets = {"lcm.url=memq://", "ring.path=" + ring, "service.max_frames=12",
                  "stereo.max_disparity=64"};
  sources.source = "indemind://";
  LoadedConfig config = load_config(sources);
  Logger log;

  drivers::SourceStatus seen_status;
  SimulatedIndemind* sim = nullptr;
  Daemon daemon(sources, std::move(config), log, [&](std::string_view uri) {
    SimulatedIndemind::Options o;
    o.pace_real_time = true;  // capture times on CLOCK_MONOTONIC, as from the real module
    auto owned = std::make_unique<SimulatedIndemind>(o);
    sim = owned.get();
    drivers::IndemindOptions io;
    io.fps = 25;
    io.clock = [s = sim] { return s->now_ns(); };
    return drivers::open_indemind(std::move(owned), io, std::string(uri));
  });

  std::atomic<bool> done{false};
  float box = 0, wall = 0;
  std::uint32_t width = 0;
  std::string client_error;
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
        width = v->info().width;
        // Rectified 640x400 with f = 250 px: the box (0.9 m) covers the centre, the wall (3 m) the
        // upper left.
        const float b = median_depth(*v, 290, 195, 20), w = median_depth(*v, 60, 60, 20);
        if (c.still_valid(*v)) {
          box = b;
          wall = w;
        }
      }
    } catch (const std::exception& e) {
      client_error = e.what();
    }
  });
  const int status = daemon.run();
  done = true;
  client.join();
  EXPECT_EQ(status, 0);
  // The client ends with "writer stopped" when the daemon closes the ring after max_frames.
  EXPECT_EQ(width, 640u) << client_error;
  EXPECT_NEAR(box, SimulatedIndemind::kBoxDepthM, 0.1 * SimulatedIndemind::kBoxDepthM);
  EXPECT_NEAR(wall, SimulatedIndemind::kWallDepthM, 0.2 * SimulatedIndemind::kWallDepthM);
  ASSERT_NE(sim, nullptr);
  EXPECT_EQ(sim->record().flash_writes, 0u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dco::daemon
