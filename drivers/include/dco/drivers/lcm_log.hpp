#pragma once

// Reading LCM log files (what lcm-logger writes) event by event, with the place and nature of any
// damage: a log cut short by a pulled power cord, or bytes that are not an event where one should
// start. LCM's own reader stops at damage without saying where, and a field engineer needs to
// know how much of a recording is good.

#include <climits>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <istream>
#include <memory>
#include <string>
#include <vector>

namespace dco::drivers {

struct LcmLogEvent {
  std::int64_t number = 0;        // the logger's event counter
  std::int64_t timestamp_us = 0;  // when the logger received it, µs since the epoch
  std::string channel;
  std::vector<std::uint8_t> data;
  std::uint64_t offset = 0;  // of the event's first byte in the file
};

class LcmLogReader {
 public:
  // Throws dco::Error when the file cannot be opened or is no regular file.
  explicit LcmLogReader(const std::filesystem::path& path);
  // Reads from a stream the caller keeps alive; `name` is for messages.
  LcmLogReader(std::istream& in, std::string name);

  // The next event, its buffers reused. False at the end of the log, and at damage, after which
  // damage() says where and what, and nothing more is read. Throws dco::Error when the stream
  // fails to read (a disk error), which is neither end nor damage.
  bool next(LcmLogEvent& event);

  // Empty while the log is intact (so far); else one line naming the log, the event and byte.
  const std::string& damage() const { return damage_; }
  // After damage: moves to the next place past it where a whole event head starts (a sync word,
  // a channel name of 1..255 printable bytes, lengths within the file), so that a report can
  // read on past a damaged stretch; next() then reads from there. False, the damage kept, when
  // none follows or the stream cannot seek. A replay does not resync: frames after a gap of
  // unknown length are not the recording's sequence.
  bool resync();
  std::uint64_t skipped_bytes() const { return skipped_; }  // by resync(), in all
  long events_read() const { return events_; }
  std::uint64_t bytes_read() const { return offset_; }
  // Whether the log began with an event's sync word: a log cut before its first whole event,
  // where it is false for a file that is no LCM log at all.
  bool began_like_a_log() const { return began_like_a_log_; }

  static constexpr std::uint32_t kSyncWord = 0xEDA1DA01;
  static constexpr std::size_t kMaxChannel = 255;
  static constexpr std::size_t kMaxData = std::size_t{1} << 28;  // LCM_MAX_MESSAGE_SIZE

 private:
  bool fail(const std::string& what);
  void check_read() const;
  void measure();

  std::unique_ptr<std::ifstream> file_;
  std::istream* in_ = nullptr;
  std::string name_;
  std::string damage_;
  std::uint64_t offset_ = 0;
  std::uint64_t size_ = UINT64_MAX;  // of the log, where the stream can tell
  std::uint64_t skipped_ = 0;
  long events_ = 0;
  bool began_like_a_log_ = false;
};

// Writes events in the same format (for tools that cut or filter logs, and for tests).
void write_lcm_log_event(std::ostream& out, const LcmLogEvent& event);

}  // namespace dco::drivers
