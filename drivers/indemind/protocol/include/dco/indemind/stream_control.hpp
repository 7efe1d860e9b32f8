#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace dco::indemind {

// A streaming mode of the module: per-eye size and frame rate. On the wire a frame is a
// width × height YUY2 image that really is 2·width × height grey, left half then right half.
struct StreamMode {
  int width = 0, height = 0, fps = 0;
  std::uint8_t frame_index = 0;  // bFrameIndex of the descriptor

  std::size_t frame_bytes() const { return std::size_t(width) * height * 2; }
  std::uint32_t interval_100ns() const { return 10'000'000u / static_cast<std::uint32_t>(fps); }
  std::string name() const;  // "640x400@50"
};

// The module's modes: 1280×800 at 100/50/25 and 640×400 at 200/100/50/25 on USB 3; only 640×400
// at 25 on USB 2. A width or height of 0 is the one of the mode with the other (each size has
// one). nullopt with `why` filled when the combination is not offered.
std::optional<StreamMode> find_stream_mode(int width, int height, int fps, int usb_speed_mbps,
                                           std::string& why);
// The mode used when none is asked for: 640×400 at 50 on USB 3, at 25 on USB 2.
StreamMode default_stream_mode(int usb_speed_mbps);

// UVC 1.1 video probe and commit control (34 bytes, little-endian; UVC 1.1 table 4-47).
struct StreamControl {
  std::uint16_t hint = 1;  // dwFrameInterval is fixed
  std::uint8_t format_index = 1;
  std::uint8_t frame_index = 0;
  std::uint32_t frame_interval = 0;  // 100 ns units
  std::uint32_t max_video_frame_size = 0;
  std::uint32_t max_payload_transfer_size = 0;
  std::uint32_t clock_frequency = 0;
  std::uint8_t framing_info = 0;
};
inline constexpr std::size_t kStreamControlBytes = 34;
// UVC 1.0 devices answer with the first 26 bytes only.
inline constexpr std::size_t kStreamControlBytesUvc10 = 26;

std::array<std::uint8_t, kStreamControlBytes> encode_stream_control(const StreamControl& c);
// nullopt when fewer than 26 bytes came back.
std::optional<StreamControl> decode_stream_control(std::span<const std::uint8_t> bytes);

// UVC class requests and the selectors used with them.
inline constexpr std::uint8_t kUvcSetCur = 0x01, kUvcGetCur = 0x81;
inline constexpr std::uint8_t kVsProbeControl = 0x01, kVsCommitControl = 0x02;
inline constexpr int kVideoControlInterface = 0, kVideoStreamingInterface = 1, kImuInterface = 2;
inline constexpr std::uint8_t kVideoEndpoint = 0x81, kImuEndpoint = 0x89;
inline constexpr std::uint16_t kVendorId = 0x05a9, kProductId = 0xf581;

}  // namespace dco::indemind
