#pragma once

// One filled message of every dco LCM type, with arrays and strings of several lengths, for the
// round-trip tests and as the fuzz corpus's seeds.

#include <cstdint>
#include <string>

#include "dco/ipc/lcm_messages.hpp"

namespace dco::ipc::testing {

inline dco::depth_frame_t sample_depth_frame() {
  dco::depth_frame_t m;
  m.session_id = -0x1234567890abcdefLL;
  m.slot = 2;
  m.publish_index = 77;
  m.frame_seq = 1077;
  m.capture_ns = 123456789;
  m.publish_ns = 123999999;
  m.width = 1280;
  m.height = 720;
  return m;
}

inline dco::depth_preview_t sample_preview() {
  dco::depth_preview_t m;
  m.session_id = 99;
  m.publish_index = 5;
  m.frame_seq = 6;
  m.capture_ns = 7;
  m.source_width = 64;
  m.source_height = 36;
  m.width = 16;
  m.height = 9;
  m.num_pixels = m.width * m.height;
  for (int i = 0; i < m.num_pixels; ++i) m.depth_mm.push_back(static_cast<std::int16_t>(i * 200));
  return m;
}

inline dco::pipeline_stats_t sample_stats() {
  dco::pipeline_stats_t m{};
  m.utime_ns = 1;
  m.interval_s = 1.0;
  m.fps_in = 30;
  m.fps_out = 29.5;
  m.pushed = 300;
  m.dropped = 3;
  m.published = 297;
  m.latency_p50_ms = 40;
  m.latency_p99_ms = 55;
  m.stereo_p50_ms = 10;
  m.stereo_p99_ms = 12;
  m.contour_p50_ms = 8;
  m.contour_p99_ms = 9;
  m.densify_p50_ms = 20;
  m.densify_p99_ms = 25;
  m.entry_high_water = 1;
  m.stereo_queue_high_water = 2;
  m.densify_queue_high_water = 2;
  m.right_channels = 1;
  m.right_gain[0] = 0.976;
  m.right_level_offset[0] = 0.1;
  m.right_gain[1] = m.right_gain[2] = 1;
  m.right_row_offset = 0.25;
  m.right_roll_deg = -0.05;
  m.lens_falloff = 0.12;
  return m;
}

inline dco::device_status_t sample_status() {
  dco::device_status_t m;
  m.utime_ns = 5;
  m.state = dco::device_status_t::STATE_ERROR;
  m.device = "indemind";
  m.serial = "";
  m.firmware = "1.2.3";
  m.usb_speed_mbps = 480;
  m.error = "stall on endpoint 0x81";
  m.counter_count = 2;
  m.counter_names = {"frames", "stalls"};
  m.counter_values = {1200, 1};
  return m;
}

inline dco::log_event_t sample_log() {
  dco::log_event_t m;
  m.utime_ns = 42;
  m.level = dco::log_event_t::LEVEL_ERROR;
  m.source = "densify";
  m.text = "solver did not converge";
  return m;
}

inline dco::raw_stereo_t sample_raw() {
  dco::raw_stereo_t m;
  m.frame_seq = 3;
  m.capture_ns = 4;
  m.width = 8;
  m.height = 4;
  m.encoding = "png";
  m.left_size = 32;
  m.right_size = 20;
  for (int i = 0; i < m.left_size; ++i) m.left.push_back(static_cast<std::uint8_t>(i));
  for (int i = 0; i < m.right_size; ++i) m.right.push_back(static_cast<std::uint8_t>(255 - i));
  m.calibration = "[left]\nwidth = 8\n";
  m.num_imu = 3;
  for (int i = 0; i < m.num_imu; ++i) {
    m.imu_ns.push_back(1000 * i);
    m.accel.push_back({0.1f * static_cast<float>(i), 9.81f, 0.0f});
    m.gyro.push_back({0.0f, 0.01f, -0.02f});
  }
  return m;
}

}  // namespace dco::ipc::testing
