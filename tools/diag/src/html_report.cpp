#include "dco/diag/html_report.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/error.hpp"
#include "dco/diag/svg_chart.hpp"

namespace dco::diag {
namespace {

const char* level_name(std::int8_t level) {
  static const char* const names[] = {"debug", "info", "warning", "error"};
  return level >= 0 && level <= 3 ? names[level] : "?";
}

std::string h(const std::string& text) {
  return escape_markup(text);
}

std::string row(std::initializer_list<std::string> cells) {
  std::string out = "<tr>";
  for (const auto& c : cells) out += "<td>" + c + "</td>";
  return out + "</tr>\n";
}

// The colour scale of the thumbnails: the 2nd to 98th percentile of the known depths they show.
std::pair<int, int> depth_range(const std::vector<PreviewSample>& previews) {
  std::vector<float> known;
  for (const PreviewSample& p : previews)
    for (const std::int16_t mm : p.preview.depth_mm)
      if (mm > 0 && mm < 32767) known.push_back(mm);
  if (known.empty()) return {300, 10000};
  const int near_mm = static_cast<int>(percentile(known, 2));
  const int far_mm = static_cast<int>(percentile(known, 98));
  return {std::max(1, near_mm), std::max(near_mm + 1, far_mm)};
}

std::string charts(const LogDigest& d) {
  std::string out;
  ChartSeries latency{"per frame", "#c0392b", {}, true};
  for (const FramePoint& f : d.frames) latency.xy.emplace_back(f.t_s, f.latency_ms);
  out += line_chart_svg({"Capture to publication, every frame (DCO_DEPTH)", "log time (s)", "ms"},
                        {latency});
  ChartSeries stereo{"stereo p50", "#2e86c1", {}}, contour{"contour p50", "#28b463", {}},
      densify{"densify p50", "#af7ac5", {}}, p99{"latency p99", "#c0392b", {}},
      fps_in{"in", "#2e86c1", {}}, fps_out{"out", "#28b463", {}},
      drops{"dropped at the entry", "#c0392b", {}}, entry{"entry", "#2e86c1", {}},
      stereo_q{"stereo queue", "#28b463", {}}, densify_q{"densify queue", "#af7ac5", {}},
      rows{"rows below the left's", "#2e86c1", {}}, gain{"gain - 1, %", "#c0392b", {}},
      roll{"roll, 1/100 degree", "#28b463", {}}, falloff{"k", "#af7ac5", {}};
  for (const StatsPoint& p : d.stats) {
    const ::dco::pipeline_stats_t& s = p.stats;
    stereo.xy.emplace_back(p.t_s, s.stereo_p50_ms);
    contour.xy.emplace_back(p.t_s, s.contour_p50_ms);
    densify.xy.emplace_back(p.t_s, s.densify_p50_ms);
    p99.xy.emplace_back(p.t_s, s.latency_p99_ms);
    fps_in.xy.emplace_back(p.t_s, s.fps_in);
    fps_out.xy.emplace_back(p.t_s, s.fps_out);
    drops.xy.emplace_back(p.t_s, static_cast<double>(p.dropped));
    entry.xy.emplace_back(p.t_s, s.entry_high_water);
    stereo_q.xy.emplace_back(p.t_s, s.stereo_queue_high_water);
    densify_q.xy.emplace_back(p.t_s, s.densify_queue_high_water);
    if (s.right_channels == 1 || s.right_channels == 3) {
      rows.xy.emplace_back(p.t_s, s.right_row_offset);
      roll.xy.emplace_back(p.t_s, 100 * s.right_roll_deg);
      // The first channel's: B of a colour camera, whose three gains move together.
      gain.xy.emplace_back(p.t_s, 100 * (s.right_gain[0] - 1));
      falloff.xy.emplace_back(p.t_s, s.lens_falloff);
    }
  }
  out += line_chart_svg({"Stage times over the run so far (DCO_STATS)", "log time (s)", "ms"},
                        {stereo, contour, densify, p99});
  out += line_chart_svg({"Frame rate (DCO_STATS)", "log time (s)", "frames/s"}, {fps_in, fps_out});
  out += line_chart_svg(
      {"Frames dropped at the pipeline entry, per interval (DCO_STATS)", "log time (s)", "frames"},
      {drops});
  out += line_chart_svg({"Queue high water (DCO_STATS)", "log time (s)", "frames"},
                        {entry, stereo_q, densify_q});
  out += line_chart_svg(
      {"The right camera against the left, as the stereo stage corrects it (DCO_STATS)",
       "log time (s)", "rows; %; 1/100 degree"},
      {rows, gain, roll});
  out += line_chart_svg(
      {"Lens fall-off of both cameras, V = 1 - k r^2 (DCO_STATS)", "log time (s)", "k"}, {falloff});
  std::vector<float> values(d.frames.size());
  std::transform(d.frames.begin(), d.frames.end(), values.begin(),
                 [](const FramePoint& f) { return f.latency_ms; });
  out += histogram_svg({"Latency histogram, capture to publication", "ms", "frames"}, values, 40);
  return out;
}

std::string thumbnails(const LogDigest& d) {
  if (d.previews.empty()) return "<p>No depth previews in this log (preview_hz = 0?).</p>\n";
  const auto [near_mm, far_mm] = depth_range(d.previews);
  std::string out = fmt::format(
      "<p>{} of {} previews, evenly over the log; colour from {} mm (red) to {} mm (blue), "
      "black where depth is unknown.</p>\n<div class=\"thumbs\">\n",
      d.previews.size(), d.previews_seen, near_mm, far_mm);
  for (const PreviewSample& p : d.previews) {
    const int scale = std::max(1, 160 / std::max(1, p.preview.width));
    const std::string png = preview_png(p.preview, near_mm, far_mm, scale);
    out += fmt::format(
        "<figure><img alt=\"depth of frame {0}\" src=\"data:image/png;base64,{1}\"><figcaption>"
        "{2:.2f} s, frame {0}</figcaption></figure>\n",
        p.preview.frame_seq, base64(reinterpret_cast<const unsigned char*>(png.data()), png.size()),
        p.t_s);
  }
  return out + "</div>\n";
}

std::string device_section(const LogDigest& d) {
  if (d.status_messages == 0) return "<p>No DCO_STATUS in this log.</p>\n";
  std::string out = fmt::format(
      "<p>{} status messages; the changes of state or fault:</p>\n<table>\n<tr><th>time "
      "(s)</th><th>state</th><th>device</th><th>serial</th><th>firmware</th><th>USB "
      "Mbit/s</th><th>fault</th></tr>\n",
      d.status_messages);
  for (const StatusChange& c : d.status_changes) {
    const ::dco::device_status_t& s = c.status;
    out +=
        row({fmt::format("{:.2f}", c.t_s),
             fmt::format("<span class=\"{0}\">{0}</span>", device_state_name(s.state)), h(s.device),
             h(s.serial), h(s.firmware), std::to_string(s.usb_speed_mbps), h(s.error)});
  }
  out += "</table>\n";
  if (d.status_changes_dropped > 0)
    out += fmt::format("<p>{} later changes are not listed; the counts include them.</p>\n",
                       d.status_changes_dropped);
  const ::dco::device_status_t& last = d.last_status;
  const auto n = std::min({static_cast<std::size_t>(std::max(0, last.counter_count)),
                           last.counter_names.size(), last.counter_values.size()});
  if (n == 0) return out;
  out += "<p>The driver's counters at the end:</p>\n<table>\n";
  for (std::size_t i = 0; i < n; ++i)
    out += row({h(last.counter_names[i]), std::to_string(last.counter_values[i])});
  return out + "</table>\n";
}

std::string log_section(const LogDigest& d) {
  std::string out = fmt::format(
      "<p>{} errors, {} warnings, {} info, {} debug.{}</p>\n", d.log_by_level[3], d.log_by_level[2],
      d.log_by_level[1], d.log_by_level[0],
      d.log_lines_dropped > 0 ? fmt::format(" The first {} are listed, {} more are not.",
                                            d.log.size(), d.log_lines_dropped)
                              : std::string());
  if (d.log.empty()) return out;
  out += "<table>\n<tr><th>time (s)</th><th>level</th><th>source</th><th>message</th></tr>\n";
  for (const LogLine& l : d.log)
    out += row({fmt::format("{:.2f}", l.t_s),
                fmt::format("<span class=\"{0}\">{0}</span>", level_name(l.event.level)),
                h(l.event.source), h(l.event.text)});
  return out + "</table>\n";
}

std::string summary_section(const LogDigest& d, const LogSummary& s) {
  std::string out = "<table>\n";
  out += row({"log", fmt::format("{} events, {} bytes read of {}, over {:.2f} s", d.events, d.bytes,
                                 d.file_bytes, d.span_s)});
  if (d.clock_steps_back > 0) out += row({"clock", clock_text(d)});
  out += row({"frames", fmt::format("{} published in {} session(s), {:.2f} fps", s.frames,
                                    s.sessions, s.fps)});
  out += row({"not published", fmt::format("{} camera frames (gaps in frame numbers); {} dropped "
                                           "at the pipeline entry by DCO_STATS",
                                           s.unpublished_frames, s.dropped_at_entry)});
  out += row(
      {"missing from the log", fmt::format("{} DCO_DEPTH announcements (gaps in publish indices)",
                                           s.missing_announcements)});
  out += row({"latency", fmt::format("p50 {:.2f} ms, p90 {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms, "
                                     "mean {:.2f} ms",
                                     s.latency.p50_ms, s.latency.p90_ms, s.latency.p99_ms,
                                     s.latency.max_ms, s.latency.mean_ms)});
  if (const auto& t = s.last_stats)
    out += row({"stages (p50/p99)",
                fmt::format("stereo {:.2f}/{:.2f} ms, contour {:.2f}/{:.2f} ms, densify "
                            "{:.2f}/{:.2f} ms",
                            t->stereo_p50_ms, t->stereo_p99_ms, t->contour_p50_ms,
                            t->contour_p99_ms, t->densify_p50_ms, t->densify_p99_ms)});
  out += row({"device", fmt::format("{} state changes, {} faults, {} disconnects", s.state_changes,
                                    s.device_errors, s.disconnects)});
  out += row({"messages", fmt::format("{} errors, {} warnings", s.log_errors, s.log_warnings)});
  if (d.raw_pairs > 0)
    out += row(
        {"raw recording", fmt::format("{}, {} bytes; {} frame numbers between them without a pair",
                                      raw_runs_text(d), d.raw_bytes, d.raw_missing)});
  out +=
      "</table>\n<h3>Sessions</h3>\n<table>\n<tr><th>session</th><th>from (s)</th><th>to "
      "(s)</th><th>size</th><th>frames</th><th>frame numbers</th><th>not published</th><th>"
      "missing from the log</th></tr>\n";
  for (const Session& x : d.sessions)
    out += row({fmt::format("{:016x}", static_cast<std::uint64_t>(x.id)),
                fmt::format("{:.2f}", x.first_s), fmt::format("{:.2f}", x.last_s),
                fmt::format("{}x{}", x.width, x.height), std::to_string(x.frames),
                fmt::format("{}-{}", x.first_seq, x.last_seq), std::to_string(x.unpublished_frames),
                std::to_string(x.missing_announcements)});
  out +=
      "</table>\n<h3>Channels</h3>\n<table>\n<tr><th>channel</th><th>messages</th><th>bytes"
      "</th><th>undecodable</th></tr>\n";
  for (const auto& [name, t] : d.channels)
    out += row({h(name), std::to_string(t.events), std::to_string(t.bytes),
                t.undecodable == 0 ? "0"
                                   : fmt::format("<span class=\"error\">{}</span> (first: {})",
                                                 t.undecodable, h(t.first_problem))});
  return out + "</table>\n";
}

}  // namespace

std::string base64(const unsigned char* data, std::size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t n = static_cast<std::uint32_t>(data[i]) << 16 |
                            (i + 1 < size ? static_cast<std::uint32_t>(data[i + 1]) << 8 : 0) |
                            (i + 2 < size ? static_cast<std::uint32_t>(data[i + 2]) : 0);
    out += kAlphabet[n >> 18 & 63];
    out += kAlphabet[n >> 12 & 63];
    out += i + 1 < size ? kAlphabet[n >> 6 & 63] : '=';
    out += i + 2 < size ? kAlphabet[n & 63] : '=';
  }
  return out;
}

std::string preview_png(const ::dco::depth_preview_t& p, int near_mm, int far_mm, int scale) {
  if (p.width < 1 || p.height < 1 ||
      static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height) != p.depth_mm.size())
    throw Error(fmt::format("depth preview of frame {}: {}x{} but {} pixels", p.frame_seq, p.width,
                            p.height, p.depth_mm.size()));
  // Inverse depth spreads the colours where a headset cares: near things.
  const double inv_near = 1.0 / near_mm, inv_far = 1.0 / far_mm;
  cv::Mat level(p.height, p.width, CV_8UC1);
  cv::Mat unknown(p.height, p.width, CV_8UC1);
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const int mm = p.depth_mm[static_cast<std::size_t>(y * p.width + x)];
      const double t = mm > 0 ? (1.0 / mm - inv_far) / (inv_near - inv_far) : 0;
      level.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(std::clamp(t, 0.0, 1.0) * 255);
      unknown.at<std::uint8_t>(y, x) = mm <= 0 ? 255 : 0;
    }
  cv::Mat colour;
  cv::applyColorMap(level, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), unknown);
  cv::Mat big;
  cv::resize(colour, big, {}, scale, scale, cv::INTER_NEAREST);
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", big, bytes)) throw Error("PNG encoding of a depth preview failed");
  return std::string(bytes.begin(), bytes.end());
}

std::string html_report(const LogDigest& d, const LogSummary& s) {
  std::string out = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>dco-diag: "
      "{0}</title>\n<style>\nbody{{font-family:sans-serif;margin:1.5em;max-width:1100px}}"
      "table{{border-collapse:collapse;margin:.5em 0}}td,th{{border:1px solid #ccc;padding:2px "
      "8px;text-align:left;font-size:13px}}.error{{color:#b00;font-weight:bold}}.warning{{color:"
      "#a60}}.damage{{background:#fdd;border:1px solid #b00;padding:.5em}}svg{{display:block;"
      "margin:.7em 0}}.thumbs{{display:flex;flex-wrap:wrap;gap:6px}}figure{{margin:0}}figcaption"
      "{{font-size:11px;color:#555}}img{{image-rendering:pixelated}}\n</style>\n</head>\n<body>\n"
      "<h1>dco-diag: {0}</h1>\n",
      h(d.name));
  if (!d.damage.empty())
    out += fmt::format(
        "<p class=\"damage\">The log is damaged: read {} of {} bytes{}. {}</p>\n", d.bytes,
        d.file_bytes,
        d.skipped_bytes == 0
            ? std::string()
            : fmt::format(", {} damaged stretch(es) and {} bytes skipped to read on past them",
                          d.damaged_stretches, d.skipped_bytes),
        h(d.damage));
  out += "<h2>Summary</h2>\n" + summary_section(d, s);
  out += "<h2>Timing</h2>\n" + charts(d);
  out += "<h2>Depth</h2>\n" + thumbnails(d);
  out += "<h2>Device</h2>\n" + device_section(d);
  out += "<h2>Daemon log</h2>\n" + log_section(d);
  return out + "</body>\n</html>\n";
}

}  // namespace dco::diag
