// dco-diag's report: the key numbers of a log written here with known frames, drops, restarts,
// device faults and messages; logs cut anywhere; the HTML's self-containment and escaping; the
// charts' ticks and thinning; thumbnails; and the binary's exit codes.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "dco/core/error.hpp"
#include "dco/diag/html_report.hpp"
#include "dco/diag/log_digest.hpp"
#include "dco/diag/log_summary.hpp"
#include "dco/diag/svg_chart.hpp"
#include "dco/drivers/lcm_log.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "support/lcm_bytes.hpp"

namespace dco::diag {
namespace {

using drivers::LcmLogEvent;
constexpr std::int64_t kStartUs = 1'700'000'000'000'000;

using dco::testing::lcm_bytes;

// A log of two dcod runs whose every number is known.
class KnownLog {
 public:
  KnownLog() {
    // Run 1: 30 fps, frames 0..49 with 10, 11, 12 dropped at the entry; the announcement of
    // publish index 20 never reached the logger. Latency of the k-th published frame: 10 + k ms.
    status(0.0, ::dco::device_status_t::STATE_STARTING, "");
    std::int64_t index = 0;
    for (int seq = 0; seq < 50; ++seq) {
      if (seq >= 10 && seq <= 12) continue;
      ++index;
      const double t = seq / 30.0;
      const double latency_ms = 10 + static_cast<double>(index - 1);
      if (index != 20) {
        frame(t, 0x1111, index, seq, latency_ms);
        latencies.push_back(static_cast<float>(latency_ms));
      }
      if (seq == 1) status(t, ::dco::device_status_t::STATE_STREAMING, "");
    }
    stats(0.5, 0);
    stats(1.0, 3);
    stats(1.5, 5);
    status(1.6, ::dco::device_status_t::STATE_DISCONNECTED, "");
    log(1.6, ::dco::log_event_t::LEVEL_WARNING, "camera <unplugged> & gone");
    status(1.7, ::dco::device_status_t::STATE_STREAMING, "");
    status(1.8, ::dco::device_status_t::STATE_STREAMING, "");  // no change: not listed
    status(1.9, ::dco::device_status_t::STATE_ERROR, "usb: babble");
    log(1.9, ::dco::log_event_t::LEVEL_ERROR, "usb: babble");
    log(1.95, ::dco::log_event_t::LEVEL_INFO, "restarting");
    // Run 2 (a restart of dcod): ten frames of 100 ms, at 10 fps; the runtime's count restarts.
    for (int k = 0; k < 10; ++k) {
      frame(2.0 + k * 0.1, 0x2222, k + 1, 1000 + k, 100);
      latencies.push_back(100);
    }
    stats(3.0, 2);
    log(3.0, ::dco::log_event_t::LEVEL_WARNING, "slow");
    for (int k = 0; k < 100; ++k) preview(3.0 + k * 0.01, k);
    add(3.5, "DCO_STATS", {1, 2, 3});    // does not decode
    add(3.6, "SOMETHING_ELSE", {4, 5});  // not ours: counted only
  }

  std::string bytes() const {
    std::ostringstream out;
    for (const LcmLogEvent& e : events) drivers::write_lcm_log_event(out, e);
    return out.str();
  }

  std::vector<LcmLogEvent> events;
  std::vector<float> latencies;

 private:
  void add(double t, const std::string& channel, std::vector<std::uint8_t> data) {
    LcmLogEvent e;
    e.number = static_cast<std::int64_t>(events.size());
    e.timestamp_us = kStartUs + std::llround(t * 1e6);
    e.channel = channel;
    e.data = std::move(data);
    events.push_back(std::move(e));
  }
  void frame(double t, std::int64_t session, std::int64_t index, std::int64_t seq,
             double latency_ms) {
    ::dco::depth_frame_t m{};
    m.session_id = session;
    m.slot = static_cast<std::int32_t>(index % 4);
    m.publish_index = index;
    m.frame_seq = seq;
    m.publish_ns = 5'000'000'000 + std::llround(t * 1e9);
    m.capture_ns = m.publish_ns - std::llround(latency_ms * 1e6);
    m.width = 64;
    m.height = 48;
    add(t, ipc::channel::kDepth, lcm_bytes(m));
  }
  void stats(double t, std::int64_t dropped) {
    ::dco::pipeline_stats_t m{};
    m.dropped = dropped;
    m.stereo_p50_ms = t;
    m.stereo_p99_ms = 2 * t;
    m.densify_p50_ms = 0.5;
    m.entry_high_water = dropped > 4 ? 2 : 1;
    // A right camera 2.4 % brighter, turned 0.02 degrees, whose rows drift from 0.25 above the
    // left's to 1 below; both lenses darken by 15 % at the corners.
    m.right_channels = 1;
    m.right_gain[0] = 0.976;
    m.right_level_offset[0] = 0.1;
    m.right_row_offset = t / 2 - 0.5;
    m.right_roll_deg = 0.02;
    m.lens_falloff = 0.15;
    add(t, ipc::channel::kStats, lcm_bytes(m));
  }
  void status(double t, std::int8_t state, const std::string& error) {
    ::dco::device_status_t m{};
    m.state = state;
    m.device = "indemind test";
    m.error = error;
    m.counter_count = 1;
    m.counter_names = {"frames"};
    m.counter_values = {static_cast<std::int64_t>(t * 30)};
    add(t, ipc::channel::kStatus, lcm_bytes(m));
  }
  void log(double t, std::int8_t level, const std::string& text) {
    ::dco::log_event_t m{};
    m.level = level;
    m.source = "dcod";
    m.text = text;
    add(t, ipc::channel::kLog, lcm_bytes(m));
  }
  void preview(double t, std::int64_t seq) {
    ::dco::depth_preview_t m{};
    m.frame_seq = seq;
    m.width = 4;
    m.height = 3;
    m.num_pixels = 12;
    m.depth_mm = {0, 500, 1000, 2000, 4000, 32767, 800, 800, 800, 900, 900, 900};
    add(t, ipc::channel::kDepthPreview, lcm_bytes(m));
  }
};

TEST(LogDigest, KeyNumbersOfAKnownLog) {
  const KnownLog known;
  std::istringstream in(known.bytes());
  DigestOptions options;
  options.max_previews = 10;
  const LogDigest d = digest_log(in, "known.log", options);
  EXPECT_TRUE(d.damage.empty()) << d.damage;
  EXPECT_EQ(d.events, static_cast<long>(known.events.size()));
  EXPECT_EQ(d.bytes, known.bytes().size());
  EXPECT_NEAR(d.span_s, 3.99, 1e-6);  // the latest event, not the last one
  EXPECT_EQ(d.channels.at("SOMETHING_ELSE").events, 1);
  EXPECT_EQ(d.channels.at("DCO_STATS").undecodable, 1);
  EXPECT_NE(d.channels.at("DCO_STATS").first_problem.find("event "), std::string::npos);

  const LogSummary s = summarize(d);
  EXPECT_EQ(s.frames, 46 + 10);
  ASSERT_EQ(s.sessions, 2);
  EXPECT_EQ(d.sessions[0].frames, 46);
  EXPECT_EQ(d.sessions[0].first_seq, 0);
  EXPECT_EQ(d.sessions[0].last_seq, 49);
  EXPECT_EQ(s.unpublished_frames, 3);
  EXPECT_EQ(s.missing_announcements, 1);
  // Run 1 publishes 46 frames over 49/30 s, run 2 ten over 0.9 s.
  EXPECT_NEAR(s.fps, (45 + 9) / (49 / 30.0 + 0.9), 1e-6);
  EXPECT_EQ(s.dropped_at_entry, 5 + 2);
  EXPECT_EQ(s.undecodable, 1);

  // 56 latencies: 10..55 ms without the one of index 20 (29 ms), and ten of 100 ms.
  EXPECT_EQ(s.latency.frames, 56);
  EXPECT_NEAR(s.latency.max_ms, 100, 1e-3);
  EXPECT_NEAR(s.latency.p50_ms, 38, 1e-3);  // the 28th smallest: 10..28, 30..38
  EXPECT_NEAR(s.latency.p90_ms, 100, 1e-3);
  double sum = 0;
  for (const float v : known.latencies) sum += v;
  EXPECT_NEAR(s.latency.mean_ms, sum / 56, 1e-3);
  ASSERT_TRUE(s.last_stats);
  EXPECT_DOUBLE_EQ(s.last_stats->stereo_p50_ms, 3.0);
  EXPECT_EQ(s.entry_high_water, 2);

  // starting -> streaming -> disconnected -> streaming -> error: four changes, one of them a
  // disconnect, one a fault.
  EXPECT_EQ(d.status_messages, 6);
  EXPECT_EQ(d.status_changes.size(), 5u);
  EXPECT_EQ(s.state_changes, 4);
  EXPECT_EQ(s.disconnects, 1);
  EXPECT_EQ(s.device_errors, 1);
  EXPECT_EQ(d.last_status.error, "usb: babble");
  EXPECT_EQ(s.log_errors, 1);
  EXPECT_EQ(s.log_warnings, 2);
  EXPECT_EQ(d.log_by_level[1], 1);

  // 100 previews thinned to at most 10, spread over the whole run.
  EXPECT_EQ(d.previews_seen, 100);
  ASSERT_GE(d.previews.size(), 5u);
  ASSERT_LE(d.previews.size(), 10u);
  EXPECT_LE(d.previews.front().preview.frame_seq, 10);
  EXPECT_GE(d.previews.back().preview.frame_seq, 80);
  for (std::size_t i = 1; i < d.previews.size(); ++i)
    EXPECT_GT(d.previews[i].preview.frame_seq, d.previews[i - 1].preview.frame_seq);

  const std::string text = text_summary(d, s, "known.log.html");
  EXPECT_NE(text.find("56 published in 2 sessions"), std::string::npos) << text;
  EXPECT_NE(text.find("3 camera frames not published, 1 announcements missing"), std::string::npos)
      << text;
  EXPECT_NE(text.find("BAD       DCO_STATS: 1 messages do not decode"), std::string::npos) << text;
  EXPECT_NE(text.find("right cam gain 0.976, offset +0.1; rows +1.00; roll +0.020 deg; lens "
                      "fall-off k +0.150 (last DCO_STATS); rows -0.25 to +1.00 over the log"),
            std::string::npos)
      << text;
  const std::string json = json_summary(d, s);
  EXPECT_NE(json.find("\"right_camera\": {\"gain\": [0.976], \"level_offset\": [0.1], "
                      "\"row_offset\": 1, \"row_offset_min\": -0.25, \"row_offset_max\": 1, "
                      "\"roll_deg\": 0.02, \"lens_falloff\": 0.15}"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"frames\": 56,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"dropped_at_entry\": 7,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"damage\": null"), std::string::npos) << json;
}

// A device that flaps all day must not fill memory: the list stops, the counts go on.
TEST(LogDigest, StatusChangesPastTheCapAreCountedNotKept) {
  const KnownLog known;
  std::istringstream in(known.bytes());
  DigestOptions options;
  options.max_status_changes = 2;
  const LogDigest d = digest_log(in, "known.log", options);
  const LogSummary s = summarize(d);
  ASSERT_EQ(d.status_changes.size(), 2u);
  EXPECT_EQ(d.status_changes[1].status.state, +::dco::device_status_t::STATE_STREAMING);
  EXPECT_EQ(d.status_changes_dropped, 3);
  EXPECT_EQ(s.state_changes, 4);
  EXPECT_EQ(s.disconnects, 1);
  EXPECT_EQ(s.device_errors, 1);
  EXPECT_EQ(d.last_status.error, "usb: babble");
  EXPECT_NE(html_report(d, s).find("3 later changes are not listed"), std::string::npos);
}

TEST(LogSummary, TheRightCameraNamesEachChannelOfAColourCamera) {
  ::dco::pipeline_stats_t m{};
  EXPECT_EQ(right_camera_text(m), "none reported");  // a channel count dcod never sends
  m.right_channels = 3;
  m.right_gain[0] = 0.98;
  m.right_gain[1] = 0.99;
  m.right_gain[2] = 1.0;
  m.right_level_offset[1] = -2;
  m.right_row_offset = -0.5;
  m.right_roll_deg = -0.125;
  EXPECT_EQ(right_camera_text(m),
            "B gain 0.980, offset +0.0; G gain 0.990, offset -2.0; R gain 1.000, offset +0.0; "
            "rows -0.50; roll -0.125 deg");
  m.lens_falloff = 0.15;  // shown once the stage corrects one
  EXPECT_EQ(right_camera_text(m),
            "B gain 0.980, offset +0.0; G gain 0.990, offset -2.0; R gain 1.000, offset +0.0; "
            "rows -0.50; roll -0.125 deg; lens fall-off k +0.150");
}

// A log can hold any count: the totals stop at the largest long instead of wrapping negative.
TEST(LogDigest, HugeCountsSaturate) {
  std::ostringstream out;
  for (int i = 0; i < 20000; ++i) {
    ::dco::pipeline_stats_t m{};
    m.dropped = i % 2 == 0 ? 1'000'000'000'000'000 : 0;  // each step down restarts the count
    LcmLogEvent e;
    e.number = i;
    e.timestamp_us = kStartUs + i * 1000;
    e.channel = ipc::channel::kStats;
    e.data = lcm_bytes(m);
    drivers::write_lcm_log_event(out, e);
  }
  std::istringstream in(out.str());
  const LogDigest d = digest_log(in, "huge.log", DigestOptions{});
  const LogSummary s = summarize(d);
  EXPECT_EQ(s.dropped_at_entry, std::numeric_limits<long>::max());
  EXPECT_NE(text_summary(d, s, "huge.log.html").find("9223372036854775807 dropped at the entry"),
            std::string::npos);
}

// Raw pairs whose frame numbers skip (dropped by the recorder, lost on the way to the logger) are
// counted: a replay plays them as if consecutive. A number that goes back starts another run.
TEST(LogDigest, FrameNumbersWithoutARawPairAreCounted) {
  std::ostringstream out;
  std::int64_t number = 0;
  for (const std::int64_t seq : {0, 1, 2, 5, 6, 0, 1, 3}) {
    ::dco::raw_stereo_t m{};
    m.frame_seq = seq;
    m.width = 8;
    m.height = 4;
    LcmLogEvent e;
    e.number = number;
    e.timestamp_us = kStartUs + number * 1000;
    ++number;
    e.channel = ipc::channel::kRaw;
    e.data = lcm_bytes(m);
    drivers::write_lcm_log_event(out, e);
  }
  std::istringstream in(out.str());
  const LogDigest d = digest_log(in, "gaps.log", DigestOptions{});
  EXPECT_EQ(d.raw_pairs, 8);
  EXPECT_EQ(d.raw_missing, 3);
  EXPECT_NE(text_summary(d, summarize(d), "").find("3 frame numbers between them have no pair"),
            std::string::npos)
      << text_summary(d, summarize(d), "");
}

// The drops of a restarted pipeline or dcod count whole, even where the new count has already
// reached the old one when its first DCO_STATS is sent.
TEST(LogDigest, DropsAfterARestartCountWhole) {
  std::ostringstream out;
  std::int64_t number = 0;
  const auto add = [&](const std::string& channel, std::vector<std::uint8_t> data) {
    LcmLogEvent e;
    e.number = number;
    e.timestamp_us = kStartUs + number * 1000;
    ++number;
    e.channel = channel;
    e.data = std::move(data);
    drivers::write_lcm_log_event(out, e);
  };
  const auto frame = [&](std::int64_t session) {
    ::dco::depth_frame_t m{};
    m.session_id = session;
    m.publish_index = 1;
    m.width = 64;
    m.height = 48;
    add(ipc::channel::kDepth, lcm_bytes(m));
  };
  const auto stats = [&](std::int64_t pushed, std::int64_t dropped) {
    ::dco::pipeline_stats_t m{};
    m.pushed = pushed;
    m.dropped = dropped;
    m.published = pushed - dropped;
    add(ipc::channel::kStats, lcm_bytes(m));
  };
  frame(0x1111);
  stats(100, 3);
  stats(200, 3);
  frame(0x2222);  // a new dcod
  stats(50, 7);
  stats(60, 8);
  stats(20, 9);  // a reload restarts the pipeline: pushed steps down
  std::istringstream in(out.str());
  const LogSummary s = summarize(digest_log(in, "restarts.log", DigestOptions{}));
  EXPECT_EQ(s.dropped_at_entry, 3 + 8 + 9);
}

// A log of hand-made events, a millisecond apart unless given a time.
class EventLog {
 public:
  void add(const std::string& channel, std::vector<std::uint8_t> data, double t_s = -1) {
    LcmLogEvent e;
    e.number = number_;
    e.timestamp_us =
        kStartUs + (t_s >= 0 ? std::llround(t_s * 1e6) : static_cast<std::int64_t>(number_) * 1000);
    ++number_;
    e.channel = channel;
    e.data = std::move(data);
    drivers::write_lcm_log_event(out_, e);
  }
  void frame(std::int64_t session, std::int64_t index, double t_s = -1) {
    ::dco::depth_frame_t m{};
    m.session_id = session;
    m.publish_index = index;
    m.frame_seq = index;
    m.width = 64;
    m.height = 48;
    add(ipc::channel::kDepth, lcm_bytes(m), t_s);
  }
  void stats(std::int64_t pushed, std::int64_t dropped, std::int64_t published) {
    ::dco::pipeline_stats_t m{};
    m.pushed = pushed;
    m.dropped = dropped;
    m.published = published;
    add(ipc::channel::kStats, lcm_bytes(m));
  }
  void raw(std::int64_t seq, int width, int height) {
    ::dco::raw_stereo_t m{};
    m.frame_seq = seq;
    m.width = width;
    m.height = height;
    add(ipc::channel::kRaw, lcm_bytes(m));
  }
  LogDigest digest(const std::string& name) const {
    std::istringstream in(out_.str());
    return digest_log(in, name, DigestOptions{});
  }

 private:
  std::ostringstream out_;
  std::int64_t number_ = 0;
};

// dcod sends DCO_STATS while it starts, before its first frame: those count whole once, and the
// stats after the first frame add to them, not count whole again.
TEST(LogDigest, DropsBeforeASessionsFirstFrameCountOnce) {
  EventLog log;
  log.stats(30, 20, 0);  // warming up: the log starts here
  for (int i = 1; i <= 10; ++i) log.frame(0x1111, i);
  log.stats(60, 25, 35);
  log.stats(10, 4, 0);  // a new dcod, still starting: the counts step down
  for (int i = 1; i <= 10; ++i) log.frame(0x2222, i);
  log.stats(40, 6, 30);
  EXPECT_EQ(summarize(log.digest("starting.log")).dropped_at_entry, 25 + 6);
}

// A pair's frame number with a flipped high bit (LCM messages carry no checksum) must not wrap
// the count of numbers without a pair.
TEST(LogDigest, FrameNumbersFarAheadSaturateTheMissingCount) {
  EventLog log;
  constexpr std::int64_t kFlip = std::int64_t{1} << 62;
  for (const std::int64_t seq :
       {std::int64_t{0}, std::int64_t{1}, std::int64_t{2}, kFlip | 3, std::int64_t{4},
        std::int64_t{5}, kFlip | 6, std::int64_t{7}, kFlip | 8})
    log.raw(seq, 8, 4);
  const LogDigest d = log.digest("flipped.log");
  EXPECT_EQ(d.raw_missing, 3'000'000'000'000'000);
  EXPECT_EQ(d.raw_run_count, 3);
  EXPECT_NE(json_summary(d, summarize(d)).find("\"raw_missing\": 3000000000000000"),
            std::string::npos);
}

// The runs of a log are counted and each one's size given: a replay takes one run at a time.
TEST(LogDigest, RawPairsOfSeveralRunsShowEachRunsSize) {
  EventLog log;
  for (int seq = 0; seq < 5; ++seq) log.raw(seq, 1280, 800);
  for (int seq = 0; seq < 3; ++seq) log.raw(seq, 640, 400);
  const LogDigest d = log.digest("runs.log");
  EXPECT_EQ(d.raw_run_count, 2);
  const std::string text = text_summary(d, summarize(d), "");
  EXPECT_NE(text.find("8 pairs in 2 dcod runs (run 1: 5 of 1280x800, run 2: 3 of 640x400"),
            std::string::npos)
      << text;
  EventLog one;
  for (int seq = 0; seq < 5; ++seq) one.raw(seq, 1280, 800);
  EXPECT_NE(text_summary(one.digest("one.log"), summarize(one.digest("one.log")), "")
                .find("5 pairs of 1280x800 on DCO_RAW"),
            std::string::npos);
}

// A logger whose clock was set back (a headset without a real-time clock): the span is the
// stamps' extent, and the step is said.
TEST(LogDigest, ALoggerClockThatStepsBackIsSaid) {
  EventLog log;
  log.frame(0x1111, 1, 3600.0);
  for (int i = 2; i <= 300; ++i) log.frame(0x1111, i, i * 0.033);
  const LogDigest d = log.digest("clock.log");
  EXPECT_EQ(d.clock_steps_back, 1);
  EXPECT_EQ(d.first_step_back_event, 1);
  EXPECT_NEAR(d.first_step_back_s, 3600 - 0.066, 1e-3);
  EXPECT_NEAR(d.span_s, 3600 - 0.066, 1e-3);
  EXPECT_NE(text_summary(d, summarize(d), "").find("clock     the logger's clock stepped back 1"),
            std::string::npos)
      << text_summary(d, summarize(d), "");
}

// Channel names, device text and decode problems come from the log: the text report shows their
// control characters as '?', so a forged log cannot send escape sequences to a terminal.
TEST(LogSummary, TextFromTheLogReachesTheTerminalWithoutControlCharacters) {
  std::ostringstream out;
  const auto add = [&](const std::string& channel, std::vector<std::uint8_t> data) {
    LcmLogEvent e;
    e.number = 0;
    e.timestamp_us = kStartUs;
    e.channel = channel;
    e.data = std::move(data);
    drivers::write_lcm_log_event(out, e);
  };
  ::dco::device_status_t status{};
  status.state = ::dco::device_status_t::STATE_ERROR;
  status.device = "cam\x1b[2J";
  status.error = "usb\r\nfake line";
  add(ipc::channel::kStatus, lcm_bytes(status));
  add("\x1b]0;title\x07", {1, 2, 3});
  add(ipc::channel::kStats, {0x1b, 0x5b, 0x32, 0x4a});  // does not decode
  std::istringstream in(out.str());
  const LogDigest d = digest_log(in, "forged.log", DigestOptions{});
  const std::string text = text_summary(d, summarize(d), "");
  for (const char c : text)
    EXPECT_TRUE(c == '\n' || (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f))
        << "control character " << static_cast<int>(c) << " in:\n"
        << text;
  EXPECT_NE(text.find("cam?[2J"), std::string::npos) << text;
  EXPECT_NE(text.find("usb??fake line"), std::string::npos) << text;
  EXPECT_NE(text.find("?]0;title?"), std::string::npos) << text;
}

TEST(LogDigest, ALogCutAnywhereReportsWhatPrecedesTheCut) {
  const KnownLog known;
  const std::string whole = known.bytes();
  std::vector<std::size_t> ends;
  std::size_t at = 0;
  for (const LcmLogEvent& e : known.events)
    ends.push_back(at += 28 + e.channel.size() + e.data.size());
  ASSERT_EQ(at, whole.size());
  for (std::size_t cut = 1; cut < whole.size(); cut += 37) {
    std::istringstream in(whole.substr(0, cut));
    if (cut < ends[0]) {
      EXPECT_THROW(digest_log(in, "cut.log"), Error) << cut;
      continue;
    }
    const LogDigest d = digest_log(in, "cut.log");
    const auto complete =
        static_cast<long>(std::upper_bound(ends.begin(), ends.end(), cut) - ends.begin());
    EXPECT_EQ(d.events, complete) << cut;
    EXPECT_EQ(d.damage.empty(), std::binary_search(ends.begin(), ends.end(), cut)) << cut;
    const LogSummary s = summarize(d);
    EXPECT_LE(s.frames, 56);
    if (!d.damage.empty()) {
      EXPECT_NE(d.damage.find("cut.log"), std::string::npos) << d.damage;
      EXPECT_NE(html_report(d, s).find("class=\"damage\""), std::string::npos);
      EXPECT_NE(text_summary(d, s, "").find("DAMAGED, read"), std::string::npos);
    }
  }
}

// A damaged stretch inside a field log (stray bytes, a length field hit) costs the events in it,
// not every event after it: the report reads on from the next whole event and says what it
// skipped.
TEST(LogDigest, ADamagedStretchIsSkippedAndTheEventsAfterItAreRead) {
  const KnownLog known;
  const std::string whole = known.bytes();
  std::vector<std::size_t> starts;
  std::size_t at = 0;
  for (const LcmLogEvent& e : known.events) {
    starts.push_back(at);
    at += 28 + e.channel.size() + e.data.size();
  }
  const long all = static_cast<long>(known.events.size());
  ASSERT_GT(all, 12);
  // Thirteen stray bytes between events 10 and 11.
  std::string stray = whole;
  stray.insert(starts[10], std::string(13, '\x55'));
  std::istringstream in(stray);
  const LogDigest d = digest_log(in, "stray.log");
  EXPECT_EQ(d.events, all);
  EXPECT_EQ(d.damaged_stretches, 1);
  EXPECT_EQ(d.skipped_bytes, 13u);
  EXPECT_NE(d.damage.find("at byte " + std::to_string(starts[10])), std::string::npos) << d.damage;
  const LogSummary s = summarize(d);
  std::istringstream intact(whole);
  EXPECT_EQ(s.frames, summarize(digest_log(intact, "whole.log")).frames);
  EXPECT_NE(text_summary(d, s, "").find("13 bytes skipped past damage"), std::string::npos)
      << text_summary(d, s, "");
  EXPECT_NE(json_summary(d, s).find("\"damaged_stretches\": 1, \"skipped_bytes\": 13"),
            std::string::npos);
  // Event 5's channel length hit (0): that event is lost, the rest are read.
  std::string hit = whole;
  for (int k = 0; k < 4; ++k) hit[starts[5] + 20 + static_cast<std::size_t>(k)] = 0;
  std::istringstream in_hit(hit);
  const LogDigest h = digest_log(in_hit, "hit.log");
  EXPECT_EQ(h.events, all - 1);
  EXPECT_EQ(h.skipped_bytes, starts[6] - starts[5]);
}

TEST(LogDigest, AFileThatIsNoLogIsOneError) {
  std::istringstream text("this is not an LCM log, it is a text file with enough bytes in it");
  try {
    digest_log(text, "notes.txt");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not an LCM log"), std::string::npos) << e.what();
  }
  std::istringstream empty("");
  EXPECT_THROW(digest_log(empty, "empty.log"), Error);
  EXPECT_THROW(digest_log("/nonexistent/field.log"), Error);
}

// lcm-logger stopped by a full disk at once: an LCM log cut inside its first event is said to be
// that, not "not an LCM log".
TEST(LogDigest, ALogCutInsideItsFirstEventSaysSo) {
  const KnownLog known;
  const std::string bytes = known.bytes();
  for (const std::size_t cut : {std::size_t{2}, std::size_t{10}, std::size_t{40}}) {
    std::istringstream in(bytes.substr(0, cut));
    try {
      digest_log(in, "field.log");
      FAIL() << "no error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("an LCM log damaged before its first whole event"), std::string::npos)
          << what;
      EXPECT_EQ(what.find("not an LCM log"), std::string::npos) << what;
    }
  }
}

TEST(HtmlReport, IsSelfContainedEscapedAndHoldsChartsAndThumbnails) {
  const KnownLog known;
  std::istringstream in(known.bytes());
  DigestOptions options;
  options.max_previews = 6;
  const LogDigest d = digest_log(in, "known <log>.log", options);
  const std::string html = html_report(d, summarize(d));
  auto count = [&](const std::string& needle) {
    long n = 0;
    for (std::size_t at = html.find(needle); at != std::string::npos;
         at = html.find(needle, at + 1))
      ++n;
    return n;
  };
  EXPECT_EQ(count("<svg "), 8);
  EXPECT_EQ(count("</svg>"), 8);
  EXPECT_EQ(count("The right camera against the left"), 1);
  EXPECT_EQ(count("Lens fall-off of both cameras"), 1);
  EXPECT_EQ(count("data:image/png;base64,"), static_cast<long>(d.previews.size()));
  // Nothing to fetch: no scripts, no outside addresses other than SVG's namespace name.
  EXPECT_EQ(count("<script"), 0);
  EXPECT_EQ(count("http"), count("xmlns=\"http://www.w3.org/2000/svg\""));
  EXPECT_EQ(count("camera &lt;unplugged&gt; &amp; gone"), 1);
  EXPECT_EQ(count("<unplugged>"), 0);
  EXPECT_EQ(count("known &lt;log&gt;.log"), 2);
  EXPECT_NE(html.find("usb: babble"), std::string::npos);
  EXPECT_EQ(count("class=\"damage\""), 0);
}

TEST(SvgChart, TicksAreRoundAndCoverTheRange) {
  EXPECT_EQ(nice_ticks(0, 10, 5), (std::vector<double>{0, 2, 4, 6, 8, 10}));
  const auto fine = nice_ticks(0.3, 0.92, 5);
  ASSERT_EQ(fine.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(fine[static_cast<std::size_t>(i)], 0.4 + 0.2 * i, 1e-12);
  const auto t = nice_ticks(68.2, 75.6, 8);
  ASSERT_FALSE(t.empty());
  EXPECT_GE(t.front(), 68.2);
  EXPECT_LE(t.back(), 75.6);
  EXPECT_EQ(nice_ticks(3, 3, 5), (std::vector<double>{3}));
}

TEST(SvgChart, ThinningKeepsASingleSpikeAmongAHundredThousandPoints) {
  ChartSeries s{"latency", "#c00", {}, false};
  for (int i = 0; i < 100000; ++i) s.xy.emplace_back(i * 0.001, i == 61234 ? 500.0 : 10.0);
  const std::string svg = line_chart_svg({"t", "x", "y", 760, 230}, {s});
  const auto points = std::count(svg.begin(), svg.end(), ',');
  EXPECT_LT(points, 2000) << "thinned to the chart's pixel columns";
  // The spike is the chart's maximum: some point sits at the plot's top region.
  std::regex coordinate(R"(([0-9.]+),([0-9.]+) )");
  double lowest_y = 1e9;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), coordinate);
       it != std::sregex_iterator(); ++it)
    lowest_y = std::min(lowest_y, std::stod((*it)[2]));
  EXPECT_LT(lowest_y, 60) << "the 500 ms spike must be drawn";
  EXPECT_NE(line_chart_svg({"empty", "x", "y"}, {}).find("no data"), std::string::npos);
  EXPECT_NE(histogram_svg({"empty", "x", "y"}, {}, 10).find("no data"), std::string::npos);
}

TEST(HtmlReport, Base64MatchesRfc4648) {
  auto b64 = [](const std::string& s) {
    return base64(reinterpret_cast<const unsigned char*>(s.data()), s.size());
  };
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
}

TEST(HtmlReport, ThumbnailsShowNearWarmFarCoolAndUnknownBlack) {
  ::dco::depth_preview_t p{};
  p.width = 3;
  p.height = 1;
  p.num_pixels = 3;
  p.depth_mm = {500, 5000, 0};
  const std::string png = preview_png(p, 500, 5000, 4);
  const cv::Mat img =
      cv::imdecode(std::vector<std::uint8_t>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(img.cols, 12);
  ASSERT_EQ(img.rows, 4);
  const cv::Vec3b near = img.at<cv::Vec3b>(2, 1), far = img.at<cv::Vec3b>(2, 5),
                  unknown = img.at<cv::Vec3b>(2, 9);
  EXPECT_GT(near[2], near[0]) << "near is red (BGR)";
  EXPECT_GT(far[0], far[2]) << "far is blue";
  EXPECT_EQ(unknown, cv::Vec3b(0, 0, 0));
  p.depth_mm.pop_back();
  EXPECT_THROW(preview_png(p, 500, 5000, 1), Error);
}

TEST(DcoDiagCli, WritesTheReportsAndExitsByTheRules) {
  using tools::testing::run_cli;
  using tools::testing::slurp;
  testing::TempDir dir;
  const KnownLog known;
  const std::string bytes = known.bytes();
  const auto log = dir / "field.log";
  std::ofstream(log, std::ios::binary) << bytes;
  auto r = run_cli(DCO_DIAG_EXE, dir, {log.string(), "--json", (dir / "k.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("56 published in 2 sessions"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("report    " + log.string() + ".html"), std::string::npos) << r.out;
  EXPECT_NE(slurp(log.string() + ".html").find("</html>"), std::string::npos);
  EXPECT_NE(slurp(dir / "k.json").find("\"frames\": 56,"), std::string::npos);

  r = run_cli(DCO_DIAG_EXE, dir, {log.string(), "--no-html", "--json", "-"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("{\"log\": ", 0), 0u) << r.out;

  // A cut log: a report of what it holds, exit 0, the damage named.
  std::ofstream(dir / "cut.log", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  r = run_cli(DCO_DIAG_EXE, dir, {(dir / "cut.log").string(), "--html", (dir / "c.html").string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("DAMAGED"), std::string::npos) << r.out;
  EXPECT_NE(slurp(dir / "c.html").find("class=\"damage\""), std::string::npos);

  std::ofstream(dir / "notes.txt") << "not a log at all, just some words in a file";
  r = run_cli(DCO_DIAG_EXE, dir, {(dir / "notes.txt").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not an LCM log"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(run_cli(DCO_DIAG_EXE, dir, {}).exit_code, 2);
  EXPECT_EQ(run_cli(DCO_DIAG_EXE, dir, {log.string(), "--previews", "-3"}).exit_code, 2);
  EXPECT_EQ(run_cli(DCO_DIAG_EXE, dir, {log.string(), "--bogus"}).exit_code, 2);
  // A report never goes over the recording it reads.
  for (const char* option : {"--html", "--json"}) {
    r = run_cli(DCO_DIAG_EXE, dir, {log.string(), option, log.string()});
    EXPECT_EQ(r.exit_code, 2) << option;
    EXPECT_NE(r.err.find("is the log itself"), std::string::npos) << r.err;
  }
  r = run_cli(DCO_DIAG_EXE, dir, {log.string(), "--html", (dir / "." / "field.log").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(slurp(log), bytes);
  // A report that cannot be written says why.
  std::filesystem::create_directory(dir / "taken.html");
  r = run_cli(DCO_DIAG_EXE, dir, {log.string(), "--html", (dir / "taken.html").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("taken.html': Is a directory"), std::string::npos) << r.err;
  // The summary goes out all the same (a log on read-only media), without a report line.
  EXPECT_NE(r.out.find("56 published in 2 sessions"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("report    "), std::string::npos) << r.out;
  // A folder that cannot take the report's temporary file: the reason is given.
  std::filesystem::create_directory(dir / "locked");
  r = run_cli(DCO_DIAG_EXE, dir,
              {log.string(), "--html", (dir / "locked" / "missing" / "r.html").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("No such file or directory"), std::string::npos) << r.err;
  // Usage mistakes are one line each, not the whole usage text.
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{log.string(), "--bogus"}, std::vector<std::string>{},
        std::vector<std::string>{log.string(), "--json", ""},
        std::vector<std::string>{log.string(), "--html", (dir / "same").string(), "--json",
                                 (dir / "same").string()}}) {
    r = run_cli(DCO_DIAG_EXE, dir, args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

}  // namespace
}  // namespace dco::diag
