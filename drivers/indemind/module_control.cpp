#include "module_control.hpp"

#include <thread>

#include <fmt/format.h>

#include "dco/indemind/xu_task.hpp"

namespace dco::indemind {
namespace {

constexpr std::chrono::milliseconds kControlTimeout{200};
// The bridge answers "busy" while a flash read is in progress; the vendor software asks again up
// to 20 times, 10 ms apart.
constexpr int kBusyAttempts = 20;
constexpr std::chrono::milliseconds kBusyWait{10};

// bmRequestType for class requests to an interface (UVC 1.1 §4.2): the bridge accepts these for
// its extension unit as it does from uvcvideo.
constexpr std::uint8_t kClassOut = 0x21, kClassIn = 0xA1;

}  // namespace

std::vector<std::uint8_t> ModuleControl::transaction(const std::vector<std::uint8_t>& command,
                                                     std::size_t reply_bytes) {
  std::vector<std::uint8_t> out = command;
  const auto value = static_cast<std::uint16_t>(kXuSelector << 8);
  const auto index = static_cast<std::uint16_t>(kXuUnit << 8 | kVideoControlInterface);
  device_.control(kClassOut, kUvcSetCur, value, index, out, kControlTimeout);
  std::vector<std::uint8_t> reply(kXuReplyDataOffset + reply_bytes);
  for (int attempt = 0; attempt < kBusyAttempts; ++attempt) {
    const std::size_t n =
        device_.control(kClassIn, kUvcGetCur, value, index, reply, kControlTimeout);
    switch (classify_xu_reply(std::span(reply).first(n))) {
      case XuReply::kDone:
        if (n < reply.size())
          throw Error(fmt::format("indemind: extension unit answered {} bytes, expected {}", n,
                                  reply.size()));
        reply.erase(reply.begin(), reply.begin() + kXuReplyDataOffset);
        return reply;
      case XuReply::kBusy:
        ++busy_retries_;
        std::this_thread::sleep_for(kBusyWait);
        break;
      case XuReply::kInvalid:
        throw Error(
            fmt::format("indemind: extension unit answered status 0x{:02x}", n > 0 ? reply[0] : 0));
    }
  }
  throw Error(fmt::format("indemind: extension unit still busy after {} attempts", kBusyAttempts));
}

std::vector<std::uint8_t> ModuleControl::read_flash(std::uint32_t address, std::size_t length) {
  std::vector<std::uint8_t> data;
  data.reserve(length);
  while (data.size() < length) {
    const std::size_t chunk = std::min(kFlashChunkBytes, length - data.size());
    const auto at = static_cast<std::uint32_t>(address + data.size());
    const auto part =
        transaction(encode_xu_read(XuTarget::kFlash, at, static_cast<std::uint16_t>(chunk)), chunk);
    data.insert(data.end(), part.begin(), part.end());
  }
  return data;
}

ModuleCalibration ModuleControl::read_calibration() {
  const auto header = read_flash(kFlashHeaderAddress, kFlashHeaderSize);
  const std::size_t length = parse_flash_header(header);
  return parse_calibration_blob(read_flash(kFlashBlobAddress, length));
}

void ModuleControl::configure_imu(int rate_hz, const ImuRanges& ranges) {
  if (rate_hz <= 0 || 1000 % rate_hz != 0)
    throw Error(fmt::format("indemind: IMU rate {} Hz does not divide 1000 Hz", rate_hz));
  // A divider above 255 would wrap in the register and set another rate.
  if (rate_hz < kMinImuHz)
    throw Error(
        fmt::format("indemind: IMU rate {} Hz is below the slowest the module runs at ({} Hz)",
                    rate_hz, kMinImuHz));
  const std::pair<std::uint8_t, std::uint8_t> writes[] = {
      {0x19, static_cast<std::uint8_t>(1000 / rate_hz - 1)},       // SMPLRT_DIV
      {0x1B, static_cast<std::uint8_t>(ranges.gyro_index << 3)},   // GYRO_CONFIG
      {0x1C, static_cast<std::uint8_t>(ranges.accel_index << 3)},  // ACCEL_CONFIG
  };
  for (const auto& [reg, value] : writes) transaction(encode_imu_register_write(reg, value), 0);
}

StreamControl ModuleControl::negotiate(const StreamMode& mode) {
  StreamControl asked;
  asked.frame_index = mode.frame_index;
  asked.frame_interval = mode.interval_100ns();
  asked.max_video_frame_size = static_cast<std::uint32_t>(mode.frame_bytes());
  auto bytes = encode_stream_control(asked);
  const auto probe = static_cast<std::uint16_t>(kVsProbeControl << 8);
  const auto commit = static_cast<std::uint16_t>(kVsCommitControl << 8);
  device_.control(kClassOut, kUvcSetCur, probe, kVideoStreamingInterface, bytes, kControlTimeout);
  bytes.fill(0);
  const std::size_t n = device_.control(kClassIn, kUvcGetCur, probe, kVideoStreamingInterface,
                                        bytes, kControlTimeout);
  const auto got = decode_stream_control(std::span(bytes).first(n));
  if (!got) throw Error(fmt::format("indemind: probe answer of {} bytes", n));
  if (got->frame_index != asked.frame_index || got->frame_interval != asked.frame_interval)
    throw Error(fmt::format("indemind: module offers frame {} every {} × 100 ns instead of {}",
                            got->frame_index, got->frame_interval, mode.name()));
  if (got->max_video_frame_size != mode.frame_bytes())
    throw Error(fmt::format("indemind: module announces {}-byte frames for {}, expected {}",
                            got->max_video_frame_size, mode.name(), mode.frame_bytes()));
  if (got->max_payload_transfer_size < 64 || got->max_payload_transfer_size > (1u << 22))
    throw Error(
        fmt::format("indemind: implausible payload size {}", got->max_payload_transfer_size));
  auto commit_bytes = encode_stream_control(*got);
  device_.control(kClassOut, kUvcSetCur, commit, kVideoStreamingInterface, commit_bytes,
                  kControlTimeout);
  return *got;
}

}  // namespace dco::indemind
