#include "dco/diag/log_digest.hpp"

#include <algorithm>
#include <fstream>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/drivers/lcm_log.hpp"
#include "dco/drivers/recorded_previews.hpp"
#include "dco/ipc/lcm_messages.hpp"

namespace dco::diag {
namespace {

class Digester {
 public:
  Digester(LogDigest& out, const DigestOptions& options) : d_(out), options_(options) {}

  void add(const drivers::LcmLogEvent& e) {
    if (d_.events == 0) d_.first_us = e.timestamp_us;
    ++d_.events;
    // In double: a damaged timestamp must not overflow 64-bit arithmetic.
    const double t =
        (static_cast<double>(e.timestamp_us) - static_cast<double>(d_.first_us)) * 1e-6;
    if (d_.events > 1 && t < last_t_ - LogDigest::kClockStepBackS) {
      if (d_.clock_steps_back++ == 0) {
        d_.first_step_back_event = e.number;
        d_.first_step_back_s = last_t_ - t;
      }
    }
    last_t_ = t;
    earliest_t_ = std::min(earliest_t_, t);
    latest_t_ = std::max(latest_t_, t);
    d_.span_s = latest_t_ - earliest_t_;
    ChannelTally& tally = d_.channels[e.channel];
    ++tally.events;
    tally.bytes += e.data.size();
    namespace ch = ipc::channel;
    if (e.channel == ch::kDepth) {
      if (decode(e, tally, depth_)) add_frame(t);
    } else if (e.channel == ch::kStats) {
      if (decode(e, tally, stats_)) add_stats(t);
    } else if (e.channel == ch::kStatus) {
      if (decode(e, tally, status_)) add_status(t);
    } else if (e.channel == ch::kLog) {
      if (decode(e, tally, log_)) add_log(t);
    } else if (e.channel == ch::kDepthPreview) {
      if (decode(e, tally, preview_) && plausible_preview(e, tally)) add_preview(t);
    } else if (e.channel == ch::kRaw) {
      if (decode(e, tally, raw_)) add_raw(e);
    }
  }

 private:
  template <class Message>
  bool decode(const drivers::LcmLogEvent& e, ChannelTally& tally, Message& m) {
    std::string problem;
    if (ipc::decode_message(e.data.data(), e.data.size(), m, problem)) return true;
    if (tally.undecodable++ == 0)
      tally.first_problem = fmt::format("event {} at byte {}: {}", e.number, e.offset, problem);
    return false;
  }

  void add_frame(double t) {
    const ::dco::depth_frame_t& m = depth_;
    // Differences in double: a corrupt message's values must not overflow 64-bit arithmetic.
    d_.frames.push_back(
        {static_cast<float>(t),
         static_cast<float>(
             (static_cast<double>(m.publish_ns) - static_cast<double>(m.capture_ns)) * 1e-6)});
    auto it = std::find_if(d_.sessions.begin(), d_.sessions.end(),
                           [&](const Session& s) { return s.id == m.session_id; });
    if (it == d_.sessions.end()) {
      // A new dcod: its DCO_STATS count from 0. Unless those it sent before its first frame
      // (while starting) already stepped the counts down, or the log starts with them: then they
      // were counted whole, and the next one adds to them.
      new_session_ = !restart_counted_;
      Session s;
      s.id = m.session_id;
      s.first_s = t;
      s.first_seq = s.last_seq = m.frame_seq;
      s.first_publish_ns = m.publish_ns;
      s.last_index = m.publish_index;
      d_.sessions.push_back(s);
      it = d_.sessions.end() - 1;
    } else {
      // Only forward steps count as gaps: the ring's indices and the camera's numbers only
      // grow. A frame whose announcement was lost was published, so it is no pipeline drop.
      Session& s = *it;
      const double lost = steps_skipped(s.last_index, m.publish_index);
      const double skipped = steps_skipped(s.last_seq, m.frame_seq);
      // Each step is at most 1e15, so it fits a long.
      add_saturating(s.missing_announcements, static_cast<long>(lost));
      add_saturating(s.unpublished_frames, static_cast<long>(std::max(0.0, skipped - lost)));
      s.last_index = std::max(s.last_index, m.publish_index);
      s.last_seq = std::max(s.last_seq, m.frame_seq);
    }
    restart_counted_ = false;
    Session& s = *it;
    s.last_s = t;
    s.last_publish_ns = m.publish_ns;
    s.width = m.width;
    s.height = m.height;
    ++s.frames;
  }

  void add_raw(const drivers::LcmLogEvent& e) {
    // Frame numbers rise within a run; one that does not starts another run.
    const std::int64_t run = raw_run_numbers_.session_of(raw_.frame_seq);
    if (run >= d_.raw_run_count) {
      d_.raw_run_count = run + 1;
      if (d_.raw_runs.size() < LogDigest::kMostRawRuns)
        d_.raw_runs.push_back({0, raw_.width, raw_.height});
    } else {
      // Each step is at most 1e15, so it fits a long.
      add_saturating(d_.raw_missing,
                     static_cast<long>(steps_skipped(last_raw_seq_, raw_.frame_seq)));
    }
    if (static_cast<std::size_t>(run) < d_.raw_runs.size())
      ++d_.raw_runs[static_cast<std::size_t>(run)].pairs;
    last_raw_seq_ = raw_.frame_seq;
    ++d_.raw_pairs;
    d_.raw_bytes += e.data.size();
  }

  static double steps_skipped(std::int64_t from, std::int64_t to) {
    return std::clamp(static_cast<double>(to) - static_cast<double>(from) - 1, 0.0, 1e15);
  }

  void add_stats(double t) {
    // The runtime's counters restart with the pipeline (a reload) and with dcod (a new session
    // since the last DCO_STATS): then the whole count is new. A step down of any counter says
    // so even when the new count has already passed the old one in another.
    const auto count = [](std::int64_t v) { return std::clamp(static_cast<double>(v), 0.0, 1e15); };
    const double pushed = count(stats_.pushed), dropped = count(stats_.dropped),
                 published = count(stats_.published);
    const bool restarted = new_session_ || pushed < last_pushed_ || dropped < last_dropped_ ||
                           published < last_published_;
    const double increment = restarted ? dropped : dropped - last_dropped_;
    last_pushed_ = pushed;
    last_dropped_ = dropped;
    last_published_ = published;
    new_session_ = false;
    if (restarted) restart_counted_ = true;
    d_.stats.push_back({t, static_cast<long>(increment), stats_});
  }

  // A preview whose sides do not match its pixel count cannot be drawn.
  bool plausible_preview(const drivers::LcmLogEvent& e, ChannelTally& tally) {
    const ::dco::depth_preview_t& p = preview_;
    if (ipc::consistent_preview(p) && p.width <= 4096 && p.height <= 4096) return true;
    if (tally.undecodable++ == 0)
      tally.first_problem = fmt::format("event {} at byte {}: a {}x{} preview of {} pixels",
                                        e.number, e.offset, p.width, p.height, p.depth_mm.size());
    return false;
  }

  void add_status(double t) {
    ++d_.status_messages;
    const ::dco::device_status_t* before = d_.has_status ? &d_.last_status : nullptr;
    if (!before || status_.state != before->state || status_.error != before->error ||
        status_.device != before->device) {
      const bool new_state = !before || before->state != status_.state;
      if (before && new_state) ++d_.state_changes;
      if (new_state && status_.state == ::dco::device_status_t::STATE_DISCONNECTED)
        ++d_.disconnects;
      if ((new_state && status_.state == ::dco::device_status_t::STATE_ERROR) ||
          (!status_.error.empty() && (!before || before->error != status_.error)))
        ++d_.device_errors;
      if (d_.status_changes.size() < options_.max_status_changes)
        d_.status_changes.push_back({t, status_});
      else
        ++d_.status_changes_dropped;
    }
    d_.last_status = status_;
    d_.has_status = true;
  }

  void add_log(double t) {
    d_.log_by_level[static_cast<std::size_t>(std::clamp<int>(log_.level, 0, 3))]++;
    if (d_.log.size() < options_.max_log_lines)
      d_.log.push_back({t, log_});
    else
      ++d_.log_lines_dropped;
  }

  // Keeps every stride-th preview; when twice the budget is held, every other one goes and the
  // stride doubles, so the sample stays even over a log of any length.
  void add_preview(double t) {
    if (d_.previews_seen++ % preview_stride_ != 0 || options_.max_previews == 0) return;
    d_.previews.push_back({t, preview_});
    if (d_.previews.size() >= 2 * options_.max_previews) {
      std::size_t kept = 0;
      for (std::size_t i = 0; i < d_.previews.size(); i += 2, ++kept)
        if (kept != i) d_.previews[kept] = std::move(d_.previews[i]);
      d_.previews.resize(kept);
      preview_stride_ *= 2;
    }
  }

  LogDigest& d_;
  const DigestOptions& options_;
  long preview_stride_ = 1;
  double last_pushed_ = 0, last_dropped_ = 0, last_published_ = 0;
  bool new_session_ = false;  // a DCO_DEPTH of a session not seen before since the last stats
  // DCO_STATS counted whole (a restart, or the log's first) since the last DCO_DEPTH.
  bool restart_counted_ = true;
  double last_t_ = 0, earliest_t_ = 0, latest_t_ = 0;
  drivers::FrameSessions raw_run_numbers_;
  ::dco::depth_frame_t depth_;
  ::dco::pipeline_stats_t stats_;
  ::dco::device_status_t status_;
  ::dco::log_event_t log_;
  ::dco::depth_preview_t preview_;
  ::dco::raw_stereo_t raw_;
  std::int64_t last_raw_seq_ = 0;
};

LogDigest read_all(drivers::LcmLogReader& reader, const std::string& name,
                   const DigestOptions& options) {
  LogDigest d;
  d.name = name;
  Digester digester(d, options);
  drivers::LcmLogEvent event;
  // A field log with one bad byte still has hours of good events after it.
  for (bool more = true; more;) {
    while (reader.next(event)) digester.add(event);
    if (reader.damage().empty()) break;
    if (d.damage.empty()) d.damage = reader.damage();
    ++d.damaged_stretches;
    more = reader.resync();
  }
  d.bytes = reader.bytes_read();
  d.skipped_bytes = reader.skipped_bytes();
  if (d.events == 0 && !d.damage.empty())
    throw Error(d.damage +
                (reader.began_like_a_log()
                     ? " (an LCM log damaged before its first whole event: nothing to report)"
                     : " (not an LCM log?)"));
  if (d.events == 0) throw Error(name + ": the log holds no event");
  // Keep the thinned sample within the budget when the last halving left more.
  if (d.previews.size() > options.max_previews) {
    std::vector<PreviewSample> kept;
    const double step =
        static_cast<double>(d.previews.size()) / static_cast<double>(options.max_previews);
    for (std::size_t i = 0; i < options.max_previews; ++i)
      kept.push_back(
          std::move(d.previews[static_cast<std::size_t>(static_cast<double>(i) * step)]));
    d.previews = std::move(kept);
  }
  return d;
}

}  // namespace

LogDigest digest_log(const std::filesystem::path& path, const DigestOptions& options) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  drivers::LcmLogReader reader(path);
  LogDigest d = read_all(reader, path.string(), options);
  d.file_bytes = ec ? d.bytes : size;
  return d;
}

LogDigest digest_log(std::istream& in, const std::string& name, const DigestOptions& options) {
  drivers::LcmLogReader reader(in, name);
  LogDigest d = read_all(reader, name, options);
  d.file_bytes = d.bytes;
  return d;
}

}  // namespace dco::diag
