#include "dco/drivers/recorded_previews.hpp"

#include <algorithm>
#include <deque>
#include <limits>

#include "dco/drivers/lcm_log.hpp"
#include "dco/drivers/source_uri.hpp"
#include "dco/ipc/lcm_messages.hpp"

namespace dco::drivers {

RecordedPreviews read_recorded_previews(const ReplayedLog& log, std::size_t max_count) {
  // A frame of the headset: its number and capture time, which its raw pair and preview share.
  using Frame = std::pair<std::int64_t, std::int64_t>;
  // dcod sends a frame's pair and its preview from different threads, in either order and a few
  // frames apart: recent pairs wait for their previews, and previews for their pairs.
  constexpr std::size_t kRecentPairs = 256;
  std::deque<std::pair<Frame, std::int64_t>> recent_pairs;  // and their sessions
  // With the order they came in: a new run numbers its frames from 0 again, so the smallest
  // frame is not the oldest.
  std::map<Frame, std::pair<std::uint64_t, ::dco::depth_preview_t>> waiting;
  std::uint64_t arrivals = 0;
  FrameSessions sessions;
  RecordedPreviews out;
  // Stores a preview whose pair was found; false once the limit is reached. A replay of one run
  // compares with that run's previews only, and counts no others.
  const auto store = [&](std::int64_t session, std::int64_t seq, ::dco::depth_preview_t&& p) {
    if (log.one_run && session != log.first_session) return true;
    if (out.by_frame.size() >= max_count) {
      out.truncated = true;
      return false;
    }
    out.by_frame[{session, seq}] = std::move(p);
    return true;
  };
  LcmLogReader reader(log.path);
  LcmLogEvent event;
  ::dco::depth_preview_t preview;
  ::dco::raw_stereo_t pair;
  std::string problem;
  while (reader.next(event)) {
    if (event.channel == log.channel) {
      // One that does not decode ends the replay, which says why.
      if (!ipc::decode_message(event.data.data(), event.data.size(), pair, problem)) continue;
      const Frame frame{pair.frame_seq, pair.capture_ns};
      const std::int64_t session = sessions.session_of(pair.frame_seq);
      if (const auto it = waiting.find(frame); it != waiting.end()) {
        const bool room = store(session, pair.frame_seq, std::move(it->second.second));
        waiting.erase(it);
        if (!room) break;
      } else {
        recent_pairs.emplace_back(frame, session);
        if (recent_pairs.size() > kRecentPairs) recent_pairs.pop_front();
      }
      continue;
    }
    if (event.channel != ipc::channel::kDepthPreview) continue;
    if (!ipc::decode_message(event.data.data(), event.data.size(), preview, problem) ||
        !ipc::consistent_preview(preview)) {
      ++out.undecodable;
      continue;
    }
    const Frame frame{preview.frame_seq, preview.capture_ns};
    const auto it = std::find_if(recent_pairs.rbegin(), recent_pairs.rend(),
                                 [&](const auto& p) { return p.first == frame; });
    if (it != recent_pairs.rend()) {
      if (!store(it->second, preview.frame_seq, std::move(preview))) break;
    } else {
      waiting[frame] = {arrivals++, std::move(preview)};
      // A preview's pair comes a few frames later at most: the oldest waiting ones past that are
      // of frames the log holds no pair of (raw recording was off), and give way.
      if (waiting.size() > kRecentPairs)
        waiting.erase(std::min_element(
            waiting.begin(), waiting.end(),
            [](const auto& a, const auto& b) { return a.second.first < b.second.first; }));
    }
  }
  return out;  // previews still waiting have no pair in the log: nothing replays their frames
}

std::optional<ReplayedLog> replayed_log(std::string_view source_uri) {
  if (!source_uri.starts_with("lcmlog://")) return std::nullopt;
  SourceUri uri(source_uri);
  ReplayedLog log{uri.path(), uri.value("channel").value_or(ipc::channel::kRaw)};
  // Checked by the source when it opens; here only which run's previews to compare with.
  const int run = uri.integer("run", 0, 1, std::numeric_limits<int>::max());
  log.one_run = run > 0;
  log.first_session = log.one_run ? run - 1 : 0;
  return log;
}

}  // namespace dco::drivers
