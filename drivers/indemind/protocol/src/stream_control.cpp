#include "dco/indemind/stream_control.hpp"

#include "dco/indemind/byte_order.hpp"

namespace dco::indemind {
namespace {

struct ModeEntry {
  int width, height;
  std::uint8_t frame_index;
  std::array<int, 4> fps;  // 0 = no more
};
constexpr ModeEntry kModes[] = {
    {1280, 800, 1, {100, 50, 25, 0}},
    {640, 400, 2, {200, 100, 50, 25}},
};

std::string mode_list() {
  return "1280x800 at 100/50/25 fps, 640x400 at 200/100/50/25 fps";
}

// Each width has one height and each height one width, so either alone names a size.
constexpr bool sizes_are_unique() {
  for (const ModeEntry& a : kModes)
    for (const ModeEntry& b : kModes)
      if (&a != &b && (a.width == b.width || a.height == b.height)) return false;
  return true;
}
static_assert(sizes_are_unique());

}  // namespace

std::string StreamMode::name() const {
  return std::to_string(width) + "x" + std::to_string(height) + "@" + std::to_string(fps);
}

std::optional<StreamMode> find_stream_mode(int width, int height, int fps, int usb_speed_mbps,
                                           std::string& why) {
  if (width == 0 || height == 0) {
    const ModeEntry* sized = nullptr;
    for (const ModeEntry& e : kModes)
      if (e.width == width || e.height == height) sized = &e;
    if (!sized) {
      why = "no mode " +
            (width ? std::to_string(width) + " wide" : std::to_string(height) + " high") +
            " (modes: " + mode_list() + ")";
      return std::nullopt;
    }
    width = sized->width;
    height = sized->height;
  }
  for (const ModeEntry& e : kModes) {
    if (e.width != width || e.height != height) continue;
    for (int f : e.fps) {
      if (f == 0 || f != fps) continue;
      StreamMode m{width, height, fps, e.frame_index};
      if (usb_speed_mbps > 0 && usb_speed_mbps < 5000 && (width != 640 || fps != 25)) {
        why = m.name() + " needs USB 3; this USB " + std::to_string(usb_speed_mbps) +
              " Mb/s link offers 640x400@25 only (plug the module into a USB 3 port)";
        return std::nullopt;
      }
      return m;
    }
    why = std::to_string(width) + "x" + std::to_string(height) + " does not run at " +
          std::to_string(fps) + " fps (modes: " + mode_list() + ")";
    return std::nullopt;
  }
  why = "no " + std::to_string(width) + "x" + std::to_string(height) +
        " mode (modes: " + mode_list() + ")";
  return std::nullopt;
}

StreamMode default_stream_mode(int usb_speed_mbps) {
  const bool usb2 = usb_speed_mbps > 0 && usb_speed_mbps < 5000;
  return StreamMode{640, 400, usb2 ? 25 : 50, 2};
}

std::array<std::uint8_t, kStreamControlBytes> encode_stream_control(const StreamControl& c) {
  std::array<std::uint8_t, kStreamControlBytes> b{};
  write_le16(b, 0, c.hint);
  b[2] = c.format_index;
  b[3] = c.frame_index;
  write_le32(b, 4, c.frame_interval);
  write_le32(b, 18, c.max_video_frame_size);
  write_le32(b, 22, c.max_payload_transfer_size);
  write_le32(b, 26, c.clock_frequency);
  b[30] = c.framing_info;
  return b;
}

std::optional<StreamControl> decode_stream_control(std::span<const std::uint8_t> b) {
  if (b.size() < kStreamControlBytesUvc10) return std::nullopt;
  StreamControl c;
  c.hint = read_le16(b, 0);
  c.format_index = b[2];
  c.frame_index = b[3];
  c.frame_interval = read_le32(b, 4);
  c.max_video_frame_size = read_le32(b, 18);
  c.max_payload_transfer_size = read_le32(b, 22);
  if (b.size() >= kStreamControlBytes) {
    c.clock_frequency = read_le32(b, 26);
    c.framing_info = b[30];
  }
  return c;
}

}  // namespace dco::indemind
