// dco-bench ipc: how fast a published depth frame reaches client processes through the
// shared-memory ring, next to the same frames sent inline over LCM udpm in the same run.
//
// The benchmark starts its clients as copies of itself in a hidden role ("--role ring-reader PATH
// POLL_US" or "--role lcm-reader URL"); each prints "ready" once connected and, when the publisher
// is done, one line "frames N lat L1 L2 ..." with the latency of every frame it got (ns).

#include "ipc_bench.hpp"

#include <dco/client.h>
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <lcm/lcm-cpp.hpp>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/json.hpp"
#include "median.hpp"

extern char** environ;

namespace dco::bench {
namespace {

namespace fs = std::filesystem;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-bench ipc [--clients LIST] [--rates LIST] [--frames N] [--size WxH]
                     [--no-image] [--poll-us US] [--lcm-url URL] [--no-netns] [--json]

Publishes depth frames into the shared-memory ring, read by client processes through
libdco-client (dco_client_wait_next, frames read in place), then sends the same frames inline
over LCM to as many subscriber processes; one run per client count and rate:
  latency  from the publish call to the moment a client holds the frame (ring: the slot's
           publish time to wait_next's return; LCM: just before publish() to the subscriber's
           handler), over every frame every client got: p50, p99 and max in microseconds
  lost     frames a client never got (a ring client that falls behind skips to the newest
           frame; LCM loses what the socket cannot hold)
  ratio    inline p99 / ring p99
  write    the publisher's time to copy a frame into a slot and publish it (a writer that
           renders into the slot skips the copy) and to send it inline
  cpu      a client process's CPU time from connecting to the end of the run divided by the
           frames, mean over clients

  --clients LIST  client process counts, comma separated (default 1,4,8)
  --rates LIST    publish rates in Hz, comma separated (default 30,90)
  --frames N      frames per run (default 150)
  --size WxH      depth size (default 1280x720), float32
  --no-image      no 8-bit grey image with the depth (by default slots and messages carry one)
  --poll-us US     ring clients wake when the writer starts a frame and poll up to US for
                  it (dco_client_options::poll_us; default 2000); 0: they sleep until the
                  frame is published
  --lcm-url URL   the inline peer's LCM URL
                  (default udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304)
  --no-netns      measure in the current network namespace; by default the benchmark runs
                  itself inside a private one (unshare, lo up, a multicast route on lo) so no
                  udpm datagram can leave the machine
  --json          one JSON object: the worst case over the runs at the top level (p99_us, lost,
                  inline_p99_us, inline_lost, ratio = the smallest per-run ratio), each run
                  under "runs"
  -h, --help      print this help

Exit status: 0 success, 1 a failure while measuring (namespace, LCM, ring, a client), 2 bad
command line.
)";

constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
constexpr const char* kInlineChannel = "DCO_BENCH_INLINE";
constexpr const char* kEndChannel = "DCO_BENCH_END";
constexpr const char* kNetnsMarker = "DCO_BENCH_PRIVATE_NETNS";
constexpr int kRingSlots = 4;
constexpr int kClientTimeoutMs = 5000;
constexpr std::size_t kInlineHeader = 16;  // frame number, send time (ns)

struct Options {
  std::vector<int> clients{1, 4, 8};
  std::vector<double> rates{30, 90};
  int frames = 150;
  int width = 1280, height = 720;
  bool image = true;
  int poll_us = 2000;
  std::string lcm_url = kDefaultLcmUrl;
  bool netns = true;
  bool json = false;
  bool help = false;
};

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t t) {
  const timespec ts{static_cast<time_t>(t / 1'000'000'000), static_cast<long>(t % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

template <class T>
std::vector<T> parse_list(std::string_view option, const std::string& text, T lo, T hi) {
  std::vector<T> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      const double v = std::stod(item, &used);
      if (used == item.size() && v >= static_cast<double>(lo) && v <= static_cast<double>(hi) &&
          (std::is_floating_point_v<T> || v == std::floor(v))) {
        out.push_back(static_cast<T>(v));
        continue;
      }
    } catch (const std::exception&) {
    }
    throw UsageError(fmt::format("{} needs comma-separated numbers in [{}, {}], not '{}'", option,
                                 lo, hi, text));
  }
  if (out.empty()) throw UsageError(fmt::format("{} needs at least one value", option));
  return out;
}

Options parse_args(int argc, char** argv) {
  Options opt;
  dco::tools::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    if (arg == "-h" || arg == "--help")
      opt.help = args.flag();
    else if (arg == "--clients")
      opt.clients = parse_list<int>("--clients", args.value(), 1, 64);
    else if (arg == "--rates")
      opt.rates = parse_list<double>("--rates", args.value(), 1.0, 1000.0);
    else if (arg == "--frames")
      opt.frames = args.int_value();
    else if (arg == "--size") {
      const auto size = dco::tools::parse_image_size("--size", args.value(), 16);
      opt.width = size.width;
      opt.height = size.height;
    } else if (arg == "--no-image")
      opt.image = !args.flag();
    else if (arg == "--poll-us")
      opt.poll_us = args.int_value();
    else if (arg == "--lcm-url")
      opt.lcm_url = args.value();
    else if (arg == "--no-netns")
      opt.netns = !args.flag();
    else if (arg == "--json")
      opt.json = args.flag();
    else if (arg.starts_with("-"))
      throw UsageError(fmt::format("unknown option {}", arg));
    else
      throw UsageError(fmt::format("unexpected argument '{}'", arg));
  }
  if (opt.frames < 2 || opt.frames > 100000) throw UsageError("--frames must be in 2..100000");
  if (opt.poll_us < 0 || opt.poll_us > 100000) throw UsageError("--poll-us must be in 0..100000");
  if (opt.width > 8192 || opt.height > 8192) throw UsageError("--size must be at most 8192x8192");
  return opt;
}

fs::path self_exe() {
  return fs::read_symlink("/proc/self/exe");
}

// Replaces this process with itself inside a private network namespace with a multicast route
// on lo. Only returns by throwing.
[[noreturn]] void rerun_in_private_netns(int argc, char** argv) {
  setenv(kNetnsMarker, "1", 1);
  const std::string exe = self_exe().string();
  std::vector<std::string> args{"unshare",
                                geteuid() == 0 ? "-n" : "-rn",
                                "sh",
                                "-c",
                                "ip link set lo up && ip route add 224.0.0.0/4 dev lo && "
                                "exec \"$0\" \"$@\"",
                                exe};
  for (int i = 0; i < argc; ++i) args.emplace_back(argv[i]);
  std::vector<char*> c_args;
  for (auto& a : args) c_args.push_back(a.data());
  c_args.push_back(nullptr);
  execvp("unshare", c_args.data());
  throw Error(fmt::format(
      "cannot run unshare for a private network namespace: {} (inside a namespace with a "
      "multicast route, pass --no-netns)",
      std::strerror(errno)));
}

// ---- client roles ----------------------------------------------------------------------------

std::int64_t cpu_time_us() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto us = [](const timeval& t) { return std::int64_t{t.tv_sec} * 1'000'000 + t.tv_usec; };
  return us(usage.ru_utime) + us(usage.ru_stime);
}

// The result line: frames received, the CPU time (µs) spent since the client was ready and every
// latency (ns).
void print_latencies(const std::vector<std::int64_t>& lat, std::int64_t cpu_us_at_ready) {
  std::string line =
      fmt::format("frames {} cpu_us {} lat", lat.size(), cpu_time_us() - cpu_us_at_ready);
  for (const std::int64_t v : lat) line += fmt::format(" {}", v);
  fmt::print("{}\n", line);
}

int ring_reader(const std::string& path, std::uint32_t poll_us) {
  dco_client_options options;
  dco_client_options_init(&options);
  options.path = path.c_str();
  options.poll_us = poll_us;
  dco_client* client = nullptr;
  if (dco_client_open(&options, &client) != DCO_OK) {
    fmt::print("error {}\n", dco::tools::one_line(dco_client_last_error()));
    return 1;
  }
  fmt::print("ready\n");
  std::fflush(stdout);
  const std::int64_t cpu_at_ready = cpu_time_us();
  std::vector<std::int64_t> lat;
  lat.reserve(1 << 16);
  dco_frame_view view;
  dco_frame_view_init(&view);
  int rc = 0;
  for (;;) {
    const dco_status status = dco_client_wait_next(client, kClientTimeoutMs, &view);
    if (status == DCO_OK) {
      lat.push_back(monotonic_ns() - view.info.publish_ns);
      continue;
    }
    if (status != DCO_E_WRITER_GONE) {
      fmt::print("error {}\n", dco::tools::one_line(dco_client_last_error()));
      rc = 1;
    }
    break;
  }
  dco_client_close(client);
  if (rc == 0) print_latencies(lat, cpu_at_ready);
  return rc;
}

struct InlineReader {
  std::vector<std::int64_t> lat;
  bool done = false;
};

void on_inline_frame(const lcm::ReceiveBuffer* buffer, const std::string&, InlineReader* r) {
  const std::int64_t now = monotonic_ns();
  if (buffer->data_size < kInlineHeader) return;
  std::int64_t sent = 0;
  std::memcpy(&sent, static_cast<const unsigned char*>(buffer->data) + 8, sizeof(sent));
  r->lat.push_back(now - sent);
}

void on_end(const lcm::ReceiveBuffer*, const std::string&, InlineReader* r) {
  r->done = true;
}

int lcm_reader(const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    fmt::print("error LCM cannot start on {}\n", url);
    return 1;
  }
  InlineReader reader;
  reader.lat.reserve(1 << 16);
  lcm.subscribeFunction(kInlineChannel, &on_inline_frame, &reader);
  lcm.subscribeFunction(kEndChannel, &on_end, &reader);
  fmt::print("ready\n");
  std::fflush(stdout);
  const std::int64_t cpu_at_ready = cpu_time_us();
  while (!reader.done) {
    const int r = lcm.handleTimeout(kClientTimeoutMs);
    if (r <= 0) {
      fmt::print("error {} while waiting for LCM messages\n", r == 0 ? "timeout" : "LCM failure");
      return 1;
    }
  }
  print_latencies(reader.lat, cpu_at_ready);
  return 0;
}

// ---- the publisher side ----------------------------------------------------------------------

class Child {
 public:
  explicit Child(const std::vector<std::string>& args) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw Error(fmt::format("pipe: {}", std::strerror(errno)));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    const std::string exe = self_exe().string();
    std::vector<std::string> all{exe, "ipc"};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int err = posix_spawn(&pid_, exe.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    fd_ = fds[0];
    if (err != 0) {
      close(fd_);
      throw Error(fmt::format("cannot start a client process: {}", std::strerror(err)));
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  Child(Child&& o) noexcept : pid_(o.pid_), fd_(o.fd_), out_(std::move(o.out_)) {
    o.pid_ = -1;
    o.fd_ = -1;
  }
  ~Child() {
    if (fd_ >= 0) close(fd_);
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }

  // Waits for the "ready" line; throws with the client's own message when it failed.
  void wait_ready() {
    const std::int64_t deadline = monotonic_ns() + std::int64_t{kClientTimeoutMs} * 1'000'000;
    while (out_.find('\n') == std::string::npos) {
      if (!read_some(deadline)) break;
    }
    const std::string line = out_.substr(0, out_.find('\n'));
    if (line != "ready")
      throw Error(line.empty() ? "a client process did not start" : "client: " + line);
    out_.erase(0, line.size() + 1);
  }

  struct Result {
    std::vector<std::int64_t> latency_ns;
    std::int64_t cpu_us = 0;
  };

  // Reads the result line after the publisher is done.
  Result result() {
    const std::int64_t deadline = monotonic_ns() + std::int64_t{kClientTimeoutMs} * 2'000'000;
    while (read_some(deadline)) {
    }
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    std::istringstream in(out_);
    std::string frames_word, cpu_word, lat_word;
    std::size_t n = 0;
    Result r;
    in >> frames_word >> n >> cpu_word >> r.cpu_us >> lat_word;
    if (!in || frames_word != "frames" || cpu_word != "cpu_us" || lat_word != "lat" ||
        !WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw Error("client: " + dco::tools::one_line(out_.empty() ? "no result" : out_));
    r.latency_ns.resize(n);
    for (auto& v : r.latency_ns)
      if (!(in >> v)) throw Error("client: truncated result");
    return r;
  }

 private:
  // False at EOF or the deadline.
  bool read_some(std::int64_t deadline) {
    const std::int64_t left_ms = (deadline - monotonic_ns()) / 1'000'000;
    if (left_ms <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left_ms)) <= 0) return false;
    char buf[65536];
    const ssize_t got = read(fd_, buf, sizeof(buf));
    if (got <= 0) return false;
    out_.append(buf, static_cast<std::size_t>(got));
    return true;
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  std::string out_;
};

struct Latency {
  double p50_us = 0, p99_us = 0, max_us = 0;
  long received = 0, lost = 0;
  double cpu_us_per_frame = 0;  // a client's CPU time over the run / frames, mean over clients
};

double nearest_rank(const std::vector<std::int64_t>& sorted, double q) {
  if (sorted.empty()) return 0;
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return static_cast<double>(sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1]) / 1e3;
}

Latency summarize(std::vector<Child>& clients, int frames) {
  std::vector<std::int64_t> all;
  Latency l;
  for (Child& c : clients) {
    const Child::Result r = c.result();
    l.lost += std::max(0L, frames - static_cast<long>(r.latency_ns.size()));
    all.insert(all.end(), r.latency_ns.begin(), r.latency_ns.end());
    l.cpu_us_per_frame +=
        static_cast<double>(r.cpu_us) / frames / static_cast<double>(clients.size());
  }
  std::sort(all.begin(), all.end());
  l.received = static_cast<long>(all.size());
  l.p50_us = nearest_rank(all, 0.5);
  l.p99_us = nearest_rank(all, 0.99);
  l.max_us = nearest_rank(all, 1.0);
  return l;
}

struct Frame {
  Image<float> depth;
  Image<std::uint8_t> image;
};

Frame make_frame(const Options& opt) {
  Frame f;
  f.depth.resize(opt.width, opt.height);
  for (int y = 0; y < opt.height; ++y)
    for (int x = 0; x < opt.width; ++x)
      f.depth.at(x, y) = 0.5f + 0.001f * static_cast<float>((x * 7 + y * 13) % 4000);
  if (opt.image) {
    f.image.resize(opt.width, opt.height);
    for (int y = 0; y < opt.height; ++y)
      for (int x = 0; x < opt.width; ++x)
        f.image.at(x, y) = static_cast<std::uint8_t>((x ^ y) & 0xff);
  }
  return f;
}

struct Run {
  int clients = 0;
  double rate = 0;
  Latency ring, inline_lcm;
  double ring_write_us = 0, inline_send_us = 0;
  double ratio() const { return ring.p99_us > 0 ? inline_lcm.p99_us / ring.p99_us : 0; }
};

class TempRingDir {
 public:
  TempRingDir() {
    std::string tmpl = (fs::temp_directory_path() / "dco-bench-ipc.XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr)
      throw Error(fmt::format("{}: mkdtemp: {}", tmpl, std::strerror(errno)));
    path_ = tmpl;
  }
  ~TempRingDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void measure_ring(const Options& opt, const fs::path& path, Frame& frame, Run& run) {
  std::vector<Child> clients;
  std::vector<double> write_us;
  {
    dco::ipc::RingWriter writer(path, {opt.width, opt.height, opt.image ? 1 : 0, kRingSlots});
    for (int i = 0; i < run.clients; ++i)
      clients.emplace_back(std::vector<std::string>{"--role", "ring-reader", path.string(),
                                                    std::to_string(opt.poll_us)});
    for (Child& c : clients) c.wait_ready();
    const auto period = static_cast<std::int64_t>(1e9 / run.rate);
    const std::int64_t start = monotonic_ns() + 20'000'000;
    for (int i = 0; i < opt.frames; ++i) {
      sleep_until_ns(start + i * period);
      frame.depth.at(0, 0) = static_cast<float>(i);
      dco::ipc::FrameMeta meta;
      meta.frame_seq = static_cast<std::uint64_t>(i);
      meta.capture_ns = monotonic_ns();
      writer.write(frame.depth.cview(), frame.image.cview(), meta);
      write_us.push_back(static_cast<double>(monotonic_ns() - meta.capture_ns) / 1e3);
    }
    // Let the last frame reach everyone before the ring closes (closing ends the readers).
    sleep_until_ns(monotonic_ns() + 200'000'000);
  }
  run.ring = summarize(clients, opt.frames);
  run.ring_write_us = median(write_us);
}

void measure_inline(const Options& opt, const Frame& frame, Run& run) {
  lcm::LCM lcm(opt.lcm_url);
  if (!lcm.good())
    throw Error(fmt::format(
        "LCM cannot start on '{}' (udpm needs a multicast route; without --no-netns the "
        "benchmark makes one in a private namespace)",
        opt.lcm_url));
  std::vector<Child> clients;
  for (int i = 0; i < run.clients; ++i)
    clients.emplace_back(std::vector<std::string>{"--role", "lcm-reader", opt.lcm_url});
  for (Child& c : clients) c.wait_ready();

  const std::size_t depth_bytes = std::size_t{4} * opt.width * opt.height;
  const std::size_t image_bytes = opt.image ? std::size_t{1} * opt.width * opt.height : 0;
  std::vector<unsigned char> payload(kInlineHeader + depth_bytes + image_bytes);
  for (int y = 0; y < opt.height; ++y) {
    std::memcpy(payload.data() + kInlineHeader + std::size_t{4} * opt.width * y, frame.depth.row(y),
                std::size_t{4} * opt.width);
    if (opt.image)
      std::memcpy(payload.data() + kInlineHeader + depth_bytes + std::size_t{1} * opt.width * y,
                  frame.image.row(y), opt.width);
  }
  std::vector<double> send_us;
  const auto period = static_cast<std::int64_t>(1e9 / run.rate);
  const std::int64_t start = monotonic_ns() + 20'000'000;
  for (int i = 0; i < opt.frames; ++i) {
    sleep_until_ns(start + i * period);
    const auto seq = static_cast<std::uint64_t>(i);
    std::memcpy(payload.data(), &seq, sizeof(seq));
    const std::int64_t sent = monotonic_ns();
    std::memcpy(payload.data() + 8, &sent, sizeof(sent));
    if (lcm.publish(kInlineChannel, payload.data(), static_cast<unsigned>(payload.size())) != 0)
      throw Error("LCM publish failed");
    send_us.push_back(static_cast<double>(monotonic_ns() - sent) / 1e3);
  }
  // The end marker is a datagram too: send it a few times.
  const unsigned char end = 1;
  for (int i = 0; i < 5; ++i) {
    sleep_until_ns(monotonic_ns() + 50'000'000);
    lcm.publish(kEndChannel, &end, 1);
  }
  run.inline_lcm = summarize(clients, opt.frames);
  run.inline_send_us = median(send_us);
}

std::string wait_text(const Options& opt) {
  return opt.poll_us == 0 ? std::string("sleeping until woken")
                          : fmt::format("polling up to {} us through each write", opt.poll_us);
}

std::string frame_text(const Options& opt) {
  const double mb = (4.0 + (opt.image ? 1.0 : 0.0)) * opt.width * opt.height / 1e6;
  return fmt::format("{}x{} float32 depth{} ({:.2f} MB per frame)", opt.width, opt.height,
                     opt.image ? " + 8-bit grey image" : "", mb);
}

void print_text(const Options& opt, const std::vector<Run>& runs) {
  fmt::print("ipc: {}, {} frames per run, ring of {} slots, clients {}; inline peer: LCM {}\n",
             frame_text(opt), opt.frames, kRingSlots, wait_text(opt), opt.lcm_url);
  fmt::print(
      "clients  rate Hz |  ring p50 / p99 / max us   lost  write us  cpu us |  inline p50 / p99 / "
      "max us   lost   send us  cpu us | ratio p99\n");
  for (const Run& r : runs)
    fmt::print(
        "{:7d}  {:7g} | {:8.1f} {:8.1f} {:8.1f} {:6d} {:9.1f} {:7.1f} | {:9.1f} {:8.1f} {:8.1f} "
        "{:6d} {:9.1f} {:7.1f} | {:9.1f}\n",
        r.clients, r.rate, r.ring.p50_us, r.ring.p99_us, r.ring.max_us, r.ring.lost,
        r.ring_write_us, r.ring.cpu_us_per_frame, r.inline_lcm.p50_us, r.inline_lcm.p99_us,
        r.inline_lcm.max_us, r.inline_lcm.lost, r.inline_send_us, r.inline_lcm.cpu_us_per_frame,
        r.ratio());
}

void print_json(const Options& opt, const std::vector<Run>& runs) {
  using dco::tools::json_number;
  double p99 = 0, inline_p99 = 0, ratio = runs.front().ratio();
  long lost = 0, inline_lost = 0;
  std::string items;
  for (const Run& r : runs) {
    p99 = std::max(p99, r.ring.p99_us);
    inline_p99 = std::max(inline_p99, r.inline_lcm.p99_us);
    ratio = std::min(ratio, r.ratio());
    lost += r.ring.lost;
    inline_lost += r.inline_lcm.lost;
    items += fmt::format(
        "{}{{\"clients\": {}, \"rate_hz\": {}, \"received\": {}, \"p50_us\": {}, \"p99_us\": {}, "
        "\"max_us\": {}, \"lost\": {}, \"write_us\": {}, \"client_cpu_us_per_frame\": {}, "
        "\"inline_received\": {}, \"inline_p50_us\": {}, \"inline_p99_us\": {}, "
        "\"inline_max_us\": {}, \"inline_lost\": {}, \"inline_send_us\": {}, "
        "\"inline_client_cpu_us_per_frame\": {}, \"ratio\": {}}}",
        items.empty() ? "" : ", ", r.clients, json_number(r.rate), r.ring.received,
        json_number(r.ring.p50_us), json_number(r.ring.p99_us), json_number(r.ring.max_us),
        r.ring.lost, json_number(r.ring_write_us), json_number(r.ring.cpu_us_per_frame),
        r.inline_lcm.received, json_number(r.inline_lcm.p50_us), json_number(r.inline_lcm.p99_us),
        json_number(r.inline_lcm.max_us), r.inline_lcm.lost, json_number(r.inline_send_us),
        json_number(r.inline_lcm.cpu_us_per_frame), json_number(r.ratio()));
  }
  fmt::print(
      "{{\"p99_us\": {}, \"lost\": {}, \"inline_p99_us\": {}, \"inline_lost\": {}, \"ratio\": {}, "
      "\"frames\": {}, \"width\": {}, \"height\": {}, \"image\": {}, \"poll_us\": {}, "
      "\"runs\": [{}]}}\n",
      json_number(p99), lost, json_number(inline_p99), inline_lost, json_number(ratio), opt.frames,
      opt.width, opt.height, opt.image ? "true" : "false", opt.poll_us, items);
}

}  // namespace

int run_ipc_bench(int argc, char** argv) {
  return dco::tools::run_tool("dco-bench ipc", [&] {
    if (argc >= 4 && std::string_view(argv[1]) == "--role") {
      if (argc == 5 && std::string_view(argv[2]) == "ring-reader")
        return ring_reader(argv[3], static_cast<std::uint32_t>(std::stoul(argv[4])));
      if (argc == 4 && std::string_view(argv[2]) == "lcm-reader") return lcm_reader(argv[3]);
    }
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    if (opt.netns && std::getenv(kNetnsMarker) == nullptr) rerun_in_private_netns(argc, argv);

    TempRingDir dir;
    const fs::path ring = dir.path() / "depth.shm";
    Frame frame = make_frame(opt);
    std::vector<Run> runs;
    for (const double rate : opt.rates)
      for (const int clients : opt.clients) {
        Run run;
        run.clients = clients;
        run.rate = rate;
        measure_ring(opt, ring, frame, run);
        measure_inline(opt, frame, run);
        runs.push_back(run);
      }
    if (opt.json)
      print_json(opt, runs);
    else
      print_text(opt, runs);
    return 0;
  });
}

}  // namespace dco::bench
