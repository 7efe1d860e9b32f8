#pragma once

// The depth previews (DCO_DEPTH_PREVIEW) a field log holds, by dcod session and camera frame
// number: what the headset's depth looked like, for checking a replay of the same log against it.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "dco/depth_preview_t.hpp"

namespace dco::drivers {

// Numbers the dcod sessions in a sequence of frame numbers: one that does not increase starts a
// new session (a restarted dcod numbers its frames again). The previews are keyed by the sessions
// of the log's raw pairs, and the replay check counts the replayed frames the same way.
class FrameSessions {
 public:
  // `first`: the session of the first frame (a replay of one run of a log: that run's).
  explicit FrameSessions(std::int64_t first = 0) : session_(first) {}

  std::int64_t session_of(std::int64_t frame_seq) {
    if (has_last_ && frame_seq <= last_) ++session_;
    has_last_ = true;
    last_ = frame_seq;
    return session_;
  }

 private:
  bool has_last_ = false;
  std::int64_t last_ = 0;
  std::int64_t session_ = 0;
};

struct RecordedPreviews {
  // By (session, frame number); only previews of frames whose raw pair is in the log, since only
  // those are replayed.
  std::map<std::pair<std::int64_t, std::int64_t>, ::dco::depth_preview_t> by_frame;
  long undecodable = 0;    // preview messages that did not decode or hold no whole grid
  bool truncated = false;  // more previews than the limit; the first ones are kept
};

// The log an lcmlog:// URI replays and the channel of its raw pairs.
struct ReplayedLog {
  std::filesystem::path path;
  std::string channel;
  std::int64_t first_session = 0;  // the dcod run replayed first (lcmlog's run=N: N - 1)
  bool one_run = false;            // lcmlog's run=N: only that run is replayed
};

// Reads the log up to its end or its damage (which the replay itself reports); with
// ReplayedLog::one_run only that run's previews. Throws dco::Error when the file cannot be opened
// or read.
RecordedPreviews read_recorded_previews(const ReplayedLog& log, std::size_t max_count);

// nullopt for sources other than lcmlog://.
std::optional<ReplayedLog> replayed_log(std::string_view source_uri);

}  // namespace dco::drivers
