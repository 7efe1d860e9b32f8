#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace dco::indemind {

// The OV580 bridge's vendor extension-unit "task" protocol (protocol notes §6): a 16-byte command
// header (plus payload) written with SET_CUR to extension unit 4, selector 2, then the answer read
// back with GET_CUR: byte 0 is the status, data starts at byte 17.
inline constexpr std::uint8_t kXuUnit = 4;
inline constexpr std::uint8_t kXuSelector = 2;
inline constexpr std::size_t kXuHeaderBytes = 16;
inline constexpr std::size_t kXuReplyDataOffset = 17;
// Flash is read in chunks of this many bytes.
inline constexpr std::size_t kFlashChunkBytes = 256;
// ICM-20602 register r sits at this bridge address + r.
inline constexpr std::uint32_t kImuRegisterBase = 0x8018FD00;

enum class XuTarget : std::uint8_t {
  kSystemRegister = 0xA2,  // bridge registers, and through them the IMU's
  kFlash = 0xA1,
};

enum class XuReply { kDone, kBusy, kInvalid };

// A read of `length` bytes at `address`.
std::vector<std::uint8_t> encode_xu_read(XuTarget target, std::uint32_t address,
                                         std::uint16_t length);
// A one-byte register write. There is deliberately no encoder for flash writes or erases: the
// calibration lives in the module's flash and a daemon must never risk it.
std::vector<std::uint8_t> encode_imu_register_write(std::uint8_t reg, std::uint8_t value);

// Classifies a GET_CUR answer: 'V' done, 'U' busy (ask again), anything else invalid.
XuReply classify_xu_reply(std::span<const std::uint8_t> reply);

// What a decoded command asks for (the simulated device answers with it; tests check encoders).
struct XuCommand {
  bool read = false;
  std::uint8_t target = 0;
  std::uint8_t sub_id = 0;
  std::uint32_t address = 0;
  std::uint16_t length = 0;
  std::span<const std::uint8_t> payload;
};
// False when the bytes are not a well-formed command header.
bool decode_xu_command(std::span<const std::uint8_t> bytes, XuCommand& out);

}  // namespace dco::indemind
