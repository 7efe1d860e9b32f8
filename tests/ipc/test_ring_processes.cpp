// Readers in their own processes, as renderers are: eight of them at different speeds, one killed
// mid-read and one stalled for seconds, next to a writer that must not notice any of them. Also a
// writer that dies and one that comes back, and the dco-watch tool.

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "ipc_test_support.hpp"
#include "process_support.hpp"

namespace dco::ipc::testing {
namespace {

std::int64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

TEST(RingProcesses, EightReadersNeverAcceptTornFramesNorSlowTheWriter) {
  TempDir dir;
  RingOptions o;
  o.width = kFrameWidth;
  o.height = kFrameHeight;
  o.image_channels = 1;
  o.slot_count = 4;
  RingWriter writer(dir.path() / "depth.shm", o);
  const std::string path = writer.path().string();
  PatternSource source;
  constexpr auto kPeriod = std::chrono::milliseconds(4);
  std::uint64_t seq = 0;
  std::vector<double> cpu_alone, cpu_with_readers, wall_alone, wall_with_readers;
  auto publish_one = [&](std::vector<double>& cpu, std::vector<double>& wall) {
    source.fill(++seq);
    const auto w0 = std::chrono::steady_clock::now();
    const std::int64_t c0 = thread_cpu_ns();
    writer.write(source.depth(), source.image(), {.frame_seq = seq});
    cpu.push_back(static_cast<double>(thread_cpu_ns() - c0) / 1e3);
    wall.push_back(
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - w0).count());
    std::this_thread::sleep_for(kPeriod);
  };

  for (int i = 0; i < 150; ++i) publish_one(cpu_alone, wall_alone);

  const std::string duration = "2500";
  std::vector<Child> kids;
  for (int i = 0; i < 3; ++i)
    kids.push_back(spawn("view" + std::to_string(i),
                         {"--path", path, "--mode", "view", "--duration-ms", duration}));
  for (int i = 0; i < 2; ++i)
    kids.push_back(spawn("copy" + std::to_string(i),
                         {"--path", path, "--mode", "copy", "--duration-ms", duration}));
  // A read takes about as long as the writer needs to come round the 4 slots (16 ms): some
  // reads finish in time, many are overtaken.
  kids.push_back(spawn(
      "slow", {"--path", path, "--mode", "slow", "--row-us", "40", "--duration-ms", duration}));
  kids.push_back(spawn("stall", {"--path", path, "--mode", "stall", "--stall-ms", "1500",
                                 "--duration-ms", duration}));
  // Reads take over 140 ms, so a kill lands mid-read.
  kids.push_back(spawn(
      "killed", {"--path", path, "--mode", "slow", "--row-us", "1000", "--duration-ms", "10000"}));
  Child& killed = kids.back();

  const auto start = std::chrono::steady_clock::now();
  bool kill_sent = false;
  for (;;) {
    publish_one(cpu_with_readers, wall_with_readers);
    const auto elapsed = std::chrono::steady_clock::now() - start;
    if (!kill_sent && elapsed > std::chrono::milliseconds(1000)) {
      ASSERT_EQ(kill(killed.pid, SIGKILL), 0);
      kill_sent = true;
    }
    bool all = true;
    for (auto& k : kids) all = poll_exit(k) && all;
    if (all) break;
    ASSERT_LT(elapsed, std::chrono::seconds(20)) << "readers did not finish";
  }

  const auto published = static_cast<double>(writer.published());
  const double with_readers_frames = static_cast<double>(cpu_with_readers.size());
  EXPECT_TRUE(WIFSIGNALED(killed.status) && WTERMSIG(killed.status) == SIGKILL);
  for (auto& k : kids) {
    if (&k == &killed) continue;
    SCOPED_TRACE(k.name + ": " + k.output);
    ASSERT_TRUE(WIFEXITED(k.status) && WEXITSTATUS(k.status) == 0);
    EXPECT_EQ(field(k.output, "torn_accepted"), 0);
    const long accepted = field(k.output, "accepted");
    const long span = field(k.output, "last") - field(k.output, "first") + 1;
    if (k.name.rfind("view", 0) == 0 || k.name.rfind("copy", 0) == 0) {
      // Keeping up: it followed the writer to the end and most frames reached it, untorn (the
      // writer's rate depends on the build, so the bounds are relative to what it published).
      EXPECT_GE(static_cast<double>(span), 0.6 * with_readers_frames);
      EXPECT_GE(static_cast<double>(accepted), 0.5 * static_cast<double>(span));
    }
    if (k.name == "slow") {
      // Its reads really were mixed from several frames, and every such read was refused.
      EXPECT_GT(field(k.output, "torn_rejected"), 0);
    }
    if (k.name == "stall") {
      EXPECT_EQ(field(k.output, "stall_rejected"), 1) << "a frame held for 1.5 s was rewritten";
      EXPECT_GT(accepted, 10) << "and the reader caught up afterwards";
      EXPECT_GE(static_cast<double>(field(k.output, "last")), 0.9 * published);
    }
    std::printf("[ reader   ] %-6s %s", k.name.c_str(), k.output.c_str());
  }
  const double alone = median(cpu_alone);
  const double with_readers = median(cpu_with_readers);
  std::printf(
      "[ writer   ] publish %dx%d depth+image: cpu p50 %.1f us alone, %.1f us with 8 "
      "readers; wall p50 %.1f / %.1f us; %llu frames\n",
      kFrameWidth, kFrameHeight, alone, with_readers, median(wall_alone), median(wall_with_readers),
      static_cast<unsigned long long>(writer.published()));
  // The writer never waits on a reader; only cache traffic from readers may cost it a little.
  EXPECT_LT(with_readers, 3.0 * alone + 50.0);
}

TEST(RingProcesses, ClientSeesAKilledWriterAndFollowsItsReplacement) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  RingOptions o;
  o.width = 32;
  o.height = 16;
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t pid = fork();
  if (pid == 0) {
    close(ready[0]);
    RingWriter writer(path, o);
    publish_pattern(writer, 5);
    const char byte = 1;
    if (write(ready[1], &byte, 1) != 1) _exit(1);
    for (;;) pause();
  }
  close(ready[1]);
  char byte = 0;
  ASSERT_EQ(read(ready[0], &byte, 1), 1);
  close(ready[0]);

  client::Options co;
  co.path = path.string();
  client::Client c(co);
  const auto v = c.wait_next(std::chrono::milliseconds(500));
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->info().frame_seq, 5u);
  const std::uint64_t dead_session = c.session_id();

  ASSERT_EQ(kill(pid, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  dco_frame_view raw;
  dco_frame_view_init(&raw);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(dco_client_wait_next(c.handle(), 2000, &raw), DCO_E_WRITER_GONE);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500))
      << "a dead writer is noticed without waiting for the timeout";
  EXPECT_TRUE(std::filesystem::exists(path)) << "a killed writer leaves its file behind";
  {
    // A client that comes after the crash gets no stale frame from wait_next, only from latest.
    client::Client late(co);
    dco_frame_view stale;
    dco_frame_view_init(&stale);
    EXPECT_EQ(dco_client_wait_next(late.handle(), 2000, &stale), DCO_E_WRITER_GONE);
    ASSERT_EQ(dco_client_latest(late.handle(), &stale), DCO_OK);
    EXPECT_EQ(stale.info.frame_seq, 5u);
  }

  RingWriter again(path, o);
  publish_pattern(again, 6);
  const auto next = c.wait_next(std::chrono::milliseconds(1000));
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->info().session_id, again.session_id());
  EXPECT_NE(again.session_id(), dead_session);
  EXPECT_EQ(next->info().frame_seq, 6u);
}

TEST(RingProcesses, ReadersFollowWriterRestartsWithoutMixingSessions) {
  run_restarts(3, std::chrono::milliseconds(500), 3);
}

// Runs a shell command line, stderr with stdout; its output and exit code.
std::string run_shell(const std::string& command, int* exit_code) {
  const std::string cmd = command + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[512];
  while (p != nullptr && std::fgets(buf, sizeof(buf), p) != nullptr) out += buf;
  const int status = p ? pclose(p) : -1;
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

std::string run_watch(const std::string& args, int* exit_code) {
  return run_shell(std::string(DCO_WATCH_EXE) + " " + args, exit_code);
}

TEST(DcoWatch, PrintsRateLatencyAndMetadata) {
  TempDir dir;
  RingOptions o;
  o.width = 64;
  o.height = 48;
  RingWriter writer(dir.path() / "depth.shm", o);
  std::atomic<bool> done{false};
  std::thread publisher([&] {
    for (std::uint64_t seq = 1; !done.load(); ++seq) {
      publish_pattern(writer, seq);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  int code = -1;
  const std::string out =
      run_watch("--path " + writer.path().string() + " --frames 20 --interval-ms 50", &code);
  // One frame gives no rate (it was published before the watch began), not frames per the
  // microseconds it took to read it.
  int one_code = -1;
  const std::string one =
      run_watch("--path " + writer.path().string() + " --frames 1 --interval-ms 50", &one_code);
  EXPECT_EQ(one_code, 0) << one;
  EXPECT_EQ(one.rfind("fps 0.0 ", 0), 0u) << one;
  int copy_code = -1;
  const std::string copy_out = run_watch(
      "--path " + writer.path().string() + " --frames 5 --interval-ms 50 --copy", &copy_code);
  done.store(true);
  publisher.join();
  EXPECT_EQ(code, 0) << out;
  ASSERT_EQ(out.rfind("fps ", 0), 0u) << out;
  const double fps = std::stod(out.substr(4));
  EXPECT_GT(fps, 20.0) << out;  // one frame every 5 ms and a little
  EXPECT_LT(fps, 250.0) << out;
  EXPECT_NE(out.find("latency capture p50"), std::string::npos) << out;
  EXPECT_NE(out.find("64x48"), std::string::npos) << out;
  EXPECT_NE(out.find("fx 5"), std::string::npos) << out;
  EXPECT_EQ(copy_code, 0) << copy_out;
}

// The daemon stops and a new one (another size) starts while the watch runs: it waits for it,
// as a renderer does, and follows it.
TEST(DcoWatch, FollowsARestartedWriter) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const RingOptions first{64, 48}, second{32, 24};
  std::atomic<bool> done{false};
  std::thread daemon([&] {
    {
      RingWriter w(path, first);
      for (std::uint64_t seq = 1; seq <= 30 && !done; ++seq) {
        publish_pattern(w, seq);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a restart's pause
    RingWriter w(path, second);
    for (std::uint64_t seq = 1; !done; ++seq) {
      publish_pattern(w, seq);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  int code = -1;
  const std::string out = run_watch(
      "--path " + path.string() + " --frames 60 --interval-ms 50 --timeout-ms 3000", &code);
  done = true;
  daemon.join();
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("the writer stopped; waiting"), std::string::npos) << out;
  EXPECT_NE(out.find("32x24"), std::string::npos) << out;
}

// A stopped daemon that does not come back within --timeout-ms ends the watch with exit 1; an
// overlay is never written through a link planted beside it; a file size limit is an error.
TEST(DcoWatch, AWriterThatStaysAwayEndsItAndOverlaysAreWrittenSafely) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const RingOptions o{64, 48, 1};
  auto writer = std::make_unique<RingWriter>(path, o);
  publish_pattern(*writer, 1);
  const std::string overlay = (dir.path() / "ov.ppm").string();
  std::ofstream(dir.path() / "victim") << "keep me";
  std::filesystem::create_symlink(dir.path() / "victim", overlay + ".tmp");
  std::thread stopper([&] {
    for (std::uint64_t seq = 2; seq <= 20; ++seq) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      publish_pattern(*writer, seq);
    }
    writer.reset();
  });
  int code = -1;
  const auto start = std::chrono::steady_clock::now();
  const std::string out = run_watch(
      "--path " + path.string() + " --interval-ms 1 --timeout-ms 500 --overlay " + overlay, &code);
  stopper.join();
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("writer stopped"), std::string::npos) << out;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  std::ifstream victim(dir.path() / "victim");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(victim), {}), "keep me");
  EXPECT_TRUE(std::filesystem::is_regular_file(std::filesystem::symlink_status(overlay)));

  RingWriter again(path, o);
  publish_pattern(again, 2);
  const std::string limited =
      run_shell("ulimit -f 1 && " + std::string(DCO_WATCH_EXE) + " --path " + path.string() +
                    " --frames 1 --overlay " + (dir.path() / "big.ppm").string(),
                &code);
  EXPECT_EQ(code, 1) << limited;
  EXPECT_NE(limited.find("File too large"), std::string::npos) << limited;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find("big.ppm"), std::string::npos)
        << "left behind: " << e.path();
}

// Without --path, the ring of a dcod run by hand by the same user is found where it writes it.
TEST(DcoWatch, FindsTheRingOfADcodRunByHand) {
  if (std::filesystem::exists("/run/dcod/depth.shm")) GTEST_SKIP() << "a service's ring is here";
  TempDir dir;
  std::filesystem::create_directory(dir.path() / "dcod");
  RingWriter writer(dir.path() / "dcod" / "depth.shm", RingOptions{32, 16});
  publish_pattern(writer, 7);
  int code = -1;
  const std::string out = run_shell(
      "XDG_RUNTIME_DIR=" + dir.path().string() + " " + std::string(DCO_WATCH_EXE) + " --frames 1",
      &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("32x16"), std::string::npos) << out;
}

TEST(DcoWatch, BadInputGivesOneLineAndAnExitCode) {
  TempDir dir;
  int code = -1;
  std::string out = run_watch("--path " + (dir.path() / "none.shm").string(), &code);
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("dco-watch: error: no depth ring"), std::string::npos) << out;
  out = run_watch("--frames zero", &code);
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("dco-watch: error: --frames needs a whole number of frames, 1 or more, not "
                     "'zero' (see --help)"),
            std::string::npos)
      << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  out = run_watch("--bogus", &code);
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("unknown argument '--bogus'"), std::string::npos) << out;
  RingOptions o;
  o.width = 8;
  o.height = 8;
  RingWriter writer(dir.path() / "depth.shm", o);
  out = run_watch("--path " + writer.path().string() + " --timeout-ms 50", &code);
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("timed out"), std::string::npos) << out;
}

}  // namespace
}  // namespace dco::ipc::testing
