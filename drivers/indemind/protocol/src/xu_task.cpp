#include "dco/indemind/xu_task.hpp"

#include "dco/indemind/byte_order.hpp"

namespace dco::indemind {
namespace {

constexpr std::uint8_t kSet = 0x50, kGet = 0x51;
constexpr std::uint8_t kSubImu = 0x20, kSubFlash = 0x03;

std::vector<std::uint8_t> header(std::uint8_t op, XuTarget target, std::uint8_t sub,
                                 std::uint32_t address, std::uint16_t length, std::size_t payload) {
  std::vector<std::uint8_t> b(kXuHeaderBytes + payload, 0);
  b[0] = op;
  b[1] = static_cast<std::uint8_t>(target);
  b[2] = sub;
  b[3] = 4;  // address width
  b[4] = 1;  // data width
  write_be32(b, 5, address);
  write_be16(b, 9, static_cast<std::uint16_t>(0x9000 | (length & 0x0fff)));
  write_be16(b, 11, length);
  return b;
}

}  // namespace

std::vector<std::uint8_t> encode_xu_read(XuTarget target, std::uint32_t address,
                                         std::uint16_t length) {
  return header(kGet, target, target == XuTarget::kFlash ? kSubFlash : kSubImu, address, length, 0);
}

std::vector<std::uint8_t> encode_imu_register_write(std::uint8_t reg, std::uint8_t value) {
  auto b = header(kSet, XuTarget::kSystemRegister, kSubImu, kImuRegisterBase + reg, 1, 1);
  b[kXuHeaderBytes] = value;
  return b;
}

XuReply classify_xu_reply(std::span<const std::uint8_t> reply) {
  if (reply.empty()) return XuReply::kInvalid;
  if (reply[0] == 0x56) return XuReply::kDone;
  if (reply[0] == 0x55) return XuReply::kBusy;
  return XuReply::kInvalid;
}

bool decode_xu_command(std::span<const std::uint8_t> b, XuCommand& out) {
  if (b.size() < kXuHeaderBytes || (b[0] != kSet && b[0] != kGet) || b[3] != 4 || b[4] != 1)
    return false;
  out.read = b[0] == kGet;
  out.target = b[1];
  out.sub_id = b[2];
  out.address = read_be32(b, 5);
  out.length = read_be16(b, 11);
  if ((read_be16(b, 9) & 0x0fff) != (out.length & 0x0fff)) return false;
  out.payload = b.subspan(kXuHeaderBytes);
  return true;
}

}  // namespace dco::indemind
