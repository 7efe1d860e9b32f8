#pragma once

// The key numbers of a digested log, as a person reads them (text) and as a script does (JSON).

#include <optional>
#include <string>
#include <vector>

#include "dco/diag/log_digest.hpp"

namespace dco::diag {

struct LatencySummary {
  long frames = 0;
  double mean_ms = 0, p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
};

struct LogSummary {
  long frames = 0;
  long sessions = 0;
  double fps = 0;  // published frames per second of publishing, over all sessions
  long unpublished_frames = 0;
  long missing_announcements = 0;
  long dropped_at_entry = 0;  // the runtime's own count (DCO_STATS), over restarts
  LatencySummary latency;
  // The last DCO_STATS: stage times over that run so far.
  std::optional<::dco::pipeline_stats_t> last_stats;
  int entry_high_water = 0, stereo_queue_high_water = 0, densify_queue_high_water = 0;
  // The right camera's rows below the left's, as the stereo stage fitted them, over the log's
  // DCO_STATS: a calibration that drifts while the headset warms up shows as a spread.
  double row_offset_min = 0, row_offset_max = 0;
  long state_changes = 0;
  long device_errors = 0;  // status changes into ERROR or with a new fault
  long disconnects = 0;
  long log_errors = 0, log_warnings = 0;
  long undecodable = 0;
};

// The stereo stage's correction of the right camera in a DCO_STATS message: "gain 0.976, offset
// +0.1; rows +0.31" (per channel B, G, R for a colour camera); "none reported" when the message
// names no channel count dcod sends (1 or 3).
std::string right_camera_text(const ::dco::pipeline_stats_t& stats);

// DCO_STATUS's state as a word ("streaming"); "unknown" for values the type does not define.
const char* device_state_name(std::int8_t state);

// p in [0, 100]: the nearest-rank percentile (the smallest value with at least p % of the values
// at or below it); 0 for no values.
double percentile(std::vector<float> values, double p);

LogSummary summarize(const LogDigest& digest);

// The raw recording's pairs and, when the log holds several dcod runs, each run's count and size.
std::string raw_runs_text(const LogDigest& digest);
// What the logger's clock stepping back means for the times shown (digest.clock_steps_back > 0).
std::string clock_text(const LogDigest& digest);

// A few lines for a terminal; `report` names the HTML file when one was written.
std::string text_summary(const LogDigest& digest, const LogSummary& summary,
                         const std::string& report);
// One JSON object with the same numbers (and the damage, if any).
std::string json_summary(const LogDigest& digest, const LogSummary& summary);

}  // namespace dco::diag
