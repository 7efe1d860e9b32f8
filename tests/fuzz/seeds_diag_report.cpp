#include <sstream>

#include "dco/drivers/lcm_log.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

template <class Message>
void add(std::ostringstream& log, std::int64_t& number, const char* channel, const Message& m) {
  drivers::LcmLogEvent e;
  e.number = number++;
  e.timestamp_us = 1700000000000000 + 50000 * e.number;
  e.channel = channel;
  e.data.resize(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(e.data.data(), 0, static_cast<int>(e.data.size()));
  drivers::write_lcm_log_event(log, e);
}

}  // namespace

// A short dcod log with every channel dco-diag reads, and each message alone.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::ostringstream all;
  std::int64_t n = 0;
  ::dco::device_status_t status{};
  status.state = ::dco::device_status_t::STATE_STREAMING;
  status.device = "indemind";
  status.counter_count = 1;
  status.counter_names = {"frames"};
  status.counter_values = {3};
  add(all, n, ipc::channel::kStatus, status);
  for (int i = 0; i < 3; ++i) {
    ::dco::depth_frame_t f{};
    f.session_id = 7;
    f.publish_index = i + 1;
    f.frame_seq = 2 * i;
    f.capture_ns = 1000000 * i;
    f.publish_ns = f.capture_ns + 20000000;
    f.width = 64;
    f.height = 48;
    add(all, n, ipc::channel::kDepth, f);
  }
  ::dco::pipeline_stats_t stats{};
  stats.dropped = 2;
  stats.stereo_p50_ms = 3;
  stats.right_channels = 3;
  stats.right_gain[0] = stats.right_gain[1] = stats.right_gain[2] = 0.97;
  stats.right_row_offset = 0.5;
  stats.right_roll_deg = 0.1;
  stats.lens_falloff = 0.2;
  add(all, n, ipc::channel::kStats, stats);
  ::dco::depth_preview_t preview{};
  preview.width = 3;
  preview.height = 2;
  preview.num_pixels = 6;
  preview.depth_mm = {0, 400, 800, 1600, 3200, 32767};
  add(all, n, ipc::channel::kDepthPreview, preview);
  ::dco::log_event_t line{};
  line.level = ::dco::log_event_t::LEVEL_ERROR;
  line.source = "dcod";
  line.text = "usb: <stall>";
  add(all, n, ipc::channel::kLog, line);
  const std::string s = all.str();
  return {std::vector<std::uint8_t>(s.begin(), s.end())};
}

}  // namespace dco::fuzz
