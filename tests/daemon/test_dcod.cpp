#include <sys/stat.h>

#include <map>
#include <regex>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "dco/client.hpp"
#include "dco/core/calibration.hpp"
#include "dco/core/depth_conversion.hpp"
#include "dco/core/disparity_io.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/drivers/lcm_log.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "dcod_process.hpp"
#include "support/one_cpu.hpp"
#include "support/stalled_tcpq_peer.hpp"
#include "support/synthetic_recording.hpp"
#include "support/temp_dir.hpp"
#include "support/thread_names.hpp"

namespace dco::testing {
namespace {

using namespace std::chrono_literals;

// A small, fast scene so the tests spend their time on the lifecycle, not on stereo.
std::vector<std::string> base_args(const TempDir& dir, const std::string& source) {
  return {"--source",        source,  "--set",
          "lcm.url=memq://", "--set", "ring.path=" + (dir.path() / "depth.shm").string()};
}
const std::string kScene = "synthetic://hand?width=160&height=96&fps=30";

// dcod on the small scene with `config` as its file, reporting to `notify`.
DcodOptions configured(const TempDir& dir, const std::filesystem::path& config,
                       NotifySocket& notify) {
  DcodOptions o;
  o.args = base_args(dir, kScene);
  o.args.insert(o.args.end(), {"--config", config.string()});
  o.log = dir / "dcod.log";
  o.notify = &notify;
  return o;
}

// dcod on the small scene in a private network namespace, with LCM on udpm as on a headset.
DcodOptions on_udpm(const TempDir& dir, NotifySocket& notify) {
  DcodOptions o;
  o.args = {"--source", kScene,
            "--set",    "lcm.url=udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304",
            "--set",    "ring.path=" + (dir / "depth.shm").string()};
  o.log = dir / "dcod.log";
  o.notify = &notify;
  o.private_network = true;
  return o;
}

// SIGHUP, then RELOADING=1 and READY=1 again, as systemd sees a reload.
bool reloaded(DcodProcess& dcod, NotifySocket& notify) {
  const std::size_t before = notify.messages().size();
  dcod.signal(SIGHUP);
  return notify.wait_for("RELOADING=1", 5s, before) && notify.wait_for("READY=1", 5s, before);
}

dco::client::Client ring_client(const TempDir& dir) {
  dco::client::Options co;
  co.path = (dir / "depth.shm").string();
  return dco::client::Client(co);
}

TEST(Dcod, ReadyWatchdogPingsAndACleanStopOnSigterm) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = base_args(dir, kScene);
  o.log = dir / "dcod.log";
  o.notify = &notify;
  o.watchdog = 400ms;
  DcodProcess dcod(o);
  const auto ready = notify.wait_for("READY=1", 20s);
  ASSERT_TRUE(ready) << dcod.log();
  EXPECT_TRUE(std::filesystem::exists(dir / "depth.shm"));
  EXPECT_TRUE(notify.wait_for("STATUS=synthetic hand 160x96", 3s));
  // The stage threads runtime.threads = 0 chose, and why.
  EXPECT_NE(dcod.log().find(" stage thread(s) (runtime.threads = 0, "), std::string::npos)
      << dcod.log();
  // Pings at a quarter of the period while frames flow.
  const std::size_t before = notify.messages().size();
  std::this_thread::sleep_for(1000ms);
  EXPECT_GE(notify.count("WATCHDOG=1", before), 5) << dcod.log();

  dco::client::Options co;
  co.path = (dir / "depth.shm").string();
  dco::client::Client client(co);
  const auto frame = client.wait_next(2s);
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->info().width, 160u);
  EXPECT_EQ(frame->info().image_channels, 1u);
  // Its threads say what they run (top -H, perf, gdb).
  const std::vector<std::string> names = thread_names(dcod.pid());
  for (const char* name : {"dco-source", "dco-stereo", "dco-contour"})
    EXPECT_EQ(count_named(names, name), 1) << name;

  const auto term = SteadyClock::now();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
  EXPECT_LT(SteadyClock::now() - term, 1s) << "SIGTERM must stop dcod within a second";
  EXPECT_TRUE(notify.wait_for("STOPPING=1", 100ms));
  EXPECT_FALSE(std::filesystem::exists(dir / "depth.shm")) << "the ring is removed on stop";
  EXPECT_NE(dcod.log().find("stopping on SIGTERM"), std::string::npos) << dcod.log();
}

TEST(Dcod, LogsHowItCorrectsTheRightCamera) {
  // A right camera 15 % brighter with 4 levels more black, whose rows lie 0.75 below the left's,
  // turned 0.4 degrees: its levels are matched as (v - 4) / 1.15 = 0.870 v - 3.5.
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = base_args(dir,
                     "synthetic://boxes?width=320&height=180&fps=30&right_gain=1.15&"
                     "right_offset=4&right_rows=0.75&right_roll_deg=0.4");
  o.log = dir / "dcod.log";
  o.notify = &notify;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  const auto until = SteadyClock::now() + 10s;
  while (dcod.log().find("camera alignment: ") == std::string::npos && SteadyClock::now() < until)
    std::this_thread::sleep_for(50ms);
  const std::string log = dcod.log();
  // 0.88 v - 5.0 at 320x180 with the rows apart: the same levels within one over the middle.
  EXPECT_NE(log.find("camera alignment: right camera levels 0.8"), std::string::npos) << log;
  EXPECT_NE(log.find(", rows +0."), std::string::npos) << log;  // found 0.75 to 1/8 row
  const std::size_t roll = log.find(", roll ");
  ASSERT_NE(roll, std::string::npos) << log;
  EXPECT_NEAR(std::stod(log.substr(roll + 7)), 0.4, 0.03) << log;  // degrees
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

TEST(Dcod, AStalledSourceStopsTheWatchdogPings) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = base_args(dir, "synthetic://hand?width=160&height=96&fps=30&stall_after=15");
  o.args.insert(o.args.end(), {"--set", "service.stall_timeout_s=0.5"});
  o.log = dir / "dcod.log";
  o.notify = &notify;
  o.watchdog = 400ms;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  // 15 frames at 30 fps, then the camera hangs: after the stall timeout no more pings.
  ASSERT_TRUE(notify.wait_for("STALLED", 5s)) << dcod.log();
  const std::size_t stalled = notify.messages().size();
  std::this_thread::sleep_for(1500ms);
  EXPECT_EQ(notify.count("WATCHDOG=1", stalled), 0) << dcod.log();
  EXPECT_GE(notify.count("WATCHDOG=1", 0, stalled), 2) << "it pinged while frames flowed";
  EXPECT_TRUE(dcod.running()) << "a stalled dcod waits for the service manager's verdict";
  EXPECT_NE(dcod.log().find("watchdog pings withheld"), std::string::npos) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// A reload that restarts the stages is no sign of life: a hung camera stays without pings.
TEST(Dcod, AReloadDoesNotRearmTheWatchdogOfAStalledSource) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n");
  DcodOptions o = configured(dir, config, notify);
  o.args = base_args(dir, "synthetic://hand?width=160&height=96&fps=30&stall_after=15");
  o.args.insert(o.args.end(),
                {"--config", config.string(), "--set", "service.stall_timeout_s=0.5"});
  o.watchdog = 400ms;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  ASSERT_TRUE(notify.wait_for("STALLED", 5s)) << dcod.log();
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  const std::size_t after = notify.messages().size();
  std::this_thread::sleep_for(1200ms);
  EXPECT_EQ(notify.count("WATCHDOG=1", after), 0) << dcod.log();
  EXPECT_EQ(dcod.log().find("frames flow again"), std::string::npos) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// What a reload changes live applies at once: a faster lcm.stats_hz does not wait out the slow
// one's period. And the status keeps counting the drops of the stages a reload replaced.
TEST(Dcod, AReloadKeepsTheCountsAndAppliesTheStatsRateAtOnce) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n[lcm]\nstats_hz = 2\n");
  DcodOptions o = configured(dir, config, notify);
  // As fast as the source renders: most frames are dropped at the entry.
  o.args = base_args(dir, "synthetic://hand?width=160&height=96&fps=0");
  o.args.insert(o.args.end(), {"--config", config.string()});
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  const auto dropped_in = [](const std::string& status) {
    const std::size_t at = status.find(" dropped (");
    if (at == std::string::npos) return -1L;
    const std::size_t begin = status.rfind(", ", at) + 2;
    return std::stol(status.substr(begin, at - begin));
  };
  const auto last_dropped = [&](std::size_t from) {
    long dropped = -1;
    const std::vector<Notification> m = notify.messages();
    for (std::size_t i = from; i < m.size(); ++i)
      if (m[i].text.find("STATUS=") != std::string::npos)
        dropped = std::max(dropped, dropped_in(m[i].text));
    return dropped;
  };
  ASSERT_TRUE(notify.collect(10s, [&](const auto&) { return last_dropped(0) > 20; })) << dcod.log();
  const long before = last_dropped(0);
  const auto status_lines = [&](std::size_t from) {
    long n = 0;
    const std::vector<Notification> m = notify.messages();
    for (std::size_t i = from; i < m.size(); ++i) n += m[i].text.rfind("STATUS=", 0) == 0;
    return n;
  };
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n[lcm]\nstats_hz = 0.1\n");
  const std::size_t slow = notify.messages().size();
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  // The status READY=1 carries right after the restart counts the replaced stages' drops.
  const std::vector<Notification> m = notify.messages();
  for (std::size_t i = slow; i < m.size(); ++i)
    if (m[i].text.rfind("READY=1", 0) == 0) {
      EXPECT_GE(dropped_in(m[i].text), before) << m[i].text;
    }
  // One more status at the old rate arms the slow period.
  ASSERT_TRUE(notify.collect(3s, [&](const auto&) { return status_lines(slow) >= 1; }))
      << dcod.log();
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n[lcm]\nstats_hz = 10\n");
  const std::size_t fast = notify.messages().size();
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  // READY=1 carries a status too; the stats' own STATUS lines follow at 10 Hz.
  ASSERT_TRUE(notify.collect(3s, [&](const auto&) { return status_lines(fast) >= 3; }))
      << "the 0.1 Hz period was waited out\n"
      << dcod.log();
  EXPECT_GE(last_dropped(fast), before) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// The recording's totals name every pair it did not send, not only those it dropped.
TEST(Dcod, RawRecordingTotalsCountThePairsTooLargeToSend) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = base_args(dir, "synthetic://hand?width=640&height=360&fps=30&frames=6");
  o.args.insert(o.args.end(), {"--set", "raw.enabled=true", "--set", "raw.max_message_bytes=65536",
                               "--set", "runtime.deterministic=true"});
  o.log = dir / "dcod.log";
  o.notify = &notify;
  DcodProcess dcod(o);
  ASSERT_EQ(dcod.wait(30s), 0) << dcod.log();
  EXPECT_NE(dcod.log().find("raw recording: 0 pairs on DCO_RAW, 0 dropped, 6 larger than "
                            "raw.max_message_bytes, 0 failed to encode or send"),
            std::string::npos)
      << dcod.log();
}

// A reload asked for together with a stop is not carried out: the stop comes first.
TEST(Dcod, ASighupThatCameWithASigtermDoesNotReload) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n");
  // Both pending at once when it runs again, as when a reload and a stop come close together.
  dcod.signal(SIGSTOP);
  std::this_thread::sleep_for(100ms);
  dcod.signal(SIGHUP);
  dcod.signal(SIGTERM);
  dcod.signal(SIGCONT);
  EXPECT_EQ(dcod.wait(5s), 0) << dcod.log();
  EXPECT_NE(dcod.log().find("stopping on SIGTERM"), std::string::npos) << dcod.log();
  EXPECT_EQ(dcod.log().find("restarted the pipeline"), std::string::npos) << dcod.log();
}

TEST(Dcod, SighupReloadsWhatItCanAndNamesTheRest) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n[lcm]\npreview_hz = 2\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(2s));

  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n[lcm]\npreview_hz = 5\n[ring]\nslots = 6\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  const std::string log = dcod.log();
  EXPECT_NE(log.find("applied lcm.preview_hz"), std::string::npos) << log;
  EXPECT_NE(log.find("restarted the pipeline for densify.lambda_s"), std::string::npos) << log;
  EXPECT_NE(log.find("need a restart of dcod: ring.slots"), std::string::npos) << log;
  // Frames flow again after the pipeline restart, into the same ring session.
  const std::uint64_t session = client.session_id();
  const auto after = client.wait_next(3s);
  ASSERT_TRUE(after.has_value()) << dcod.log();
  EXPECT_EQ(after->info().session_id, session);

  // A broken file leaves the running configuration in place.
  dir.write("dcod.toml", "[densify]\nlambda_s = -1\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();  // a refused file is answered with READY too
  EXPECT_NE(dcod.log().find("reload failed, the running configuration stays"), std::string::npos)
      << dcod.log();
  EXPECT_TRUE(client.wait_next(3s).has_value());
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// A reload that restarts the stages finishes the frames they hold first: a deterministic run
// publishes every frame of its source through two reloads.
TEST(Dcod, AReloadLosesNoFrame) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  constexpr int kFrames = 2000;
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n");
  DcodOptions o = configured(dir, config, notify);
  o.args = base_args(
      dir, "synthetic://hand?width=160&height=96&fps=0&frames=" + std::to_string(kFrames));
  o.args.insert(o.args.end(), {"--config", config.string(), "--set", "runtime.deterministic=true"});
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  for (const char* lambda : {"2", "1.5"}) {
    dir.write("dcod.toml", std::string("[densify]\nlambda_s = ") + lambda + "\n");
    ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  }
  // 2000 frames take 6 s in a release build, 35 s under ASan alone, and more beside another test.
  EXPECT_EQ(dcod.wait(180s), 0) << dcod.log();
  const std::string log = dcod.log();
  std::size_t restarts = 0;
  for (std::size_t at = 0;
       (at = log.find("restarted the pipeline for densify.lambda_s", at)) != std::string::npos;
       ++at)
    ++restarts;
  ASSERT_EQ(restarts, 2u) << "both reloads came before the source's end\n" << log;
  EXPECT_NE(log.find("the source ended after " + std::to_string(kFrames) + " published frames"),
            std::string::npos)
      << log;
}

TEST(Dcod, AReloadWhoseStagesCannotStartKeepsTheRunningConfiguration) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[densify]\nlambda_s = 1.2\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(2s));

  // A CPU number the checks accept (below CPU_SETSIZE) that no machine here has: only starting
  // the stage threads finds out.
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n[runtime]\naffinity = \"1000\"\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("reload failed, the running configuration stays: restarting the "
                            "pipeline: runtime.affinity: cannot run a stage thread on CPU 1000"),
            std::string::npos)
      << dcod.log();
  const auto after = client.wait_next(3s);
  ASSERT_TRUE(after.has_value()) << dcod.log();
  EXPECT_TRUE(dcod.running());

  // The next good reload compares against what runs: lambda_s = 2 is a change again.
  dir.write("dcod.toml", "[densify]\nlambda_s = 2\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("restarted the pipeline for densify.lambda_s"), std::string::npos)
      << dcod.log();
  EXPECT_TRUE(client.wait_next(3s).has_value());
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// Limits that depend on the frame size (max disparity below the width, the census window, DIS)
// are checked against the source's size before a reload stops anything: such a value would
// otherwise fail the first frame of the new stages and end dcod.
TEST(Dcod, AReloadTooLargeForTheFramesKeepsWhatRuns) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[stereo]\nmax_disparity = 20\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(2s));

  dir.write("dcod.toml", "[stereo]\nmax_disparity = 500\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("reload failed, the running configuration stays: the source's "
                            "160x96 frames: stereo: max disparity 500 must be smaller than the "
                            "image width 160"),
            std::string::npos)
      << dcod.log();
  EXPECT_EQ(dcod.log().find("restarted the pipeline"), std::string::npos) << dcod.log();
  // Frames keep coming, well past the first frame a restarted pipeline would have failed on.
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(client.wait_next(3s).has_value()) << dcod.log();
  EXPECT_TRUE(dcod.running());

  // The next good reload compares against what runs.
  dir.write("dcod.toml", "[stereo]\nmax_disparity = 24\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("restarted the pipeline for stereo.max_disparity"), std::string::npos)
      << dcod.log();
  EXPECT_TRUE(client.wait_next(3s).has_value());
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
}

// The same limits at the start: refused before the source streams, with the source's size.
TEST(Dcod, StagesTooLargeForTheFramesAreRefusedAtTheStart) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[stereo]\nmax_disparity = 500\n");
  DcodProcess dcod(configured(dir, config, notify));
  EXPECT_EQ(dcod.wait(20s), 1) << dcod.log();
  EXPECT_NE(dcod.log().find("the source's 160x96 frames: stereo: max disparity 500 must be "
                            "smaller than the image width 160"),
            std::string::npos)
      << dcod.log();
  EXPECT_EQ(dcod.log().find("published frames"), std::string::npos) << dcod.log();
  EXPECT_FALSE(notify.wait_for("READY=1", 100ms));
}

// OpenCV's thread count is the process's and the source's thread may be in an OpenCV loop when
// the stages restart (changing the count under it crashes OpenCV): a reload keeps it, names
// runtime.opencv_threads as needing a restart, and says so when new stage threads would have had
// another count.
TEST(Dcod, AReloadKeepsOpenCvsThreadCountAndSaysSo) {
  const CpuScope two(2);
  if (!two.ok()) GTEST_SKIP() << "fewer than two CPUs";
  TempDir dir;
  NotifySocket notify(dir / "notify");
  // One stage thread on two CPUs: OpenCV keeps its own count.
  const auto config = dir.write("dcod.toml", "[runtime]\nthreads = 1\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(3s)) << dcod.log();

  // Two stage threads fill both CPUs, where OpenCV would get one thread.
  dir.write("dcod.toml", "[runtime]\nthreads = 2\nopencv_threads = 3\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  const std::string log = dcod.log();
  EXPECT_NE(log.find("restarted the pipeline for runtime.threads"), std::string::npos) << log;
  EXPECT_NE(log.find("need a restart of dcod: runtime.opencv_threads"), std::string::npos) << log;
  EXPECT_NE(log.find("OpenCV keeps the "), std::string::npos) << log;
  EXPECT_NE(log.find("(these stages would have it use 1 now): its count changes only with a "
                     "restart of dcod"),
            std::string::npos)
      << log;
  EXPECT_TRUE(client.wait_next(3s).has_value()) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(5s), 0) << dcod.log();
}

// A reload that turns the raw recording on needs a thread: one the system refuses (a task limit
// reached) fails the reload, not dcod, and the running configuration stays.
TEST(Dcod, AReloadWhoseRecorderThreadIsRefusedKeepsTheRunningConfiguration) {
  // Root is exempt from the task limit: dcod runs as nobody, whose limit this test may set.
  if (geteuid() != 0) GTEST_SKIP() << "needs root to run dcod as another user";
  TempDir dir;
  std::filesystem::permissions(dir.path(), std::filesystem::perms::all);
  NotifySocket notify(dir / "notify");
  std::filesystem::permissions(notify.path(), std::filesystem::perms::all);
  const auto config = dir.write("dcod.toml", "[raw]\nenabled = false\n");
  std::filesystem::permissions(config, std::filesystem::perms::all);
  DcodOptions o = configured(dir, config, notify);
  o.prefix = {"setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"};
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Options co;
  co.path = (dir / "depth.shm").string();
  co.expected_uid = 65534;
  dco::client::Client client(co);
  ASSERT_TRUE(client.wait_next(3s)) << dcod.log();

  // No task more for dcod's user from now on: the soft limit, which its own user may set.
  const auto limit_tasks = [&](const std::string& soft) {
    const std::string pid = std::to_string(dcod.pid());
    return run_command("setpriv --reuid=65534 --regid=65534 --clear-groups sh -c 'prlimit --pid " +
                       pid + " --nproc=" + soft + ":' 2>&1");
  };
  const auto limited = limit_tasks("1");
  ASSERT_EQ(limited.status, 0) << limited.output;
  dir.write("dcod.toml", "[raw]\nenabled = true\n");
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("reload failed, the running configuration stays: raw recording: its "
                            "thread cannot start: "),
            std::string::npos)
      << dcod.log();
  EXPECT_EQ(dcod.log().find("recording raw pairs"), std::string::npos) << dcod.log();
  const std::uint64_t session = client.session_id();
  const auto after = client.wait_next(3s);
  ASSERT_TRUE(after.has_value()) << dcod.log();
  EXPECT_EQ(after->info().session_id, session);
  EXPECT_TRUE(dcod.running());

  // The next reload compares against what runs: raw.enabled = true is a change again.
  const auto unlimited = limit_tasks("$(prlimit --pid " + std::to_string(dcod.pid()) +
                                     " --nproc -o HARD --noheadings)");
  ASSERT_EQ(unlimited.status, 0) << unlimited.output;
  ASSERT_TRUE(reloaded(dcod, notify)) << dcod.log();
  EXPECT_NE(dcod.log().find("recording raw pairs"), std::string::npos) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(5s), 0) << dcod.log();
}

TEST(Dcod, AReloadThatLowersMaxFramesBelowThePublishedCountStopsCleanly) {
  TempDir dir;
  NotifySocket notify(dir / "notify");
  const auto config = dir.write("dcod.toml", "[service]\nmax_frames = 0\n");
  DcodProcess dcod(configured(dir, config, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  std::uint64_t index = 0;
  while (index < 6) {
    const auto frame = client.wait_next(3s);
    ASSERT_TRUE(frame.has_value()) << dcod.log();
    index = frame->info().publish_index;
  }
  dir.write("dcod.toml", "[service]\nmax_frames = 2\n");
  dcod.signal(SIGHUP);
  EXPECT_EQ(dcod.wait(5s), 0) << dcod.log();
  EXPECT_NE(dcod.log().find("(service.max_frames): stopping"), std::string::npos) << dcod.log();
}

// A headset that boots without a network has no multicast route on lo: LCM udpm cannot be set
// up, and depth must reach the ring's readers all the same; LCM follows once the route is there.
TEST(Dcod, StartsWithoutAMulticastRouteAndSetsLcmUpOnceThereIsOne) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  if (run_command("command -v nsenter").status != 0) GTEST_SKIP() << "no nsenter here";
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o = on_udpm(dir, notify);
  o.network_setup = "ip link set lo up";
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  client::Options co;
  co.path = (dir / "depth.shm").string();
  client::Client reader(co);
  EXPECT_TRUE(reader.wait_next(5s).has_value()) << "depth reaches the ring without LCM";
  EXPECT_NE(dcod.log().find("LCM cannot be set up"), std::string::npos) << dcod.log();
  const CommandResult route = run_command("nsenter -t " + std::to_string(dcod.pid()) +
                                          " -n ip route add 224.0.0.0/4 dev lo");
  ASSERT_EQ(route.status, 0) << route.output;
  const auto until = SteadyClock::now() + 10s;
  while (dcod.log().find("LCM is set up now") == std::string::npos && SteadyClock::now() < until)
    std::this_thread::sleep_for(50ms);
  EXPECT_NE(dcod.log().find("LCM is set up now"), std::string::npos) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
}

// Raw recording asked for on a headset without a network: the pairs are not compressed for
// nothing, and the fault is one warning, not one per statistics tick for as long as it lasts.
TEST(Dcod, RawRecordingWithoutANetworkIsOneWarningAndNoCompression) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o = on_udpm(dir, notify);
  o.network_setup = "ip link set lo up";
  o.args.insert(o.args.end(), {"--set", "raw.enabled=true", "--set", "lcm.stats_hz=10"});
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  std::this_thread::sleep_for(4s);
  const std::string running = dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
  const auto count = [](const std::string& log, const std::string& text) {
    long n = 0;
    for (std::size_t at = 0; (at = log.find(text, at)) != std::string::npos; ++at) ++n;
    return n;
  };
  EXPECT_EQ(count(running, "pairs not recorded"), 1) << running;
  EXPECT_LE(count(running, "LCM could not send"), 1) << running;
  EXPECT_NE(running.find("not compressed: LCM is not set up"), std::string::npos) << running;
}

// A file size limit (LimitFSIZE=, ulimit -f) makes a write past it an error the writer reports,
// not a SIGXFSZ that ends dcod and leaves a temporary ring behind.
TEST(Dcod, AFileSizeLimitIsAnErrorNotASignal) {
  TempDir dir;
  const CommandResult r =
      run_command("ulimit -f 16 && " + std::string(DCOD_EXE) + " --source '" + kScene +
                  "' --set lcm.url=memq:// --set ring.path=" + (dir / "depth.shm").string());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("depth.shm: ftruncate: File too large"), std::string::npos) << r.output;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    ADD_FAILURE() << "left behind: " << e.path();
}

// The README's configuration reference is what the code registers: every key there, none more,
// each described as `--print-config` (and `dco-depth --list-params`) describes it.
TEST(Dcod, PrintConfigHoldsTheReadmesReference) {
  std::ifstream readme(std::string(DCO_SOURCE_DIR) + "/README.md");
  ASSERT_TRUE(readme) << "README.md";
  const auto plain = [](std::string t) {
    t = std::regex_replace(t, std::regex(R"(\\\|)"), "|");
    t = std::regex_replace(t, std::regex("`"), "");
    return std::regex_replace(t, std::regex(R"(\s+)"), " ");
  };
  std::map<std::string, std::string> documented;
  const std::regex row(R"(^\| `([a-z_]+\.[a-z_0-9]+)` \| .*? \| .*? \| (.*) \|$)");
  for (std::string line; std::getline(readme, line);)
    if (std::smatch m; std::regex_match(line, m, row)) documented[m[1]] = plain(m[2]);
  const CommandResult r = run_command(std::string(DCOD_EXE) + " --print-config");
  ASSERT_EQ(r.status, 0) << r.output;
  std::map<std::string, std::string> registered;
  std::istringstream lines(r.output);
  std::string section, comment;
  const std::regex heading(R"(^\[(\w+)\]$)"), key(R"(^(\w+) = .*)"), range(R"( \([^()]*\)$)");
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_match(line, m, heading))
      section = m[1];
    else if (line.starts_with("# ") && !section.empty())
      comment = line.substr(2);
    else if (std::regex_match(line, m, key) && !section.empty())
      registered[section + "." + std::string(m[1])] = plain(std::regex_replace(comment, range, ""));
  }
  EXPECT_EQ(documented.size(), 99u);
  for (const auto& [k, text] : documented) {
    const auto it = registered.find(k);
    if (it == registered.end())
      ADD_FAILURE() << k << " is in the README, not in the code";
    else
      EXPECT_EQ(it->second, text) << k;
  }
  for (const auto& [k, text] : registered)
    EXPECT_TRUE(documented.contains(k)) << k << " is registered, not in the README";
}

TEST(Dcod, BadConfigurationsFailWithFileLineAndReason) {
  TempDir dir;
  const auto exe = std::string(DCOD_EXE);
  const auto file = dir.write("bad.toml", "[service]\nstall_timeout_s = 1\nmax_frame = 3\n");
  auto r = run_command(exe + " --config " + file.string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find(file.string() + ":3: unknown key 'service.max_frame'"), std::string::npos)
      << r.output;

  r = run_command(exe + " --set ring.slots=99");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--set ring.slots=99"), std::string::npos) << r.output;

  // A source URI or LCM URL that no build could open is a configuration error too, named by
  // where it came from.
  const auto bad_uri = dir.write("uri.toml", "[source]\nuri = \"bogus\"\n");
  r = run_command(exe + " --config " + bad_uri.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(bad_uri.string() + ": source 'bogus': expected scheme://"),
            std::string::npos)
      << r.output;
  r = run_command(exe + " --source ftp://cam");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("unknown scheme 'ftp'"), std::string::npos) << r.output;
  r = run_command(exe + " --source '" + kScene + "' --set lcm.url=nonsense://x");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("lcm.url 'nonsense://x'"), std::string::npos) << r.output;

  r = run_command(exe + " --frobnicate");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown argument '--frobnicate'"), std::string::npos) << r.output;

  // A camera that is not there is an error, never a silent fallback to another source.
  r = run_command(exe + " --source indemind:// --set lcm.url=memq:// --set ring.path=" +
                  (dir / "r.shm").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("indemind://"), std::string::npos) << r.output;
  // One clear line: no module here (or no USB at all in a bare container).
  EXPECT_TRUE(r.output.find("no INDEMIND module (USB 05a9:f581) found") != std::string::npos ||
              r.output.find("USB unavailable") != std::string::npos)
      << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "r.shm"));

  // Line breaks and terminal escapes in what a user typed stay out of the (one-line) messages.
  r = run_command(exe + " --set \"$(printf 'log.level=x\\ny')\"");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("\"x?y\" is not one of"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  r = run_command(exe + " \"$(printf -- '--frob\\033[2J')\"");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown argument '--frob?[2J'"), std::string::npos) << r.output;
  r = run_command(exe + " --source \"$(printf 'synthetic://hand?fps=3\\033[31m\\nX')\"" +
                  " --set lcm.url=memq:// --set ring.path=" + (dir / "u.shm").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("fps=3?[31m?X must be a number"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_EQ(r.output.find('\033'), std::string::npos) << r.output;

  r = run_command(exe + " --print-config --set service.max_frames=9");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("[service]"), std::string::npos);
  EXPECT_NE(r.output.find("max_frames = 9"), std::string::npos) << r.output;
}

TEST(Dcod, ThreeWatchClientsInAPrivateNetworkNamespace) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o = on_udpm(dir, notify);
  o.watchdog = 2s;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  std::vector<std::FILE*> watchers;
  for (int i = 0; i < 3; ++i) {
    const std::string cmd = std::string(DCO_WATCH_EXE) + " --path " + (dir / "depth.shm").string() +
                            " --frames 30 --interval-ms 400 --timeout-ms 5000 2>&1" +
                            (i == 1 ? " --overlay " + (dir / "overlay.ppm").string() : "") +
                            (i == 2 ? " --copy" : "");
    watchers.push_back(popen(cmd.c_str(), "r"));
  }
  std::string overlay_report;
  for (std::FILE* w : watchers) {
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, w) != nullptr) out += buf;
    if (w == watchers[1]) overlay_report = out;
    EXPECT_EQ(pclose(w), 0) << out;
    EXPECT_NE(out.find("fps"), std::string::npos) << out;
    EXPECT_NE(out.find("160x96"), std::string::npos) << out;
  }
  EXPECT_TRUE(dcod.running()) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();

  // The overlay: the hand (nearer than the virtual box at 1 m) cuts the box, the wall does not.
  std::ifstream ppm(dir / "overlay.ppm", std::ios::binary);
  std::string magic;
  int w = 0, h = 0, max = 0;
  ppm >> magic >> w >> h >> max;
  ppm.get();
  ASSERT_EQ(magic, "P6");
  ASSERT_EQ(w, 160);
  ASSERT_EQ(h, 96);
  std::vector<unsigned char> rgb(160 * 96 * 3);
  ppm.read(reinterpret_cast<char*>(rgb.data()), static_cast<std::streamsize>(rgb.size()));
  ASSERT_TRUE(ppm.good());
  // The picture is the last report's frame: compare it with that frame's true depth, away from
  // the box's depth where a pixel could go either way.
  std::smatch seq;
  std::string rest = overlay_report, last_seq;
  while (std::regex_search(rest, seq, std::regex("seq ([0-9]+)"))) {
    last_seq = seq[1];
    rest = seq.suffix();
  }
  ASSERT_FALSE(last_seq.empty()) << overlay_report;
  synthetic::SceneRenderer scene(synthetic::preset("hand", 160, 96));
  synthetic::StereoSample truth;
  scene.render(std::stoi(last_seq), truth);
  long hand = 0, hand_in_front = 0, wall = 0, wall_behind = 0;
  for (int y = 24; y < 72; ++y)
    for (int x = 40; x < 120; ++x) {
      const unsigned char* p = &rgb[static_cast<std::size_t>(y * 160 + x) * 3];
      const bool shows_camera = p[0] == p[1] && p[1] == p[2];
      // Interiors only: the hand's core (5x5, clear of the contour band that one frame's depth
      // can put either side) and the wall's 3x3.
      float nearest = 1e9f, farthest = 0;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const float d = truth.depth_m.at(x + dx, y + dy);
          if (std::abs(dx) <= 1 && std::abs(dy) <= 1) nearest = std::min(nearest, d);
          farthest = std::max(farthest, d);
        }
      if (farthest < 0.8f) {  // the hand, 0.45-0.56 m
        ++hand;
        hand_in_front += shows_camera;
      } else if (nearest > 1.5f) {  // the wall, 2.8 m
        ++wall;
        wall_behind += !shows_camera;
      }
    }
  ASSERT_GT(wall, 500);
  EXPECT_GE(wall_behind, wall * 95 / 100) << "the box covers what is behind it";
  // The hand's accuracy varies from frame to frame (the accuracy tests measure it); what matters
  // here is that the nearer surface cuts the box at all.
  if (hand > 30) {
    EXPECT_GE(hand_in_front, hand * 60 / 100) << "what is nearer cuts the box";
  }
}

// Depth of every frame dcod publishes into the ring at `ring`, by frame number, until `frames`
// arrived or three quiet seconds.
std::map<std::uint64_t, std::vector<float>> read_ring(const std::filesystem::path& ring, int frames,
                                                      int w, int h) {
  std::map<std::uint64_t, std::vector<float>> received;
  for (int i = 0; i < 2000 && !std::filesystem::exists(ring); ++i)
    std::this_thread::sleep_for(10ms);
  if (!std::filesystem::exists(ring)) return received;
  dco::client::Options co;
  co.path = ring.string();
  dco::client::Client client(co);
  while (received.size() < static_cast<std::size_t>(frames)) {
    const auto f = client.wait_next(3s);
    if (!f) break;
    std::vector<float> depth(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y)
      std::memcpy(&depth[static_cast<std::size_t>(y) * w],
                  f->depth_row(static_cast<std::uint32_t>(y)),
                  static_cast<std::size_t>(w) * sizeof(float));
    if (client.still_valid(*f)) received[f->info().frame_seq] = std::move(depth);
  }
  return received;
}

// The headset's network goes away (Wi-Fi off): LCM can no longer send, and depth keeps reaching
// the ring's readers, with a warning instead of an exit.
TEST(Dcod, LostLcmNetworkIsAWarningAndTheRingGoesOn) {
  if (geteuid() != 0) GTEST_SKIP() << "nsenter into dcod's network namespace needs root";
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodProcess dcod(on_udpm(dir, notify));
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(2s)) << dcod.log();
  const auto route = run_command("nsenter -t " + std::to_string(dcod.pid()) +
                                 " -n ip route del 224.0.0.0/4 dev lo");
  ASSERT_EQ(route.status, 0) << route.output;
  for (int i = 0; i < 60 && dcod.log().find("LCM could not send") == std::string::npos; ++i)
    std::this_thread::sleep_for(50ms);
  EXPECT_NE(dcod.log().find("depth still reaches the ring's readers"), std::string::npos)
      << dcod.log();
  std::uint64_t last = 0;
  for (int i = 0; i < 5; ++i) {
    const auto frame = client.wait_next(2s);
    ASSERT_TRUE(frame.has_value()) << dcod.log();
    EXPECT_GT(frame->info().publish_index, last);
    last = frame->info().publish_index;
  }
  EXPECT_TRUE(dcod.running()) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(3s), 0) << dcod.log();
  // The messages lost after the first warning are reported as dcod stops.
  const std::string log = dcod.log();
  std::size_t warnings = 0;
  for (std::size_t at = 0; (at = log.find("LCM could not send", at)) != std::string::npos; ++at)
    ++warnings;
  EXPECT_GE(warnings, 2u) << log;
}

// LCM over TCP to a peer that stopped reading (or a link gone dead), while raw pairs are
// recorded: depth keeps reaching the ring, the watchdog keeps being fed and SIGTERM still stops
// dcod. Every LCM send blocks there, so none may be made on the way into the ring.
TEST(Dcod, AnLcmPeerThatStopsReadingHoldsUpNeitherTheRingNorAStop) {
  StalledTcpqPeer peer;
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = {"--source", "synthetic://hand?width=320&height=192&fps=30",
            "--set",    "lcm.url=" + peer.url(),
            "--set",    "ring.path=" + (dir / "depth.shm").string(),
            "--set",    "raw.enabled=true",
            "--set",    "raw.png_level=0"};
  o.log = dir / "dcod.log";
  o.notify = &notify;
  o.watchdog = 800ms;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Client client = ring_client(dir);
  // Uncompressed pairs of 320x192 fill both sockets' buffers within a second or two.
  std::this_thread::sleep_for(3s);
  const std::size_t before = notify.messages().size();
  std::uint64_t last = 0;
  int frames = 0;
  for (const auto end = SteadyClock::now() + 2s; SteadyClock::now() < end;) {
    const auto frame = client.wait_next(1s);
    ASSERT_TRUE(frame.has_value()) << dcod.log();
    EXPECT_GT(frame->info().publish_index, last);
    last = frame->info().publish_index;
    ++frames;
  }
  EXPECT_GE(frames, 4) << dcod.log();  // 2 fps: an ASan build beside another test is slow
  EXPECT_GE(notify.count("WATCHDOG=1", before), 4) << dcod.log();
  const auto term = SteadyClock::now();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
  EXPECT_LT(SteadyClock::now() - term, 5s) << dcod.log();
  EXPECT_NE(dcod.log().find("not compressed: LCM is not set up, or its network holds a send"),
            std::string::npos)
      << dcod.log();
}

// A tcpq server that accepts and hangs: dcod starts and serves the ring without LCM, and takes
// LCM up once the server answers.
TEST(Dcod, AnLcmServerThatDoesNotAnswerHoldsUpNeitherTheStartNorTheRing) {
  StalledTcpqPeer peer(StalledTcpqPeer::Handshake::kSilent);
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = {"--source", "synthetic://hand?width=160&height=96&fps=30",
            "--set",    "lcm.url=" + peer.url(),
            "--set",    "ring.path=" + (dir / "depth.shm").string()};
  o.log = dir / "dcod.log";
  o.notify = &notify;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  EXPECT_NE(dcod.log().find("has not ended"), std::string::npos) << dcod.log();
  dco::client::Client client = ring_client(dir);
  ASSERT_TRUE(client.wait_next(5s).has_value()) << dcod.log();
  peer.answer();
  bool set_up = false;
  for (const auto end = SteadyClock::now() + 10s; !set_up && SteadyClock::now() < end;) {
    std::this_thread::sleep_for(50ms);
    set_up = dcod.log().find("LCM is set up now") != std::string::npos;
  }
  EXPECT_TRUE(set_up) << dcod.log();
  ASSERT_TRUE(client.wait_next(5s).has_value()) << dcod.log();
  dcod.signal(SIGTERM);
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
}

TEST(Dcod, ReplayInDeterministicModeIsBitIdenticalToDcoDepth) {
  TempDir dir;
  constexpr int kFrames = 6;
  const auto rec = dir / "rec";
  write_synthetic_recording(rec, kFrames, 160, 96);
  const auto offline = dir / "offline";
  const auto r = run_command(
      std::string(DCO_DEPTH_EXE) + " --left-pattern " + (rec / "left" / "%06d.png").string() +
      " --right-pattern " + (rec / "right" / "%06d.png").string() + " --calib " +
      (rec / "calib.toml").string() + " --max-disp 40 --out-dir " + offline.string());
  ASSERT_EQ(r.status, 0) << r.output;

  DcodOptions o;
  o.args = base_args(dir, "replay://" + rec.string() + "?fps=6");
  o.args.insert(o.args.end(),
                {"--set", "runtime.deterministic=true", "--set", "stereo.max_disparity=40"});
  o.log = dir / "dcod.log";
  DcodProcess dcod(o);
  const auto ring = dir / "depth.shm";
  for (int i = 0; i < 400 && !std::filesystem::exists(ring) && dcod.running(); ++i)
    std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(std::filesystem::exists(ring)) << dcod.log();
  auto received = read_ring(ring, kFrames, 160, 96);
  EXPECT_EQ(dcod.wait(10s), 0) << "a replay without loop ends cleanly\n" << dcod.log();
  ASSERT_EQ(received.size(), static_cast<std::size_t>(kFrames)) << dcod.log();

  const RectifiedGeometry geometry = load_calibration(rec / "calib.toml").rectified;
  for (int i = 0; i < kFrames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.pfm", i);
    const Image<float> disparity = read_pfm(offline / name);
    Image<float> expected(disparity.width(), disparity.height());
    disparity_to_depth(disparity.cview(), geometry, expected.view());
    const std::vector<float>& got = received[static_cast<std::uint64_t>(i)];
    long differing = 0;
    for (int y = 0; y < 96; ++y)
      differing += std::memcmp(&got[static_cast<std::size_t>(y) * 160], expected.row(y),
                               160 * sizeof(float)) != 0;
    EXPECT_EQ(differing, 0) << "frame " << i << ": rows that differ from dco-depth";
  }
}

TEST(Dcod, AReleaseLatencyPublishesEveryFrameAtItsCaptureTimePlusThatLatency) {
  TempDir dir;
  DcodOptions o;
  o.args = base_args(dir, "synthetic://hand?width=160&height=96&fps=15&frames=24");
  // The latency must sit above the slowest frame's stages (docs: above the pipeline's p99), here
  // also under the sanitizers with other tests running beside this one, and within the results
  // the release thread holds (4 at 15 fps: up to about 4 x 67 ms after the stages).
  o.args.insert(o.args.end(), {"--set", "runtime.release_latency_ms=240"});
  o.log = dir / "dcod.log";
  NotifySocket notify(dir / "notify");
  o.notify = &notify;
  DcodProcess dcod(o);
  // The status line tells what the stages took, which the fixed latency hides.
  EXPECT_TRUE(notify.wait_for(" early)", 10s)) << dcod.log();
  const auto ring = dir / "depth.shm";
  for (int i = 0; i < 2000 && !std::filesystem::exists(ring); ++i)
    std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(std::filesystem::exists(ring)) << dcod.log();
  dco::client::Options co;
  co.path = ring.string();
  dco::client::Client client(co);
  std::vector<double> age_ms;  // the ring's publish time - the camera's capture time
  try {
    while (const auto f = client.wait_next(3s))
      age_ms.push_back(static_cast<double>(f->info().publish_ns - f->info().capture_ns) * 1e-6);
  } catch (const dco::client::Error& e) {  // the end of the sequence: dcod exits
    EXPECT_EQ(e.status(), DCO_E_WRITER_GONE) << e.what();
  }
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
  ASSERT_GE(age_ms.size(), 12u) << dcod.log();
  std::sort(age_ms.begin(), age_ms.end());
  // Never before its time, and all at one age: the stages' own times vary far more than this.
  // One release may wake a scheduler slice late when the sanitizer suite loads both CPUs.
  EXPECT_GE(age_ms.front(), 240.0);
  EXPECT_LT(age_ms[age_ms.size() - 2] - age_ms.front(), 20.0);
  // The log says whether the release thread got real-time priority (runtime.release_priority 1).
  const std::string log = dcod.log();
  EXPECT_TRUE(log.find("from a SCHED_FIFO 1 thread") != std::string::npos ||
              log.find("SCHED_FIFO 1 was refused") != std::string::npos)
      << log;
}

// A latency longer than the results the runtime holds span at the camera's rate (4 at 30 fps:
// 133 ms) cannot be kept: dcod says so as it starts, counts the results that went out early in
// its status line, and warns when they do.
TEST(Dcod, AReleaseLatencyLongerThanTheHeldResultsSpanIsReportedNotSilentlyCut) {
  TempDir dir;
  DcodOptions o;
  o.args = base_args(dir, "synthetic://hand?width=160&height=96&fps=30&frames=45");
  // Statistics ten times a second: the warning and the status line come with them, and the run
  // is 1.5 s long.
  o.args.insert(o.args.end(),
                {"--set", "runtime.release_latency_ms=400", "--set", "lcm.stats_hz=10"});
  o.log = dir / "dcod.log";
  NotifySocket notify(dir / "notify");
  o.notify = &notify;
  DcodProcess dcod(o);
  EXPECT_EQ(dcod.wait(20s), 0) << dcod.log();
  const std::string log = dcod.log();
  EXPECT_NE(log.find("runtime.release_latency_ms 400 is longer than the 4 results the runtime "
                     "holds span at 30 fps (133 ms)"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("went out before runtime.release_latency_ms (400 ms)"), std::string::npos)
      << log;
  // The status line counts them.
  const std::regex counted(", [1-9][0-9]* early\\)");
  bool said = false;
  for (const auto& m : notify.messages()) said = said || std::regex_search(m.text, counted);
  EXPECT_TRUE(said) << log;
}

// Reloads that change the raw recording's settings while it records: the old recorder sends what
// it holds before the new one takes a pair, so DCO_RAW stays in frame order (a replay plays the
// pairs in the order of the log).
TEST(Dcod, ARawRecordingReloadKeepsThePairsInOrder) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  const auto log = dir / "field.log";
  // A PNG level (applied at once) and a densify key (restarting the stage threads) in turn.
  const auto config =
      dir.write("dcod.toml", "[raw]\nenabled = true\npng_level = 9\n[densify]\nlambda_s = 1.2\n");
  const auto other =
      dir.write("other.toml", "[raw]\nenabled = true\npng_level = 0\n[densify]\nlambda_s = 1.3\n");
  // Eight reloads, 0.25 s apart, swap the file between the two. They start once the ring
  // exists: a SIGHUP that reaches a process still being loaded ends it, as it would any program.
  const std::string swaps = "n=0; while [ ! -e " + (dir / "rec.shm").string() +
                            " ] && [ $n -lt 1000 ]; do sleep 0.02; n=$((n+1)); done; "
                            "for i in 1 2 3 4 5 6 7 8; do sleep 0.25; cp " +
                            config.string() + " " + (dir / "a").string() + "; cp " +
                            other.string() + " " + config.string() + "; cp " +
                            (dir / "a").string() + " " + other.string() + "; kill -HUP $D; done";
  const std::string record =
      unshare_command() + " sh -c '" + kNetnsSetup + " && lcm-logger -q --lcm-url=\"" + url +
      "\" " + log.string() + " & L=$!; sleep 0.5; " + DCOD_EXE +
      " --source \"synthetic://hand?width=320&height=192&fps=60&frames=150\" --config " +
      config.string() + " --set \"lcm.url=" + url +
      "\" --set ring.path=" + (dir / "rec.shm").string() +
      " --set runtime.deterministic=true --set lcm.stats_hz=10 & D=$!; " + swaps +
      "; wait $D; S=$?; sleep 0.5; kill -INT $L; wait $L; exit $S'";
  const auto r = run_command(record);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("raw recording stopped"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("restarted the pipeline for densify.lambda_s"), std::string::npos)
      << r.output;
  drivers::LcmLogReader log_reader(log);
  drivers::LcmLogEvent event;
  std::vector<std::int64_t> seqs;
  std::vector<::dco::pipeline_stats_t> stats;
  while (log_reader.next(event)) {
    ::dco::raw_stereo_t raw;
    ::dco::pipeline_stats_t s;
    std::string problem;
    if (event.channel == ipc::channel::kRaw &&
        ipc::decode_message(event.data.data(), event.data.size(), raw, problem))
      seqs.push_back(raw.frame_seq);
    if (event.channel == ipc::channel::kStats &&
        ipc::decode_message(event.data.data(), event.data.size(), s, problem))
      stats.push_back(s);
  }
  ASSERT_EQ(seqs.size(), 150u) << r.output;
  for (std::size_t i = 1; i < seqs.size(); ++i)
    EXPECT_GT(seqs[i], seqs[i - 1]) << "pair " << i << " of the log";
  // DCO_STATS counts the whole run across the pipeline's restarts: its counters never go back.
  ASSERT_GE(stats.size(), 5u) << r.output;
  for (std::size_t i = 1; i < stats.size(); ++i) {
    EXPECT_GE(stats[i].pushed, stats[i - 1].pushed) << "message " << i;
    EXPECT_GE(stats[i].published, stats[i - 1].published) << "message " << i;
    EXPECT_GE(stats[i].fps_out, 0.0) << "message " << i;
  }
}

TEST(Dcod, RawRecordingThroughLcmLoggerReplaysToIdenticalDepth) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  constexpr int kFrames = 8;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  const auto log = dir / "field.log";
  const std::string pipeline = " --set runtime.deterministic=true --set stereo.max_disparity=40";
  // On the headset: dcod with raw recording and lcm-logger side by side in one network.
  const std::string record =
      unshare_command() + " sh -c '" + kNetnsSetup + " && lcm-logger -q --lcm-url=\"" + url +
      "\" " + log.string() + " & L=$!; sleep 0.5; " + DCOD_EXE +
      " --source \"synthetic://hand?width=160&height=96&fps=6&frames=" + std::to_string(kFrames) +
      "\" --set \"lcm.url=" + url + "\" --set ring.path=" + (dir / "rec.shm").string() +
      " --set raw.enabled=true" + pipeline + "; S=$?; sleep 0.5; kill -INT $L; wait $L; exit $S'";
  std::map<std::uint64_t, std::vector<float>> recorded;
  std::thread reader([&] { recorded = read_ring(dir / "rec.shm", kFrames, 160, 96); });
  const auto r = run_command(record);
  reader.join();
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("raw recording: 8 pairs on DCO_RAW, 0 dropped"), std::string::npos)
      << r.output;
  ASSERT_EQ(recorded.size(), static_cast<std::size_t>(kFrames)) << r.output;

  // dco-diag's key numbers against the log's own DCO_DEPTH announcements.
  std::vector<double> latency_ms;
  long previews = 0, raw_pairs = 0;
  {
    drivers::LcmLogReader log_reader(log);
    drivers::LcmLogEvent event;
    while (log_reader.next(event)) {
      std::string problem;
      ::dco::depth_frame_t frame;
      if (event.channel == ipc::channel::kDepth &&
          ipc::decode_message(event.data.data(), event.data.size(), frame, problem))
        latency_ms.push_back(static_cast<double>(frame.publish_ns - frame.capture_ns) * 1e-6);
      previews += event.channel == ipc::channel::kDepthPreview;
      raw_pairs += event.channel == ipc::channel::kRaw;
    }
    ASSERT_TRUE(log_reader.damage().empty()) << log_reader.damage();
  }
  ASSERT_EQ(latency_ms.size(), static_cast<std::size_t>(kFrames));
  std::sort(latency_ms.begin(), latency_ms.end());
  const auto diag =
      run_command(std::string(DCO_DIAG_EXE) + " " + log.string() + " --html " +
                  (dir / "report.html").string() + " --json " + (dir / "report.json").string());
  ASSERT_EQ(diag.status, 0) << diag.output;
  EXPECT_NE(diag.output.find("8 published in 1 session"), std::string::npos) << diag.output;
  const std::string json = read_file(dir / "report.json");
  auto number = [&](const std::string& key) {
    std::smatch m;
    const std::regex pattern("\"" + key + "\": ([-0-9.e]+)");
    EXPECT_TRUE(std::regex_search(json, m, pattern)) << key << " in " << json;
    return m.empty() ? -1.0 : std::stod(m[1]);
  };
  EXPECT_EQ(number("frames"), kFrames);
  EXPECT_EQ(number("unpublished_frames"), 0);
  EXPECT_EQ(number("missing_announcements"), 0);
  EXPECT_EQ(number("raw_pairs"), raw_pairs);
  EXPECT_EQ(number("previews"), previews);
  EXPECT_GE(previews, 1);
  EXPECT_NEAR(number("max"), latency_ms.back(), 1e-3);
  EXPECT_NEAR(number("p50"), latency_ms[kFrames / 2 - 1], 1e-3);  // nearest rank: the 4th of 8
  const std::string html = read_file(dir / "report.html");
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
  EXPECT_NE(html.find("Latency histogram"), std::string::npos);

  // On the desk: the log through the same pipeline.
  DcodOptions o;
  // The headset's pipeline keys come with the log: only the scheduling is set here.
  o.args = base_args(dir, "lcmlog://" + log.string() + "?fps=6");
  o.args.insert(o.args.end(), {"--set", "runtime.deterministic=true"});
  o.log = dir / "replay.log";
  DcodProcess dcod(o);
  const auto replayed = read_ring(dir / "depth.shm", kFrames, 160, 96);
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
  ASSERT_EQ(replayed.size(), static_cast<std::size_t>(kFrames)) << dcod.log();
  for (const auto& [seq, depth] : recorded) {
    ASSERT_TRUE(replayed.count(seq)) << "frame " << seq;
    EXPECT_EQ(std::memcmp(depth.data(), replayed.at(seq).data(), depth.size() * sizeof(float)), 0)
        << "frame " << seq << " differs from what the headset published";
  }
  EXPECT_NE(dcod.log().find("from the log's pipeline settings: stereo.max_disparity = 40"),
            std::string::npos)
      << dcod.log();
  // The replay checked itself against the headset's recorded previews.
  EXPECT_NE(dcod.log().find("replay check: depth identical to the headset's in all " +
                            std::to_string(previews) + " recorded previews replayed"),
            std::string::npos)
      << dcod.log();
  // With another disparity range the depth is not the headset's, and the replay says so.
  const auto other =
      run_command(std::string(DCOD_EXE) + " --source lcmlog://" + log.string() +
                  "?fps=0 --set lcm.url=memq:// --set ring.path=" + (dir / "other.shm").string() +
                  " --set runtime.deterministic=true --set stereo.max_disparity=12");
  EXPECT_EQ(other.status, 0) << other.output;
  EXPECT_NE(other.output.find("replay check: depth differs from the headset's in"),
            std::string::npos)
      << other.output;
  EXPECT_NE(other.output.find("preview pixels differ, by up to"), std::string::npos)
      << other.output;
  // The same log cut short: every pair before the cut is published (the stages finish what they
  // hold, even at full speed), then one line names the cut.
  const std::string bytes = read_file(log);
  std::ofstream(dir / "cut.log", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  int whole_pairs = 0;
  {
    drivers::LcmLogReader cut_reader(dir / "cut.log");
    drivers::LcmLogEvent event;
    while (cut_reader.next(event)) whole_pairs += event.channel == ipc::channel::kRaw;
    ASSERT_FALSE(cut_reader.damage().empty());
  }
  ASSERT_GE(whole_pairs, 2);
  const auto cut = run_command(std::string(DCOD_EXE) + " --source lcmlog://" +
                               (dir / "cut.log").string() + "?fps=0 --set lcm.url=memq:// " +
                               "--set ring.path=" + (dir / "cut.shm").string() + pipeline);
  EXPECT_EQ(cut.status, 1) << cut.output;
  EXPECT_NE(cut.output.find("ends inside the event"), std::string::npos) << cut.output;
  EXPECT_NE(cut.output.find("(after " + std::to_string(whole_pairs) + " published frames)"),
            std::string::npos)
      << cut.output;
}

// A field log of three dcod runs, the third with another disparity range. Each run started its
// own sequence on the headset, so the replay starts a new one where the second run's frames
// begin, and its depth is the headset's in both; it stops at the third, which replays alone.
TEST(Dcod, EachRunOfAFieldLogReplaysAsItsOwnSequence) {
  if (const std::string problem = private_network_problem(); !problem.empty())
    GTEST_SKIP() << "no private network namespace (" << problem << "); udpm never runs outside one";
  TempDir dir;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  const auto log = dir / "field.log";
  const auto run = [&](int max_disparity) {
    return std::string(DCOD_EXE) +
           " --source \"synthetic://hand?width=160&height=96&fps=8&frames=6\" --set \"lcm.url=" +
           url + "\" --set ring.path=" + (dir / "rec.shm").string() +
           " --set raw.enabled=true --set lcm.preview_hz=30 --set runtime.deterministic=true"
           " --set stereo.max_disparity=" +
           std::to_string(max_disparity);
  };
  const auto recorded =
      run_command(unshare_command() + " sh -c '" + kNetnsSetup + " && lcm-logger -q --lcm-url=\"" +
                  url + "\" " + log.string() + " & L=$!; sleep 0.5; " + run(40) + " && " + run(40) +
                  " && " + run(32) + "; S=$?; sleep 0.5; kill -INT $L; wait $L; exit $S'");
  ASSERT_EQ(recorded.status, 0) << recorded.output;

  const auto replay = [&](const std::string& query) {
    return run_command(std::string(DCOD_EXE) + " --source \"lcmlog://" + log.string() + "?fps=0" +
                       query + "\" --set lcm.url=memq:// --set ring.path=" +
                       (dir / "replay.shm").string() + " --set runtime.deterministic=true");
  };
  const auto whole = replay("");
  EXPECT_EQ(whole.status, 1) << whole.output;
  EXPECT_NE(whole.output.find("1 new dcod run(s) in the replayed log since the last report (the "
                              "last from frame 0): depth started a new sequence at each"),
            std::string::npos)
      << whole.output;
  EXPECT_EQ(whole.output.find("gap(s) in the camera's frames"), std::string::npos) << whole.output;
  EXPECT_NE(whole.output.find("replay check: depth identical to the headset's in all 12 "
                              "recorded previews replayed"),
            std::string::npos)
      << whole.output;
  EXPECT_NE(whole.output.find("dcod run 3 (from frame 0) has other pipeline keys than the replay "
                              "started with; replay it alone: lcmlog://" +
                              log.string() + "?run=3"),
            std::string::npos)
      << whole.output;
  const auto third = replay("&run=3");
  EXPECT_EQ(third.status, 0) << third.output;
  EXPECT_NE(third.output.find("from the log's pipeline settings: stereo.max_disparity = 32"),
            std::string::npos)
      << third.output;
  EXPECT_NE(third.output.find("replay check: depth identical to the headset's in all 6 "
                              "recorded previews replayed"),
            std::string::npos)
      << third.output;
}

TEST(DcodService, UnitVerifiesAndItsExposureIsAtMost2_5) {
  const std::string unit = DCOD_TEST_UNIT;
  auto verify = run_command("systemd-analyze verify " + unit);
  EXPECT_EQ(verify.status, 0) << verify.output;
  auto security = run_command("systemd-analyze security --offline=true " + unit);
  const std::regex score("Overall exposure level for dcod.service: ([0-9.]+)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(security.output, m, score)) << security.output;
  EXPECT_LE(std::stod(m[1]), 2.5) << security.output;
}

// A camera that is not plugged in fails every start: the retries end after a few, instead of a
// restart every RestartSec all day (systemd's default limit, 5 in 10 s, is never reached 2 s
// apart), and plugging the camera in starts dcod again.
TEST(DcodService, ARestartLoopEndsAndPluggingTheCameraInStartsDcod) {
  std::ifstream unit_file(DCOD_TEST_UNIT);
  const std::string unit((std::istreambuf_iterator<char>(unit_file)), {});
  const auto seconds_of = [&](const std::string& key) {
    std::smatch m;
    EXPECT_TRUE(std::regex_search(unit, m, std::regex("\\n" + key + "=([0-9]+)s?\\n"))) << key;
    return m.empty() ? 0 : std::stoi(m[1]);
  };
  const int restart_s = seconds_of("RestartSec");
  const int interval_s = seconds_of("StartLimitIntervalSec");
  const int burst = seconds_of("StartLimitBurst");
  EXPECT_GE(burst, 2);
  EXPECT_LT((burst - 1) * restart_s, interval_s) << "a restart loop never reaches the limit";
  EXPECT_LT(unit.find("StartLimitBurst"), unit.find("[Service]")) << "StartLimit* go in [Unit]";
  std::ifstream rules_file(DCO_UDEV_RULES);
  std::string camera_rule;
  for (std::string line; std::getline(rules_file, line);)
    if (line.find("ATTR{idVendor}==\"05a9\"") != std::string::npos) camera_rule = line;
  EXPECT_NE(camera_rule.find("TAG+=\"systemd\""), std::string::npos) << camera_rule;
  EXPECT_NE(camera_rule.find("ENV{SYSTEMD_WANTS}+=\"dcod.service\""), std::string::npos)
      << camera_rule;
}

}  // namespace
}  // namespace dco::testing
