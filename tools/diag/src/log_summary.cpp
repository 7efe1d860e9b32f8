#include "dco/diag/log_summary.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "dco/core/printable.hpp"
#include "dco/tools/json.hpp"

namespace dco::diag {
namespace {

std::string human_bytes(std::uint64_t bytes) {
  if (bytes < 10 * 1024) return fmt::format("{} B", bytes);
  if (bytes < 10 * 1024 * 1024) return fmt::format("{} KiB", bytes / 1024);
  return fmt::format("{} MiB", bytes / (1024 * 1024));
}

}  // namespace

std::string right_camera_text(const ::dco::pipeline_stats_t& t) {
  if (t.right_channels != 1 && t.right_channels != 3) return "none reported";
  static const char* const names[] = {"B ", "G ", "R "};
  std::string out;
  for (int c = 0; c < t.right_channels; ++c)
    out += fmt::format("{}{}gain {:.3f}, offset {:+.1f}", c > 0 ? "; " : "",
                       t.right_channels == 3 ? names[c] : "", t.right_gain[c],
                       t.right_level_offset[c]);
  out += fmt::format("; rows {:+.2f}; roll {:+.3f} deg", t.right_row_offset, t.right_roll_deg);
  if (t.lens_falloff != 0) out += fmt::format("; lens fall-off k {:+.3f}", t.lens_falloff);
  return out;
}

const char* device_state_name(std::int8_t state) {
  static const char* const names[] = {"disconnected", "starting", "streaming", "error"};
  return state >= 0 && state <= 3 ? names[state] : "unknown";
}

double percentile(std::vector<float> values, double p) {
  if (values.empty()) return 0;
  const auto rank =
      static_cast<std::size_t>(std::clamp(std::ceil(p / 100.0 * static_cast<double>(values.size())),
                                          1.0, static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(rank - 1), values.end());
  return values[rank - 1];
}

LogSummary summarize(const LogDigest& d) {
  LogSummary s;
  s.frames = static_cast<long>(d.frames.size());
  s.sessions = static_cast<long>(d.sessions.size());
  long intervals = 0;
  double publishing_s = 0;
  for (const Session& session : d.sessions) {
    add_saturating(s.unpublished_frames, session.unpublished_frames);
    add_saturating(s.missing_announcements, session.missing_announcements);
    intervals += session.frames - 1;
    publishing_s += (static_cast<double>(session.last_publish_ns) -
                     static_cast<double>(session.first_publish_ns)) *
                    1e-9;
  }
  if (publishing_s > 0) s.fps = static_cast<double>(intervals) / publishing_s;

  std::vector<float> latency(d.frames.size());
  std::transform(d.frames.begin(), d.frames.end(), latency.begin(),
                 [](const FramePoint& f) { return f.latency_ms; });
  s.latency.frames = s.frames;
  if (!latency.empty()) {
    s.latency.mean_ms =
        std::accumulate(latency.begin(), latency.end(), 0.0) / static_cast<double>(latency.size());
    s.latency.p50_ms = percentile(latency, 50);
    s.latency.p90_ms = percentile(latency, 90);
    s.latency.p99_ms = percentile(latency, 99);
    s.latency.max_ms = *std::max_element(latency.begin(), latency.end());
  }

  for (const StatsPoint& p : d.stats) add_saturating(s.dropped_at_entry, p.dropped);
  if (!d.stats.empty()) {
    s.last_stats = d.stats.back().stats;
    s.row_offset_min = s.row_offset_max = d.stats.front().stats.right_row_offset;
    for (const StatsPoint& p : d.stats) {
      s.row_offset_min = std::min(s.row_offset_min, p.stats.right_row_offset);
      s.row_offset_max = std::max(s.row_offset_max, p.stats.right_row_offset);
      s.entry_high_water = std::max(s.entry_high_water, p.stats.entry_high_water);
      s.stereo_queue_high_water =
          std::max(s.stereo_queue_high_water, p.stats.stereo_queue_high_water);
      s.densify_queue_high_water =
          std::max(s.densify_queue_high_water, p.stats.densify_queue_high_water);
    }
  }

  s.state_changes = d.state_changes;
  s.disconnects = d.disconnects;
  s.device_errors = d.device_errors;
  s.log_errors = d.log_by_level[3];
  s.log_warnings = d.log_by_level[2];
  for (const auto& [name, tally] : d.channels) s.undecodable += tally.undecodable;
  return s;
}

std::string raw_runs_text(const LogDigest& d) {
  if (d.raw_run_count <= 1 && !d.raw_runs.empty())
    return fmt::format("{} pairs of {}x{}", d.raw_pairs, d.raw_runs[0].width, d.raw_runs[0].height);
  constexpr std::size_t kListed = 8;
  std::string runs;
  for (std::size_t i = 0; i < d.raw_runs.size() && i < kListed; ++i)
    runs += fmt::format("{}run {}: {} of {}x{}", i == 0 ? "" : ", ", i + 1, d.raw_runs[i].pairs,
                        d.raw_runs[i].width, d.raw_runs[i].height);
  if (d.raw_run_count > static_cast<long>(kListed))
    runs += fmt::format(", and {} more", d.raw_run_count - static_cast<long>(kListed));
  return fmt::format("{} pairs in {} dcod runs ({}; a replay takes one: lcmlog://LOG?run=N)",
                     d.raw_pairs, d.raw_run_count, runs);
}

std::string clock_text(const LogDigest& d) {
  return fmt::format(
      "the logger's clock stepped back {} time(s), first by {:.2f} s at event {}: times count "
      "from the first event and may be negative",
      d.clock_steps_back, d.first_step_back_s, d.first_step_back_event);
}

std::string text_summary(const LogDigest& d, const LogSummary& s, const std::string& report) {
  std::string out = fmt::format("dco-diag: {}\n", d.name);
  out += fmt::format(
      "  log       {} events, {} over {:.2f} s ({})\n", d.events, human_bytes(d.bytes), d.span_s,
      d.damage.empty()
          ? std::string("read to the end")
          : fmt::format("DAMAGED, read {} of {} bytes{}", d.bytes, d.file_bytes,
                        d.skipped_bytes == 0
                            ? std::string()
                            : fmt::format(", {} bytes skipped past damage", d.skipped_bytes)));
  if (d.clock_steps_back > 0) out += fmt::format("  clock     {}\n", clock_text(d));
  if (!d.damage.empty())
    out += fmt::format(
        "  damage    {}{}\n", d.damage,
        d.damaged_stretches > 1
            ? fmt::format(" (and {} more damaged stretch(es) after it)", d.damaged_stretches - 1)
            : std::string());
  // Text from the log is shown with its control characters as '?': a corrupt or forged log must
  // not move the cursor or retitle the terminal that reads this.
  std::string channels;
  for (const auto& [name, tally] : d.channels)
    channels += fmt::format("{}{} {}", channels.empty() ? "" : ", ", printable(name), tally.events);
  out += fmt::format("  channels  {}\n", channels);
  for (const auto& [name, tally] : d.channels)
    if (tally.undecodable > 0)
      out += fmt::format("  BAD       {}: {} messages do not decode; first: {}\n", printable(name),
                         tally.undecodable, printable(tally.first_problem));
  out += fmt::format(
      "  frames    {} published in {} session{}, {:.1f} fps; {} camera frames not published, {} "
      "announcements missing from the log\n",
      s.frames, s.sessions, s.sessions == 1 ? "" : "s", s.fps, s.unpublished_frames,
      s.missing_announcements);
  if (s.frames > 0)
    out += fmt::format(
        "  latency   p50 {:.2f} ms, p90 {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms, mean {:.2f} ms "
        "(capture to publication)\n",
        s.latency.p50_ms, s.latency.p90_ms, s.latency.p99_ms, s.latency.max_ms, s.latency.mean_ms);
  if (s.last_stats) {
    const ::dco::pipeline_stats_t& t = *s.last_stats;
    out += fmt::format(
        "  stages    stereo {:.2f}/{:.2f} ms, contour {:.2f}/{:.2f} ms, densify {:.2f}/{:.2f} ms "
        "(p50/p99, last DCO_STATS)\n",
        t.stereo_p50_ms, t.stereo_p99_ms, t.contour_p50_ms, t.contour_p99_ms, t.densify_p50_ms,
        t.densify_p99_ms);
    out += fmt::format(
        "  queues    {} dropped at the entry; high water: entry {}, stereo {}, densify {}\n",
        s.dropped_at_entry, s.entry_high_water, s.stereo_queue_high_water,
        s.densify_queue_high_water);
    out += fmt::format("  right cam {} (last DCO_STATS); rows {:+.2f} to {:+.2f} over the log\n",
                       right_camera_text(t), s.row_offset_min, s.row_offset_max);
  }
  if (d.has_status)
    out += fmt::format("  device    {} ({}){}; {} state changes, {} faults, {} disconnects\n",
                       d.last_status.device.empty() ? "?" : printable(d.last_status.device),
                       device_state_name(d.last_status.state),
                       d.last_status.error.empty() ? "" : ": " + printable(d.last_status.error),
                       s.state_changes, s.device_errors, s.disconnects);
  out += fmt::format("  messages  {} errors, {} warnings, {} info in DCO_LOG\n", s.log_errors,
                     s.log_warnings, d.log_by_level[1]);
  if (d.raw_pairs > 0)
    out += fmt::format("  raw       {} on DCO_RAW, {} a pair{}\n", raw_runs_text(d),
                       human_bytes(d.raw_bytes / static_cast<std::uint64_t>(d.raw_pairs)),
                       d.raw_missing > 0 ? fmt::format("; {} frame numbers between them have no "
                                                       "pair (dropped or lost)",
                                                       d.raw_missing)
                                         : std::string());
  if (!report.empty()) out += fmt::format("  report    {}\n", report);
  return out;
}

std::string json_summary(const LogDigest& d, const LogSummary& s) {
  using tools::json_number;
  using tools::json_string;
  // Stage times are null in a log without DCO_STATS.
  const ::dco::pipeline_stats_t t = s.last_stats.value_or(::dco::pipeline_stats_t{});
  const auto stage = [&](double ms) { return s.last_stats ? json_number(ms) : "null"; };
  // The right camera's correction: null without DCO_STATS or with a channel count dcod never sends.
  std::string right_camera = "null";
  if (s.last_stats && (t.right_channels == 1 || t.right_channels == 3)) {
    std::string gain, offset;
    for (int c = 0; c < t.right_channels; ++c) {
      gain += (c > 0 ? ", " : "") + json_number(t.right_gain[c]);
      offset += (c > 0 ? ", " : "") + json_number(t.right_level_offset[c]);
    }
    right_camera = fmt::format(
        "{{\"gain\": [{}], \"level_offset\": [{}], \"row_offset\": {}, \"row_offset_min\": {}, "
        "\"row_offset_max\": {}, \"roll_deg\": {}, \"lens_falloff\": {}}}",
        gain, offset, json_number(t.right_row_offset), json_number(s.row_offset_min),
        json_number(s.row_offset_max), json_number(t.right_roll_deg), json_number(t.lens_falloff));
  }
  std::string channels;
  for (const auto& [name, tally] : d.channels)
    channels += fmt::format("{}{}: {{\"events\": {}, \"bytes\": {}, \"undecodable\": {}}}",
                            channels.empty() ? "" : ", ", json_string(name), tally.events,
                            tally.bytes, tally.undecodable);
  return fmt::format(
      "{{\"log\": {}, \"events\": {}, \"bytes_read\": {}, \"file_bytes\": {}, \"span_s\": {}, "
      "\"damage\": {}, \"damaged_stretches\": {}, \"skipped_bytes\": {},\n \"channels\": {{{}}},\n"
      " \"frames\": {}, \"sessions\": {}, \"fps\": {}, \"unpublished_frames\": {}, "
      "\"missing_announcements\": {}, \"dropped_at_entry\": {},\n"
      " \"latency_ms\": {{\"mean\": {}, \"p50\": {}, \"p90\": {}, \"p99\": {}, \"max\": {}}},\n"
      " \"stage_ms\": {{\"stereo_p50\": {}, \"stereo_p99\": {}, \"contour_p50\": {}, "
      "\"contour_p99\": {}, \"densify_p50\": {}, \"densify_p99\": {}}},\n"
      " \"right_camera\": {},\n"
      " \"state_changes\": {}, \"device_errors\": {}, \"disconnects\": {}, \"log_errors\": {}, "
      "\"log_warnings\": {}, \"previews\": {}, \"raw_pairs\": {}, \"raw_missing\": {}, "
      "\"raw_runs\": {}, \"clock_steps_back\": {}, \"undecodable\": {}}}\n",
      json_string(d.name), d.events, d.bytes, d.file_bytes, json_number(d.span_s),
      d.damage.empty() ? std::string("null") : json_string(d.damage), d.damaged_stretches,
      d.skipped_bytes, channels, s.frames, s.sessions, json_number(s.fps), s.unpublished_frames,
      s.missing_announcements, s.dropped_at_entry, json_number(s.latency.mean_ms),
      json_number(s.latency.p50_ms), json_number(s.latency.p90_ms), json_number(s.latency.p99_ms),
      json_number(s.latency.max_ms), stage(t.stereo_p50_ms), stage(t.stereo_p99_ms),
      stage(t.contour_p50_ms), stage(t.contour_p99_ms), stage(t.densify_p50_ms),
      stage(t.densify_p99_ms), right_camera, s.state_changes, s.device_errors, s.disconnects,
      s.log_errors, s.log_warnings, d.previews_seen, d.raw_pairs, d.raw_missing, d.raw_run_count,
      d.clock_steps_back, s.undecodable);
}

}  // namespace dco::diag
