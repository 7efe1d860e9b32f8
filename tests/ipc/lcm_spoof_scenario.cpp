// Three processes on one LCM bus (udpm, run by test_lcm_spoof.cpp inside a private network
// namespace): a daemon that writes pattern frames into the depth ring and announces them on
// DCO_DEPTH, a spoofer that answers every genuine descriptor with forged ones, and a reader (this
// process) that takes every descriptor it hears to dco_client_read_announced and checks whatever
// is accepted against the pattern the daemon wrote. Prints one line of counts.
//
// usage: dco_lcm_spoof_scenario RING_DIR LCM_URL FRAMES PERIOD_US

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "dco/client.h"
#include "dco/ipc/lcm_messages.hpp"
#include "dco/ipc/publisher.hpp"
#include "ipc/frame_pattern.hpp"

namespace {

using namespace dco::ipc;
using dco::ipc::testing::pattern_depth;

constexpr int kWidth = 48;
constexpr int kHeight = 16;
constexpr std::uint32_t kSlots = 4;
// Forged descriptors carry frame_seq kForged + their kind, so the reader can count them; it never
// uses a descriptor's frame_seq for anything else.
constexpr std::int64_t kForged = 1'000'000;
enum Kind {
  kWrongSession = 1,                 // another session id
  kFutureIndex,                      // an index the daemon has not published
  kIndexZero,                        // never a publish index
  kOtherSlot,                        // a published index, named in a slot it was never written to
  kSlotOutOfRange,                   // slot 4 and slot 0xffffffff
  kKindsNeverValid,                  // kinds below must all be refused
  kBeingWritten = kKindsNeverValid,  // the frame in the slot the daemon is rewriting right now
  kReplay,  // the genuine (session, slot, index) with forged frame_seq, times and size
  kKinds
};

void sleep_us(long us) {
  std::this_thread::sleep_for(std::chrono::microseconds(us));
}

int run_daemon(const std::filesystem::path& ring_path, const std::string& url, int frames,
               long period_us) {
  sleep_us(300'000);  // the spoofer and the reader subscribe first
  RingOptions ro;
  ro.width = kWidth;
  ro.height = kHeight;
  ro.image_channels = 0;
  ro.slot_count = static_cast<int>(kSlots);
  RingWriter ring(ring_path, ro);
  PublisherOptions po;
  po.lcm_url = url;
  DepthPublisher pub(ring, po);
  for (int i = 0; i < frames; ++i) {
    // The slot stays open (odd) for most of the period, so forged names of it meet a slot that
    // is being written.
    RingWriter::Slot slot = pub.begin_write();
    const auto seq = static_cast<std::uint64_t>(i);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        slot.depth.at(x, y) =
            pattern_depth(seq, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
    sleep_us(period_us);
    FrameMeta meta;
    meta.frame_seq = seq;
    meta.capture_ns = i;
    pub.publish(meta);
  }
  sleep_us(1'000'000);  // the reader may still be reading the last frames
  return 0;
}

struct Spoofer {
  lcm::LCM* lcm = nullptr;
  int frames = 0;
  bool done = false;

  void forge(dco::depth_frame_t m, Kind kind) {
    m.frame_seq = kForged + kind;
    lcm->publish(channel::kDepth, &m);
  }

  static void on_depth(const lcm::ReceiveBuffer* rbuf, const std::string&, Spoofer* self) {
    self->answer(rbuf);
  }

  void answer(const lcm::ReceiveBuffer* rbuf) {
    dco::depth_frame_t d;
    std::string error;
    if (!decode_message(rbuf->data, rbuf->data_size, d, error) || d.frame_seq >= kForged) return;
    dco::depth_frame_t m = d;
    m.session_id = d.session_id ^ 0x5a5a5a5a;
    forge(m, kWrongSession);
    m = d;
    m.publish_index = d.publish_index + 1000;
    forge(m, kFutureIndex);
    m = d;
    m.publish_index = 0;
    forge(m, kIndexZero);
    m = d;
    m.slot = static_cast<std::int32_t>((static_cast<std::uint32_t>(d.slot) + 2) % kSlots);
    forge(m, kOtherSlot);
    m = d;
    m.slot = static_cast<std::int32_t>(kSlots);
    forge(m, kSlotOutOfRange);
    m.slot = -1;
    forge(m, kSlotOutOfRange);
    if (d.publish_index > static_cast<std::int64_t>(kSlots)) {
      m = d;
      m.slot = static_cast<std::int32_t>((static_cast<std::uint32_t>(d.slot) + 1) % kSlots);
      m.publish_index = d.publish_index + 1 - static_cast<std::int64_t>(kSlots);
      forge(m, kBeingWritten);
    }
    m = d;
    m.capture_ns = -1;
    m.width = 4096;
    forge(m, kReplay);
    if (d.frame_seq == frames - 1) done = true;
  }
};

int run_spoofer(const std::string& url, int frames) {
  lcm::LCM lcm(url);
  if (!lcm.good()) return 3;
  Spoofer s{&lcm, frames};
  // Plain-function subscriptions: GCC 12's UBSan flags the member-function dispatch in
  // lcm-cpp-impl.hpp (a misaligned object at address 0x2), though the call works.
  lcm.subscribeFunction(channel::kDepth, &Spoofer::on_depth, &s);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!s.done && std::chrono::steady_clock::now() < deadline) lcm.handleTimeout(100);
  return s.done ? 0 : 4;
}

struct Reader {
  std::string ring_path;
  dco_client* client = nullptr;
  std::vector<float> depth = std::vector<float>(kWidth * kHeight);
  dco_frame_buffer buffer{};
  long genuine = 0, genuine_accepted = 0, last_genuine_seq = -1;
  long received[kKinds] = {}, accepted[kKinds] = {};
  long bad_accepts = 0;  // accepted but not what the daemon wrote for that publish index
  long decode_errors = 0;

  // The frame the daemon wrote under this index: frame_seq = index - 1, pixels by frame_seq.
  bool is_daemons(const dco_frame_info& info, const dco::depth_frame_t& d) const {
    if (info.session_id != static_cast<std::uint64_t>(d.session_id) ||
        info.publish_index != static_cast<std::uint64_t>(d.publish_index) ||
        info.frame_seq + 1 != info.publish_index)
      return false;
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        if (depth[static_cast<std::size_t>(y * kWidth + x)] !=
            pattern_depth(info.frame_seq, static_cast<std::uint32_t>(x),
                          static_cast<std::uint32_t>(y)))
          return false;
    return true;
  }

  static void on_depth(const lcm::ReceiveBuffer* rbuf, const std::string&, Reader* self) {
    self->check(rbuf);
  }

  void check(const lcm::ReceiveBuffer* rbuf) {
    dco::depth_frame_t d;
    std::string error;
    if (!decode_message(rbuf->data, rbuf->data_size, d, error)) {
      ++decode_errors;
      return;
    }
    if (client == nullptr) {
      dco_client_options o;
      dco_client_options_init(&o);
      o.path = ring_path.c_str();
      if (dco_client_open(&o, &client) != DCO_OK) return;
    }
    dco_frame_info info;
    dco_frame_info_init(&info);
    // Only plain integers cross from the message to the client library.
    const dco_status status = dco_client_read_announced(
        client, static_cast<std::uint64_t>(d.session_id), static_cast<std::uint32_t>(d.slot),
        static_cast<std::uint64_t>(d.publish_index), &buffer, &info);
    const bool ok = status == DCO_OK;
    if (ok && !is_daemons(info, d)) ++bad_accepts;
    if (d.frame_seq < kForged) {
      ++genuine;
      genuine_accepted += ok;
      last_genuine_seq = static_cast<long>(d.frame_seq);
      return;
    }
    const auto kind = static_cast<std::size_t>(d.frame_seq - kForged);
    if (kind >= kKinds) return;
    ++received[kind];
    accepted[kind] += ok;
  }
};

pid_t start(int (*body)(const std::filesystem::path&, const std::string&, int, long),
            const std::filesystem::path& path, const std::string& url, int frames, long period) {
  const pid_t pid = fork();
  if (pid == 0) {
    int rc = 2;
    try {
      rc = body(path, url, frames, period);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "child: %s\n", e.what());
    }
    _exit(rc);
  }
  return pid;
}

int spoofer_body(const std::filesystem::path&, const std::string& url, int frames, long) {
  return run_spoofer(url, frames);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s RING_DIR LCM_URL FRAMES PERIOD_US\n", argv[0]);
    return 2;
  }
  const std::filesystem::path ring_path = std::filesystem::path(argv[1]) / "depth.shm";
  const std::string url = argv[2];
  const int frames = std::atoi(argv[3]);
  const long period_us = std::atol(argv[4]);

  // Children first, so none inherits the reader's LCM socket.
  const pid_t daemon = start(run_daemon, ring_path, url, frames, period_us);
  const pid_t spoofer = start(spoofer_body, ring_path, url, frames, period_us);

  Reader r;
  r.ring_path = ring_path.string();
  dco_frame_buffer_init(&r.buffer);
  r.buffer.depth = r.depth.data();
  r.buffer.depth_stride = kWidth * sizeof(float);
  r.buffer.depth_capacity = r.depth.size() * sizeof(float);
  int rc = 0;
  {
    lcm::LCM lcm(url);
    if (!lcm.good()) {
      std::fprintf(stderr, "reader: LCM setup failed for %s\n", url.c_str());
      kill(daemon, SIGKILL);
      kill(spoofer, SIGKILL);
      rc = 3;
    } else {
      lcm.subscribeFunction(channel::kDepth, &Reader::on_depth, &r);
      // Until the last genuine frame and the forgeries answering it are in, or a deadline.
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      auto quiet_since = std::chrono::steady_clock::now();
      while (std::chrono::steady_clock::now() < deadline) {
        if (lcm.handleTimeout(50) > 0) {
          quiet_since = std::chrono::steady_clock::now();
        } else if (r.last_genuine_seq == frames - 1 &&
                   std::chrono::steady_clock::now() - quiet_since >
                       std::chrono::milliseconds(200)) {
          break;
        }
      }
    }
  }
  int status = 0;
  waitpid(daemon, &status, 0);
  const int daemon_rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  waitpid(spoofer, &status, 0);
  const int spoofer_rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  if (r.client != nullptr) dco_client_close(r.client);

  long never_valid = 0, never_valid_accepted = 0;
  for (int k = kWrongSession; k < kKindsNeverValid; ++k) {
    never_valid += r.received[k];
    never_valid_accepted += r.accepted[k];
  }
  std::printf(
      "genuine %ld genuine_accepted %ld never_valid %ld never_valid_accepted %ld "
      "being_written %ld being_written_accepted %ld replay %ld replay_accepted %ld "
      "bad_accepts %ld decode_errors %ld daemon_rc %d spoofer_rc %d\n",
      r.genuine, r.genuine_accepted, never_valid, never_valid_accepted, r.received[kBeingWritten],
      r.accepted[kBeingWritten], r.received[kReplay], r.accepted[kReplay], r.bad_accepts,
      r.decode_errors, daemon_rc, spoofer_rc);
  return rc;
}
