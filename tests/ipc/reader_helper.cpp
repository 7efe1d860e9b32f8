// A client process for the multi-process tests. It reads frames for --duration-ms in one of
// several ways, checks every frame it accepts against the checksum of its frame number and prints
// one line of counts on exit:
//   view   wait for each frame, read it in place, accept it if the view is still valid
//   copy   wait for each frame and copy it out (the copy only succeeds untorn)
//   slow   like view, but pausing --row-us after every row, so the writer often overtakes it
//   stall  like view, but the first frame is held for --stall-ms halfway through reading it
// With --follow-restarts 1 a stopped writer is waited out (a daemon restart) instead of ending
// the run; the line then also counts the sessions seen.

#include <dco/client.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "frame_pattern.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using dco::ipc::testing::Checksum;
using dco::ipc::testing::expected_checksum;

struct Args {
  std::string path;
  std::string mode = "view";
  long duration_ms = 2000;
  long row_us = 0;
  long stall_ms = 0;
  bool follow_restarts = false;
};

struct Counts {
  long accepted = 0;
  long rejected = 0;
  long torn_accepted = 0;
  long torn_rejected = 0;  // overwritten reads whose pixels were indeed mixed
  long timeouts = 0;
  long stall_rejected = 0;
  long writer_gone = 0;
  long sessions = 0;
  std::uint64_t first_index = 0;
  std::uint64_t last_index = 0;
};

// Reads a view row by row (pausing as asked) and returns its checksum.
std::uint64_t read_view(const dco::client::FrameView& v, long row_us, long stall_ms) {
  const dco_frame_info& info = v.info();
  Checksum c;
  for (std::uint32_t y = 0; y < info.height; ++y) {
    c.add(v.depth_row(y), info.width * sizeof(float));
    if (row_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(row_us));
    if (stall_ms > 0 && y == info.height / 2)
      std::this_thread::sleep_for(std::chrono::milliseconds(stall_ms));
  }
  if (v.raw.image != nullptr)
    for (std::uint32_t y = 0; y < info.height; ++y)
      c.add(v.image_row(y), std::size_t{info.width} * info.image_channels);
  return c.value();
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string_view k = argv[i];
    const char* v = argv[i + 1];
    if (k == "--path")
      a.path = v;
    else if (k == "--mode")
      a.mode = v;
    else if (k == "--duration-ms")
      a.duration_ms = std::atol(v);
    else if (k == "--row-us")
      a.row_us = std::atol(v);
    else if (k == "--follow-restarts")
      a.follow_restarts = std::atol(v) != 0;
    else if (k == "--stall-ms")
      a.stall_ms = std::atol(v);
    else {
      std::fprintf(stderr, "dco_ipc_reader: bad argument %s\n", argv[i]);
      return 2;
    }
  }
  Counts n;
  try {
    dco::client::Options o;
    o.path = a.path;
    dco::client::Client client(o);
    std::vector<float> depth;
    std::vector<std::uint8_t> image;
    dco_frame_buffer buf;
    dco_frame_buffer_init(&buf);
    const auto end = Clock::now() + std::chrono::milliseconds(a.duration_ms);
    bool stalled = false;
    std::uint64_t session = 0;
    while (Clock::now() < end) {
      std::optional<dco::client::FrameView> v;
      try {
        v = client.wait_next(std::chrono::milliseconds(100));
      } catch (const dco::client::Error& e) {
        if (!a.follow_restarts || e.status() != DCO_E_WRITER_GONE) throw;
        ++n.writer_gone;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      if (!v) {
        ++n.timeouts;
        continue;
      }
      const dco_frame_info& info = v->info();
      std::uint64_t sum = 0;
      bool ok = false;
      if (a.mode == "copy") {
        depth.resize(std::size_t{info.width} * info.height);
        image.resize(std::size_t{info.width} * info.height * info.image_channels);
        buf.depth = depth.data();
        buf.depth_stride = info.width * sizeof(float);
        buf.depth_capacity = depth.size() * sizeof(float);
        buf.image = image.empty() ? nullptr : image.data();
        buf.image_stride = std::size_t{info.width} * info.image_channels;
        buf.image_capacity = image.size();
        ok = client.copy(*v, buf);
        sum = dco::ipc::testing::frame_checksum(
            reinterpret_cast<const unsigned char*>(depth.data()), buf.depth_stride, buf.image,
            buf.image_stride, info.width, info.height, info.image_channels);
      } else {
        const bool stall_now = a.mode == "stall" && !stalled;
        sum = read_view(*v, a.mode == "slow" ? a.row_us : 0, stall_now ? a.stall_ms : 0);
        ok = client.still_valid(*v);
        if (stall_now) {
          stalled = true;
          if (!ok) ++n.stall_rejected;
        }
      }
      const bool torn = sum != expected_checksum(info.frame_seq, info.width, info.height,
                                                 v->raw.image != nullptr);
      if (!ok) {
        ++n.rejected;
        if (torn) ++n.torn_rejected;
        continue;
      }
      ++n.accepted;
      if (info.session_id != session) {
        session = info.session_id;
        ++n.sessions;
      }
      if (n.first_index == 0) n.first_index = info.publish_index;
      n.last_index = info.publish_index;
      if (torn) ++n.torn_accepted;
    }
  } catch (const dco::client::Error& e) {
    std::fprintf(stderr, "dco_ipc_reader: %s\n", e.what());
    return 1;
  }
  std::printf(
      "accepted %ld rejected %ld torn_accepted %ld torn_rejected %ld timeouts %ld "
      "stall_rejected %ld writer_gone %ld sessions %ld first %llu last %llu\n",
      n.accepted, n.rejected, n.torn_accepted, n.torn_rejected, n.timeouts, n.stall_rejected,
      n.writer_gone, n.sessions, static_cast<unsigned long long>(n.first_index),
      static_cast<unsigned long long>(n.last_index));
  return 0;
}
