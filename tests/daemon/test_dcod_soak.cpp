// dcod at its highest rate for 100k frames: resident anonymous and shared memory may not grow by
// more than 1 MB after the warm-up and the number of open descriptors stays the same. Prints the
// figures for bench/RESULTS.md.

#include <dirent.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "dcod_process.hpp"
#include "support/temp_dir.hpp"

namespace dco::testing {
namespace {

using namespace std::chrono_literals;

// Resident anonymous and shared memory: what a leak of heap, stacks, anonymous or shared mappings
// adds to. Not VmRSS, whose file-backed part grows by 1.5-2 MB as dcod exits (the libraries'
// destructors paged in), which a sample taken then counted as growth.
long rss_kib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  long anon = -1, shmem = -1;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("RssAnon:", 0) == 0) anon = std::stol(line.substr(8));
    if (line.rfind("RssShmem:", 0) == 0) shmem = std::stol(line.substr(9));
  }
  return anon < 0 || shmem < 0 ? -1 : anon + shmem;
}

long open_fds(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/fd";
  DIR* d = opendir(path.c_str());
  if (d == nullptr) return -1;
  long n = 0;
  while (readdir(d) != nullptr) ++n;
  closedir(d);
  return n - 2;
}

// Open descriptors that stay open: sd_notify opens a datagram socket for each message (the
// status line once a second) and closes it again, and a sample can catch it open. A leak stays,
// so a count above `before` is read again a moment later and the lower count kept.
long lasting_fds(pid_t pid, long before) {
  const long n = open_fds(pid);
  if (n <= before) return n;
  std::this_thread::sleep_for(20ms);
  const long again = open_fds(pid);
  return again < 0 ? n : std::min(n, again);
}

TEST(DcodSoak, HundredThousandFramesKeepMemoryAndDescriptorsFlat) {
  constexpr long kFrames = 100000;
  constexpr long kWarmUp = 5000;
  TempDir dir;
  NotifySocket notify(dir / "notify");
  DcodOptions o;
  o.args = {"--source", "synthetic://hand?width=160&height=96&fps=0", "--set", "lcm.url=memq://",
            "--set", "ring.path=" + (dir / "depth.shm").string(), "--set",
            "service.max_frames=" + std::to_string(kFrames), "--set", "lcm.preview_hz=30",
            // The source renders a frame only when the pipeline takes one: the pipeline's own
            // highest rate, without frames rendered only to be dropped.
            "--set", "runtime.deterministic=true"};
  o.log = dir / "dcod.log";
  o.notify = &notify;
  DcodProcess dcod(o);
  ASSERT_TRUE(notify.wait_for("READY=1", 20s)) << dcod.log();
  dco::client::Options co;
  co.path = (dir / "depth.shm").string();
  dco::client::Client client(co);

  long warm_rss = -1, warm_fds = -1, max_rss = 0, max_fds = 0, last_fds = 0;
  std::uint64_t seen = 0;
  const auto start = SteadyClock::now();
  while (dcod.running()) {
    if (const auto f = client.latest()) seen = f->info().publish_index;
    const long rss = rss_kib(dcod.pid());
    const long fds = lasting_fds(dcod.pid(), warm_fds < 0 ? 0 : warm_fds);
    if (rss < 0 || fds < 0) break;  // exited between the checks
    if (seen >= kWarmUp && warm_rss < 0) {
      warm_rss = rss;
      warm_fds = fds;
    }
    if (warm_rss >= 0) {
      max_rss = std::max(max_rss, rss);
      max_fds = std::max(max_fds, fds);
      last_fds = fds;
    }
    std::this_thread::sleep_for(200ms);
  }
  const double seconds = std::chrono::duration<double>(SteadyClock::now() - start).count();
  EXPECT_EQ(dcod.wait(10s), 0) << dcod.log();
  EXPECT_NE(dcod.log().find("published 100000 frames"), std::string::npos) << dcod.log();
  ASSERT_GE(warm_rss, 0) << "never saw the warm-up end";
  std::printf(
      "soak: %ld frames in %.0f s (%.0f fps); anonymous + shared RSS after %ld frames %ld KiB, "
      "max after %ld KiB (+%ld KiB); fds %ld -> max %ld, last %ld\n",
      kFrames, seconds, static_cast<double>(kFrames) / seconds, kWarmUp, warm_rss, max_rss,
      max_rss - warm_rss, warm_fds, max_fds, last_fds);
  EXPECT_LE(max_rss - warm_rss, 1024);
  EXPECT_EQ(max_fds, warm_fds);
}

}  // namespace
}  // namespace dco::testing
