// Plain std::string messages, no fmt: the fuzz build compiles this file on its own.
#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "dco/core/error.hpp"
#include "dco/core/special_file.hpp"
#include "dco/drivers/lcm_log.hpp"

namespace dco::drivers {
namespace {

// An event's head: sync word, event number, timestamp, channel length, data length; big-endian.
constexpr std::size_t kHeadBytes = 4 + 8 + 8 + 4 + 4;

std::uint64_t read_be(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | p[i];
  return v;
}

void put_be(std::ostream& out, std::uint64_t v, int bytes) {
  std::array<char, 8> b{};
  for (int i = 0; i < bytes; ++i)
    b[static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * (bytes - 1 - i)));
  out.write(b.data(), bytes);
}

std::string cut(std::uint64_t got, std::uint64_t needed) {
  return "the log ends inside the event (" + std::to_string(got) + " of " + std::to_string(needed) +
         " bytes)";
}

}  // namespace

LcmLogReader::LcmLogReader(const std::filesystem::path& path) : name_(path.string()) {
  if (path.empty()) throw Error("no LCM log file named (an empty path)");
  if (is_special_file(path))
    throw Error(name_ + ": not an LCM log file (a directory, a device or a pipe)");
  file_ = std::make_unique<std::ifstream>(path, std::ios::binary);
  in_ = file_.get();
  if (!*file_) throw Error(name_ + ": cannot open the LCM log");
  measure();
}

LcmLogReader::LcmLogReader(std::istream& in, std::string name) : in_(&in), name_(std::move(name)) {
  measure();
}

void LcmLogReader::measure() {
  const std::istream::pos_type start = in_->tellg();
  if (start == std::istream::pos_type(-1) || !in_->seekg(0, std::ios::end)) {
    in_->clear();
    return;  // not seekable: lengths are checked against what arrives
  }
  const std::istream::pos_type end = in_->tellg();
  in_->seekg(start);
  if (end != std::istream::pos_type(-1) && end >= start)
    size_ = static_cast<std::uint64_t>(end - start);
}

bool LcmLogReader::fail(const std::string& what) {
  damage_ = name_ + ": event " + std::to_string(events_ + 1) + " at byte " +
            std::to_string(offset_) + ": " + what + "; the " + std::to_string(events_) +
            " events before it are good";
  return false;
}

void LcmLogReader::check_read() const {
  // A short read is the log's end only when the stream says so; else the disk failed.
  if (in_->bad())
    throw Error(name_ + ": cannot read the LCM log at byte " + std::to_string(offset_) +
                " (event " + std::to_string(events_ + 1) + ")");
}

bool LcmLogReader::next(LcmLogEvent& event) {
  if (!damage_.empty()) return false;
  std::array<std::uint8_t, kHeadBytes> head{};
  in_->read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  const auto got = static_cast<std::size_t>(in_->gcount());
  check_read();
  if (got == 0) return false;  // the clean end
  if (got < 4 || read_be(head.data(), 4) != kSyncWord) {
    // A log cut within its first sync word began like one all the same.
    if (offset_ == 0 && got < 4 &&
        (read_be(head.data(), got) << (8 * (4 - got))) ==
            (kSyncWord >> (8 * (4 - got)) << (8 * (4 - got))))
      began_like_a_log_ = true;
    return fail(got < 4 ? "the log ends inside an event's sync word"
                        : "no LCM sync word where an event should start");
  }
  if (offset_ == 0) began_like_a_log_ = true;
  if (got < kHeadBytes)
    return fail("the log ends inside the event's head (" + std::to_string(got) + " of " +
                std::to_string(kHeadBytes) + " bytes)");
  const std::uint64_t channel_bytes = read_be(head.data() + 20, 4);
  const std::uint64_t data_bytes = read_be(head.data() + 24, 4);
  if (channel_bytes == 0 || channel_bytes > kMaxChannel)
    return fail("a channel name of " + std::to_string(channel_bytes) + " bytes (1.." +
                std::to_string(kMaxChannel) + ")");
  if (data_bytes > kMaxData)
    return fail("a message of " + std::to_string(data_bytes) + " bytes, more than LCM's " +
                std::to_string(kMaxData));
  // A length past the end of the file is a cut, found without allocating for it.
  if (const std::uint64_t left = size_ - offset_ - kHeadBytes; channel_bytes + data_bytes > left)
    return fail(cut(kHeadBytes + left, kHeadBytes + channel_bytes + data_bytes));
  event.number = static_cast<std::int64_t>(read_be(head.data() + 4, 8));
  event.timestamp_us = static_cast<std::int64_t>(read_be(head.data() + 12, 8));
  event.offset = offset_;
  event.channel.resize(channel_bytes);
  in_->read(event.channel.data(), static_cast<std::streamsize>(channel_bytes));
  const auto channel_got = static_cast<std::uint64_t>(in_->gcount());
  event.data.resize(data_bytes);
  std::uint64_t data_got = 0;
  if (channel_got == channel_bytes && data_bytes > 0) {
    in_->read(reinterpret_cast<char*>(event.data.data()), static_cast<std::streamsize>(data_bytes));
    data_got = static_cast<std::uint64_t>(in_->gcount());
  }
  check_read();
  if (channel_got < channel_bytes || data_got < data_bytes)
    return fail(cut(kHeadBytes + channel_got + data_got, kHeadBytes + channel_bytes + data_bytes));
  offset_ += kHeadBytes + channel_bytes + data_bytes;
  ++events_;
  return true;
}

bool LcmLogReader::resync() {
  if (damage_.empty() || size_ == UINT64_MAX) return false;
  constexpr std::size_t kChunk = 1 << 16;
  std::vector<std::uint8_t> buffer(kChunk + kHeadBytes + kMaxChannel);
  const auto read_at = [&](std::uint64_t at, std::size_t n) {
    in_->clear();
    in_->seekg(static_cast<std::streamoff>(at));
    in_->read(reinterpret_cast<char*>(buffer.data()), static_cast<std::streamsize>(n));
    check_read();
    return static_cast<std::size_t>(in_->gcount());
  };
  // Whether a whole event head (and a plausible channel name) starts at buffer[i].
  const auto head_at = [&](std::size_t i, std::size_t have, std::uint64_t at) {
    if (have - i < kHeadBytes || read_be(buffer.data() + i, 4) != kSyncWord) return false;
    const std::uint64_t channel = read_be(buffer.data() + i + 20, 4);
    const std::uint64_t data = read_be(buffer.data() + i + 24, 4);
    if (channel == 0 || channel > kMaxChannel || data > kMaxData ||
        channel + data > size_ - at - kHeadBytes || have - i - kHeadBytes < channel)
      return false;
    for (std::size_t k = 0; k < channel; ++k)
      if (const std::uint8_t c = buffer[i + kHeadBytes + k]; c < 0x20 || c > 0x7e) return false;
    return true;
  };
  for (std::uint64_t from = offset_ + 1; from < size_;) {
    const std::size_t have = read_at(
        from, static_cast<std::size_t>(std::min<std::uint64_t>(buffer.size(), size_ - from)));
    if (have == 0) break;
    // Candidates in the first kChunk bytes; the rest of the buffer is their heads' room.
    const std::size_t candidates = std::min(have, kChunk);
    for (std::size_t i = 0; i < candidates; ++i) {
      if (buffer[i] != 0xED || !head_at(i, have, from + i)) continue;
      skipped_ += from + i - offset_;
      offset_ = from + i;
      in_->clear();
      in_->seekg(static_cast<std::streamoff>(offset_));
      damage_.clear();
      return true;
    }
    from += candidates;
  }
  in_->clear();
  return false;
}

void write_lcm_log_event(std::ostream& out, const LcmLogEvent& event) {
  put_be(out, LcmLogReader::kSyncWord, 4);
  put_be(out, static_cast<std::uint64_t>(event.number), 8);
  put_be(out, static_cast<std::uint64_t>(event.timestamp_us), 8);
  put_be(out, event.channel.size(), 4);
  put_be(out, event.data.size(), 4);
  out.write(event.channel.data(), static_cast<std::streamsize>(event.channel.size()));
  out.write(reinterpret_cast<const char*>(event.data.data()),
            static_cast<std::streamsize>(event.data.size()));
}

}  // namespace dco::drivers
