#pragma once

// What a dcod LCM log holds, gathered in one streaming pass: every published frame's latency,
// the runtime's statistics, the device's state changes, the daemon's log, a sample of the depth
// previews and the raw recording. Memory grows by 8 bytes a frame (a day at 30 fps: 21 MB) and
// about 220 bytes a DCO_STATS (a day at the default 1 Hz: 19 MB); previews, log lines and status
// changes are capped.

#include <array>
#include <cstdint>
#include <filesystem>
#include <istream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "dco/depth_preview_t.hpp"
#include "dco/device_status_t.hpp"
#include "dco/log_event_t.hpp"
#include "dco/pipeline_stats_t.hpp"

namespace dco::diag {

// Counts come from a log, which can say anything: a total stops at the largest long. `n` >= 0.
inline void add_saturating(long& total, long n) {
  total =
      n > std::numeric_limits<long>::max() - total ? std::numeric_limits<long>::max() : total + n;
}

// Times are seconds since the log's first event, by the logger's clock: the one clock every
// channel shares.
struct FramePoint {
  float t_s = 0;
  float latency_ms = 0;  // capture to publication (DCO_DEPTH's publish_ns - capture_ns)
};

struct StatsPoint {
  double t_s = 0;
  long dropped = 0;  // at the pipeline's entry since the previous DCO_STATS (over restarts)
  ::dco::pipeline_stats_t stats;
};

struct StatusChange {
  double t_s = 0;
  ::dco::device_status_t status;  // the first message with a new state or error
};

struct LogLine {
  double t_s = 0;
  ::dco::log_event_t event;
};

struct PreviewSample {
  double t_s = 0;
  ::dco::depth_preview_t preview;
};

// One run of dcod (a ring session): a restart of the daemon starts another.
struct Session {
  std::int64_t id = 0;
  double first_s = 0, last_s = 0;
  long frames = 0;
  std::int64_t first_seq = 0, last_seq = 0;
  std::int64_t last_index = 0;  // highest publish index seen
  std::int64_t first_publish_ns = 0, last_publish_ns = 0;
  // Camera frames between two published ones that were not published (dropped at the pipeline's
  // entry), and publish indices missing from the log (announcements LCM or the logger lost).
  long unpublished_frames = 0;
  long missing_announcements = 0;
  int width = 0, height = 0;
};

// The raw pairs of one dcod run, numbered as a replay numbers them (lcmlog://LOG?run=N is the
// Nth): frame numbers that do not rise start another run.
struct RawRun {
  long pairs = 0;
  int width = 0, height = 0;  // the run's first pair's
};

struct ChannelTally {
  long events = 0;
  std::uint64_t bytes = 0;
  long undecodable = 0;
  std::string first_problem;  // of the first undecodable message
};

struct DigestOptions {
  std::size_t max_previews = 48;          // kept evenly over the log
  std::size_t max_log_lines = 5000;       // DCO_LOG entries kept; the rest are only counted
  std::size_t max_status_changes = 1000;  // the first ones kept; the rest are only counted
};

struct LogDigest {
  std::string name;
  long events = 0;
  std::uint64_t bytes = 0;       // read up to the end or the damage it could not read past
  std::uint64_t file_bytes = 0;  // the whole file, where known
  std::string damage;            // the first damage; empty when the whole log reads
  // Damaged stretches found, and the bytes skipped to read on past them (the events after a
  // damaged stretch are read and counted; a cut at the end is a stretch not read past).
  int damaged_stretches = 0;
  std::uint64_t skipped_bytes = 0;
  std::int64_t first_us = 0;  // the logger's wall clock, µs since the epoch
  double span_s = 0;          // earliest to latest event
  // Steps of more than kClockStepBackS back in the logger's clock (one set back on a headset
  // without a real-time clock): times then run from the first event on both sides of 0.
  static constexpr double kClockStepBackS = 1.0;
  long clock_steps_back = 0;
  long first_step_back_event = 0;
  double first_step_back_s = 0;
  std::map<std::string, ChannelTally> channels;

  std::vector<FramePoint> frames;  // every DCO_DEPTH, in log order
  std::vector<Session> sessions;   // in order of appearance
  std::vector<StatsPoint> stats;   // every DCO_STATS
  long status_messages = 0;
  std::vector<StatusChange> status_changes;  // the first max_status_changes
  long status_changes_dropped = 0;
  // Over every change, kept or not: changes of state, into DISCONNECTED, and faults (into ERROR
  // or a new error text).
  long state_changes = 0, disconnects = 0, device_errors = 0;
  bool has_status = false;
  ::dco::device_status_t last_status;
  std::vector<LogLine> log;
  long log_lines_dropped = 0;
  std::array<long, 4> log_by_level{};  // DEBUG, INFO, WARNING, ERROR
  std::vector<PreviewSample> previews;
  long previews_seen = 0;
  long raw_pairs = 0;
  // Frame numbers between two pairs of a run that no pair holds: dropped by dcod's recorder
  // (it says how many) or lost on the way to the logger. A replay plays the pairs as if
  // consecutive.
  long raw_missing = 0;
  std::uint64_t raw_bytes = 0;
  std::vector<RawRun> raw_runs;  // the first kMostRawRuns
  long raw_run_count = 0;
  static constexpr std::size_t kMostRawRuns = 64;
};

// Reads the log to its end, past damaged stretches to the next whole event (`damage` names the
// first, `skipped_bytes` says how much was passed over); messages on dco's
// channels that do not decode are counted per channel, never trusted. Throws dco::Error when the
// file cannot be opened or holds no LCM event at all.
LogDigest digest_log(const std::filesystem::path& path, const DigestOptions& options = {});
LogDigest digest_log(std::istream& in, const std::string& name, const DigestOptions& options = {});

}  // namespace dco::diag
