// LCM logs: the reader against logs cut at every byte and damaged heads, the DCO_RAW codec
// round trip, and the lcmlog:// source on good, cut and foreign logs.

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <streambuf>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/lcm_log.hpp"
#include "dco/drivers/raw_stereo.hpp"
#include "dco/drivers/recorded_previews.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "support/error_of.hpp"
#include "support/lcm_bytes.hpp"
#include "support/temp_dir.hpp"

namespace dco::drivers {
namespace {

LcmLogEvent event_of(int i, const std::string& channel, std::vector<std::uint8_t> data) {
  LcmLogEvent e;
  e.number = i;
  e.timestamp_us = 1'700'000'000'000'000 + 33'000 * i;
  e.channel = channel;
  e.data = std::move(data);
  return e;
}

std::string log_of(const std::vector<LcmLogEvent>& events) {
  std::ostringstream out;
  for (const auto& e : events) write_lcm_log_event(out, e);
  return out.str();
}

TEST(LcmLogReader, ReadsWhatWasWrittenAndSaysWhereACutLogEnds) {
  std::vector<LcmLogEvent> events;
  std::vector<std::size_t> ends;  // byte offset after each event
  std::size_t at = 0;
  for (int i = 0; i < 4; ++i) {
    events.push_back(event_of(i, i % 2 ? "DCO_STATS" : "DCO_RAW",
                              std::vector<std::uint8_t>(static_cast<std::size_t>(10 * i), 7)));
    at += 28 + events.back().channel.size() + events.back().data.size();
    ends.push_back(at);
  }
  const std::string whole = log_of(events);
  ASSERT_EQ(whole.size(), at);
  for (std::size_t cut = 0; cut <= whole.size(); ++cut) {
    std::istringstream in(whole.substr(0, cut));
    LcmLogReader reader(in, "cut.log");
    LcmLogEvent e;
    long n = 0;
    while (reader.next(e)) {
      ASSERT_EQ(e.channel, events[static_cast<std::size_t>(n)].channel);
      ASSERT_EQ(e.data, events[static_cast<std::size_t>(n)].data);
      ASSERT_EQ(e.timestamp_us, events[static_cast<std::size_t>(n)].timestamp_us);
      ++n;
    }
    long whole_events = 0;
    while (whole_events < 4 && ends[static_cast<std::size_t>(whole_events)] <= cut) ++whole_events;
    EXPECT_EQ(n, whole_events) << "cut at " << cut;
    const bool at_boundary =
        cut == 0 || (whole_events > 0 && ends[static_cast<std::size_t>(whole_events - 1)] == cut);
    if (at_boundary) {
      EXPECT_EQ(reader.damage(), "") << "cut at " << cut;
    } else {
      EXPECT_NE(reader.damage().find("cut.log: event " + std::to_string(n + 1) + " at byte"),
                std::string::npos)
          << reader.damage();
      EXPECT_NE(reader.damage().find("ends inside"), std::string::npos) << reader.damage();
      EXPECT_FALSE(reader.next(e)) << "nothing after damage";
    }
  }
}

TEST(LcmLogReader, DamagedHeadsAreNamed) {
  const std::string good = log_of({event_of(0, "A", {1, 2, 3})});
  auto damage_of = [](std::string bytes) {
    std::istringstream in(bytes);
    LcmLogReader reader(in, "bad.log");
    LcmLogEvent e;
    while (reader.next(e)) {
    }
    return reader.damage();
  };
  std::string no_sync = good + good;
  no_sync[good.size()] ^= 0x10;
  EXPECT_NE(damage_of(no_sync).find("event 2 at byte " + std::to_string(good.size()) +
                                    ": no LCM sync word"),
            std::string::npos)
      << damage_of(no_sync);
  std::string long_channel = good;
  long_channel[20] = 0x7f;  // channel length's top byte
  EXPECT_NE(damage_of(long_channel).find("channel name of"), std::string::npos);
  std::string huge = good;
  huge[24] = 0x40;  // data length 1 GiB and more
  EXPECT_NE(damage_of(huge).find("more than LCM's"), std::string::npos) << damage_of(huge);
  EXPECT_THROW(LcmLogReader("/nonexistent/x.log"), Error);
}

// Serves `bytes`, then fails as a disk does (EIO): the stream sets badbit, not eofbit.
class FailingBuffer : public std::streambuf {
 public:
  explicit FailingBuffer(std::string bytes) : bytes_(std::move(bytes)) {
    setg(bytes_.data(), bytes_.data(), bytes_.data() + bytes_.size());
  }

 protected:
  int_type underflow() override { throw std::ios_base::failure("input/output error"); }

 private:
  std::string bytes_;
};

TEST(LcmLogReader, AReadErrorIsNeitherTheEndNorACut) {
  const std::string two = log_of({event_of(0, "A", {1, 2, 3}), event_of(1, "B", {4, 5})});
  const std::size_t first = 28 + 1 + 3;
  // Failing where the second event starts, inside its head, inside its data.
  for (const std::size_t served : {first, first + 10, first + 29}) {
    SCOPED_TRACE(served);
    FailingBuffer buffer(two.substr(0, served));
    std::istream in(&buffer);
    LcmLogReader reader(in, "eio.log");
    LcmLogEvent e;
    ASSERT_TRUE(reader.next(e));
    EXPECT_NE(dco::testing::error_of([&] {
                reader.next(e);
              }).find("eio.log: cannot read the LCM log at byte 32 (event 2)"),
              std::string::npos);
  }
  // A directory or a device reads as an empty log: refused, named.
  dco::testing::TempDir dir;
  for (const std::filesystem::path& path : {dir.path(), std::filesystem::path("/dev/null")})
    EXPECT_NE(dco::testing::error_of([&] {
                LcmLogReader reader(path);
              }).find(path.string() + ": not an LCM log file"),
              std::string::npos);
  EXPECT_NE(dco::testing::error_of([] { LcmLogReader reader(""); }).find("no LCM log file named"),
            std::string::npos);
}

StereoFrame frame_of(const Image<std::uint8_t>& l, const Image<std::uint8_t>& r,
                     const std::vector<ImuSample>& imu) {
  StereoFrame f;
  f.seq = 41;
  f.capture_ns = 123456789;
  f.left = l.cview();
  f.right = r.cview();
  f.imu = imu;
  return f;
}

TEST(RawStereo, RoundTripIsLosslessForGreyAndColour) {
  for (const bool colour : {false, true}) {
    synthetic::SceneConfig c = synthetic::preset("hand", 96, 64);
    c.color = colour;
    synthetic::SceneRenderer scene(c);
    synthetic::StereoSample s;
    scene.render(3, s);
    std::vector<ImuSample> imu(2);
    imu[1].capture_ns = 99;
    imu[1].accel_mps2 = {0.5f, 9.8f, -0.1f};
    imu[1].gyro_radps = {0.01f, 0.02f, 0.03f};
    RawStereoEncoder encoder;
    ::dco::raw_stereo_t m;
    encoder.encode(frame_of(s.left, s.right, imu), "calib", m);
    EXPECT_EQ(m.frame_seq, 41);
    EXPECT_EQ(m.encoding, "png");
    EXPECT_LT(m.left_size + m.right_size, 2 * 96 * 64 * (colour ? 3 : 1)) << "compressed";
    ASSERT_EQ(m.num_imu, 2);
    EXPECT_EQ(m.imu_ns[1], 99);
    EXPECT_FLOAT_EQ(m.accel[1][1], 9.8f);
    EXPECT_FLOAT_EQ(m.gyro[1][2], 0.03f);
    Image<std::uint8_t> left, right;
    decode_raw_stereo(m, left, right);
    decode_raw_stereo(m, left, right);  // again, into the same buffers
    ASSERT_EQ(left.channels(), colour ? 3 : 1);
    for (int y = 0; y < 64; ++y) {
      ASSERT_EQ(0, std::memcmp(left.row(y), s.left.row(y), 96u * left.channels()));
      ASSERT_EQ(0, std::memcmp(right.row(y), s.right.row(y), 96u * right.channels()));
    }
    // Damage is named, never silently decoded.
    ::dco::raw_stereo_t bad = m;
    bad.left.resize(bad.left.size() / 2);
    EXPECT_THROW(decode_raw_stereo(bad, left, right), Error);
    bad = m;
    bad.width = 95;
    EXPECT_THROW(decode_raw_stereo(bad, left, right), Error);
    bad = m;
    bad.encoding = "jpeg";
    EXPECT_THROW(decode_raw_stereo(bad, left, right), Error);
    // A small PNG that claims a huge image is refused from its header, before it is inflated.
    bad = m;
    bad.left.assign(bad.left.begin(), bad.left.begin() + 33);
    const std::uint8_t huge[8] = {0, 0, 0x4e, 0x20, 0, 0, 0x4e, 0x20};  // 20000 x 20000
    std::copy(huge, huge + 8, bad.left.begin() + 16);
    try {
      decode_raw_stereo(bad, left, right);
      ADD_FAILURE() << "decoded a PNG of another size";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("the left image is not an 8-bit PNG of 96x64"),
                std::string::npos)
          << e.what();
    }
    bad = m;
    bad.width = 100000;
    EXPECT_THROW(decode_raw_stereo(bad, left, right), Error);
  }
}

// Messages are decoded into objects kept from one to the next (no allocation per message): an
// array announced empty must not keep the previous message's elements.
TEST(LcmMessages, DecodingAgainKeepsNothingOfTheLastMessage) {
  synthetic::SceneRenderer scene(synthetic::preset("hand", 96, 64));
  synthetic::StereoSample s;
  scene.render(1, s);
  RawStereoEncoder encoder;
  ::dco::raw_stereo_t first;
  encoder.encode(frame_of(s.left, s.right, std::vector<ImuSample>(3)), "calib", first);
  ::dco::raw_stereo_t empty = first;
  empty.left_size = 0;
  empty.left.clear();
  empty.num_imu = 0;
  empty.imu_ns.clear();
  empty.accel.clear();
  empty.gyro.clear();
  ::dco::raw_stereo_t into;
  std::string problem;
  const auto a = dco::testing::lcm_bytes(first), b = dco::testing::lcm_bytes(empty);
  ASSERT_TRUE(ipc::decode_message(a.data(), a.size(), into, problem)) << problem;
  ASSERT_TRUE(ipc::decode_message(b.data(), b.size(), into, problem)) << problem;
  EXPECT_TRUE(into.left.empty());
  EXPECT_EQ(into.right, first.right);
  EXPECT_TRUE(into.imu_ns.empty());
  Image<std::uint8_t> left, right;
  EXPECT_THROW(decode_raw_stereo(into, left, right), Error) << "an empty image is no frame";

  ::dco::depth_preview_t whole{};
  whole.width = 2;
  whole.height = 2;
  whole.num_pixels = 4;
  whole.depth_mm = {1, 2, 3, 4};
  ::dco::depth_preview_t none = whole;
  none.num_pixels = 0;
  none.depth_mm.clear();
  ::dco::depth_preview_t preview;
  const auto c = dco::testing::lcm_bytes(whole), d = dco::testing::lcm_bytes(none);
  ASSERT_TRUE(ipc::decode_message(c.data(), c.size(), preview, problem)) << problem;
  EXPECT_TRUE(ipc::consistent_preview(preview));
  ASSERT_TRUE(ipc::decode_message(d.data(), d.size(), preview, problem)) << problem;
  EXPECT_TRUE(preview.depth_mm.empty());
  EXPECT_FALSE(ipc::consistent_preview(preview)) << "a 2x2 preview of no pixels";
}

// A raw pair's message as far as the previews need it: its frame number and capture time.
std::vector<std::uint8_t> pair_bytes(std::int64_t seq, std::int64_t capture_ns) {
  ::dco::raw_stereo_t m{};
  m.frame_seq = seq;
  m.capture_ns = capture_ns;
  return dco::testing::lcm_bytes(m);
}

TEST(RecordedPreviews, OnlyWholeGridsAreKeptForTheReplayCheck) {
  dco::testing::TempDir dir;
  std::vector<LcmLogEvent> events;
  auto add = [&](std::int64_t seq, std::int32_t w, std::int32_t h, std::int32_t n) {
    events.push_back(
        event_of(static_cast<int>(events.size()), ipc::channel::kRaw, pair_bytes(seq, 1000 + seq)));
    ::dco::depth_preview_t p{};
    p.frame_seq = seq;
    p.capture_ns = 1000 + seq;
    p.source_width = 64;
    p.source_height = 48;
    p.width = w;
    p.height = h;
    p.num_pixels = n;
    p.depth_mm.assign(static_cast<std::size_t>(n), 1000);
    events.push_back(event_of(static_cast<int>(events.size()), ipc::channel::kDepthPreview,
                              dco::testing::lcm_bytes(p)));
  };
  add(1, 4, 3, 12);
  add(2, 4, 3, 200000);  // more values than the grid: read past the replayed preview before
  add(3, 4, 3, 0);
  add(4, 0, 0, 0);
  add(5, 40000, 1, 40000);
  const auto path = dir.path() / "previews.log";
  std::ofstream(path, std::ios::binary) << log_of(events);
  const RecordedPreviews r = read_recorded_previews({path, ipc::channel::kRaw}, 100);
  ASSERT_EQ(r.by_frame.size(), 1u);
  EXPECT_EQ(r.by_frame.begin()->first, (std::pair<std::int64_t, std::int64_t>{0, 1}));
  EXPECT_EQ(r.undecodable, 4);
}

// A log recorded for a while without raw pairs (raw recording switched on later): the previews of
// frames without a pair never fill the limit, and the later ones with pairs are checked.
TEST(RecordedPreviews, PreviewsWithoutPairsDoNotUseUpTheLimit) {
  dco::testing::TempDir dir;
  std::vector<LcmLogEvent> events;
  auto preview = [](std::int64_t seq) {
    ::dco::depth_preview_t p{};
    p.frame_seq = seq;
    p.capture_ns = 1000 + seq;
    p.source_width = 64;
    p.source_height = 48;
    p.width = p.height = p.num_pixels = 1;
    p.depth_mm = {1000};
    return dco::testing::lcm_bytes(p);
  };
  for (std::int64_t seq = 0; seq < 500; ++seq)
    events.push_back(
        event_of(static_cast<int>(events.size()), ipc::channel::kDepthPreview, preview(seq)));
  for (std::int64_t seq = 500; seq < 510; ++seq) {
    events.push_back(
        event_of(static_cast<int>(events.size()), ipc::channel::kRaw, pair_bytes(seq, 1000 + seq)));
    events.push_back(
        event_of(static_cast<int>(events.size()), ipc::channel::kDepthPreview, preview(seq)));
  }
  const auto path = dir.path() / "late_raw.log";
  std::ofstream(path, std::ios::binary) << log_of(events);
  const RecordedPreviews r = read_recorded_previews({path, ipc::channel::kRaw}, 100);
  EXPECT_EQ(r.by_frame.size(), 10u);
  EXPECT_FALSE(r.truncated);
}

// Two dcod runs in one log, both numbering their frames from 0: each preview stays with its own
// run, whichever of a frame's pair and preview the logger got first.
TEST(RecordedPreviews, ARestartedDcodKeepsItsOwnPreviews) {
  dco::testing::TempDir dir;
  std::vector<LcmLogEvent> events;
  auto add = [&](const char* channel, std::vector<std::uint8_t> bytes) {
    events.push_back(event_of(static_cast<int>(events.size()), channel, std::move(bytes)));
  };
  auto preview = [](int run, std::int64_t seq) {
    ::dco::depth_preview_t p{};
    p.frame_seq = seq;
    p.capture_ns = 1'000'000 * run + seq;
    p.source_width = 64;
    p.source_height = 48;
    p.width = p.height = p.num_pixels = 1;
    p.depth_mm = {static_cast<std::int16_t>(1000 * run + seq)};
    return dco::testing::lcm_bytes(p);
  };
  for (int run = 1; run <= 2; ++run)
    for (std::int64_t seq = 0; seq < 3; ++seq) {
      const bool preview_first = seq == 1;
      if (preview_first) add(ipc::channel::kDepthPreview, preview(run, seq));
      add(ipc::channel::kRaw, pair_bytes(seq, 1'000'000 * run + seq));
      if (!preview_first && seq != 2) add(ipc::channel::kDepthPreview, preview(run, seq));
    }
  add(ipc::channel::kDepthPreview, preview(3, 0));  // no pair of its frame: never replayed
  const auto path = dir.path() / "two_runs.log";
  std::ofstream(path, std::ios::binary) << log_of(events);

  const RecordedPreviews r = read_recorded_previews({path, ipc::channel::kRaw}, 100);
  std::vector<std::pair<std::int64_t, std::int64_t>> keys;
  for (const auto& [key, p] : r.by_frame) {
    keys.push_back(key);
    EXPECT_EQ(p.depth_mm[0], 1000 * (key.first + 1) + key.second) << "a preview of the other run";
  }
  EXPECT_EQ(keys,
            (std::vector<std::pair<std::int64_t, std::int64_t>>{{0, 0}, {0, 1}, {1, 0}, {1, 1}}));
  // The replay check numbers the replayed frames' runs the same way.
  FrameSessions sessions;
  std::vector<std::int64_t> replayed;
  for (const std::int64_t seq : {0, 1, 2, 0, 1, 2}) replayed.push_back(sessions.session_of(seq));
  EXPECT_EQ(replayed, (std::vector<std::int64_t>{0, 0, 0, 1, 1, 1}));
  // A replay of the second run alone (run=2) reads its previews only, and one of them fills the
  // limit: the first run's do not use it up.
  const auto second = replayed_log("lcmlog://" + path.string() + "?run=2");
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->first_session, 1);
  const RecordedPreviews only = read_recorded_previews(*second, 1);
  ASSERT_EQ(only.by_frame.size(), 1u);
  EXPECT_EQ(only.by_frame.begin()->first, (std::pair<std::int64_t, std::int64_t>{1, 0}));
  EXPECT_TRUE(only.truncated);
  keys.clear();
  for (const auto& [key, p] : read_recorded_previews(*second, 100).by_frame) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::pair<std::int64_t, std::int64_t>>{{1, 0}, {1, 1}}))
      << "the preview that came before its pair too";
}

// Previews whose pairs are not in the log (raw recording off for a while) give way to newer ones
// in the order they came, not by frame number: a restarted dcod's first previews, numbered from 0
// again, are the newest.
TEST(RecordedPreviews, ANewRunsPreviewIsNotTakenForTheOldestWaiting) {
  dco::testing::TempDir dir;
  std::vector<LcmLogEvent> events;
  auto add = [&](const char* channel, std::vector<std::uint8_t> bytes) {
    events.push_back(event_of(static_cast<int>(events.size()), channel, std::move(bytes)));
  };
  auto preview = [](std::int64_t seq, std::int64_t capture_ns) {
    ::dco::depth_preview_t p{};
    p.frame_seq = seq;
    p.capture_ns = capture_ns;
    p.source_width = 64;
    p.source_height = 48;
    p.width = p.height = p.num_pixels = 1;
    p.depth_mm = {static_cast<std::int16_t>(seq)};
    return dco::testing::lcm_bytes(p);
  };
  add(ipc::channel::kRaw, pair_bytes(1000, 1000));
  for (std::int64_t seq = 2000; seq < 2300; ++seq)
    add(ipc::channel::kDepthPreview, preview(seq, seq));
  add(ipc::channel::kDepthPreview, preview(0, 5000));  // the new run's first frame, before its pair
  add(ipc::channel::kRaw, pair_bytes(0, 5000));
  const auto path = dir.path() / "gap_in_recording.log";
  std::ofstream(path, std::ios::binary) << log_of(events);
  const RecordedPreviews r = read_recorded_previews({path, ipc::channel::kRaw}, 100);
  ASSERT_EQ(r.by_frame.size(), 1u);
  EXPECT_EQ(r.by_frame.begin()->first, (std::pair<std::int64_t, std::int64_t>{1, 0}));
  EXPECT_TRUE(read_recorded_previews({path, "OTHER_RAW"}, 100).by_frame.empty())
      << "only the replayed channel's pairs";
}

// The headset's clock when it captured frame i of recorded_log(): up for three days, at 30 fps.
std::int64_t recorded_capture_ns(int i) {
  return 259'200'000'000'000 + std::int64_t{i} * 33'333'333;
}
// Sample k of frame i against that frame's capture time: the earlier ones before it, the last
// one after it (readout).
std::int64_t recorded_imu_offset_ns(int i, int k) {
  return std::int64_t{k - i} * 4'000'000 + 1'500'000;
}

// A log as dcod records it: the scene's pairs on DCO_RAW between other channels, numbered from
// 100 as a recording switched on mid-run would be, frame i with i IMU samples.
std::string recorded_log(int frames, int width, int height) {
  synthetic::SceneRenderer scene(synthetic::preset("hand", width, height));
  const std::string calibration = calibration_to_toml(scene.calibration());
  RawStereoEncoder encoder;
  std::vector<LcmLogEvent> events;
  synthetic::StereoSample s;
  for (int i = 0; i < frames; ++i) {
    scene.render(i, s);
    std::vector<ImuSample> imu(static_cast<std::size_t>(i));
    for (int k = 0; k < i; ++k) {
      imu[static_cast<std::size_t>(k)].capture_ns =
          recorded_capture_ns(i) + recorded_imu_offset_ns(i, k);
      imu[static_cast<std::size_t>(k)].accel_mps2 = {static_cast<float>(i), 0.5f, 9.81f};
      imu[static_cast<std::size_t>(k)].gyro_radps = {0.1f, static_cast<float>(k), 0.3f};
    }
    StereoFrame f = frame_of(s.left, s.right, imu);
    f.seq = static_cast<std::uint64_t>(100 + i);
    f.capture_ns = recorded_capture_ns(i);
    ::dco::raw_stereo_t m;
    encoder.encode(f, calibration, m);
    events.push_back(event_of(2 * i, "DCO_RAW", dco::testing::lcm_bytes(m)));
    events.push_back(event_of(2 * i + 1, "DCO_STATS", {1, 2, 3}));
  }
  return log_of(events);
}

struct Collect : FrameSink {
  std::vector<std::vector<std::uint8_t>> lefts;
  std::vector<std::uint64_t> seqs;
  std::vector<std::int64_t> captures;
  std::vector<std::vector<ImuSample>> imus;
  std::vector<bool> gaps, runs;
  bool ended = false;
  std::string error;
  std::mutex mutex;
  std::condition_variable done;
  void on_frame(const StereoFrame& f) override {
    std::vector<std::uint8_t> l;
    for (int y = 0; y < f.left.height; ++y)
      l.insert(l.end(), f.left.row(y), f.left.row(y) + f.left.width);
    std::lock_guard lock(mutex);
    lefts.push_back(std::move(l));
    seqs.push_back(f.seq);
    captures.push_back(f.capture_ns);
    imus.emplace_back(f.imu.begin(), f.imu.end());
    gaps.push_back(f.follows_gap);
    runs.push_back(f.starts_run);
  }
  void on_end() override {
    std::lock_guard lock(mutex);
    ended = true;
    done.notify_all();
  }
  void on_error(const std::string& m) override {
    std::lock_guard lock(mutex);
    error = m;
    done.notify_all();
  }
  bool wait() {
    std::unique_lock lock(mutex);
    return done.wait_for(lock, std::chrono::seconds(20), [&] { return ended || !error.empty(); });
  }
};

// A pair that says it is larger than the log's frames is refused before its PNGs are decoded (a
// small message saying 16384x16384 would take gigabytes first).
TEST(LcmLogSource, APairLargerThanTheLogsFramesIsRefusedBeforeItIsDecoded) {
  dco::testing::TempDir dir;
  synthetic::SceneRenderer scene(synthetic::preset("hand", 96, 64));
  const std::string calibration = calibration_to_toml(scene.calibration());
  RawStereoEncoder encoder;
  std::vector<LcmLogEvent> events;
  synthetic::StereoSample s;
  for (int i = 0; i < 2; ++i) {
    scene.render(i, s);
    StereoFrame f = frame_of(s.left, s.right, {});
    f.seq = static_cast<std::uint64_t>(i);
    f.capture_ns = recorded_capture_ns(i);
    ::dco::raw_stereo_t m;
    encoder.encode(f, calibration, m);
    if (i == 1) m.width = m.height = 16384;
    events.push_back(event_of(i, "DCO_RAW", dco::testing::lcm_bytes(m)));
  }
  const auto path = dir.path() / "bomb.log";
  std::ofstream(path, std::ios::binary) << log_of(events);
  auto source = open_source("lcmlog://" + path.string() + "?fps=0");
  Collect sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait());
  EXPECT_NE(sink.error.find("frame 1 is 16384x16384, the log started with 96x64"),
            std::string::npos)
      << sink.error;
}

// A raw pair for log_of_pairs: its frame number, capture time and pipeline keys, the width of
// the scene (height 3/4 of it) and a note that makes its calibration's text another.
struct RecordedPair {
  std::uint64_t seq;
  std::int64_t capture_ns;
  std::string keys;
  int width = 64;
  std::string calibration_note = {};
};
std::filesystem::path log_of_pairs(const std::filesystem::path& path,
                                   const std::vector<RecordedPair>& pairs,
                                   const std::string& channel = "DCO_RAW") {
  RawStereoEncoder encoder;
  std::vector<LcmLogEvent> events;
  synthetic::StereoSample s;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    synthetic::SceneRenderer scene(
        synthetic::preset("hand", pairs[i].width, pairs[i].width * 3 / 4));
    scene.render(static_cast<int>(i), s);
    StereoFrame f = frame_of(s.left, s.right, {});
    f.seq = pairs[i].seq;
    f.capture_ns = pairs[i].capture_ns;
    ::dco::raw_stereo_t m;
    encoder.encode(f, calibration_to_toml(scene.calibration()) + pairs[i].calibration_note, m);
    m.pipeline_config = pairs[i].keys;
    events.push_back(event_of(static_cast<std::int64_t>(i), channel, dco::testing::lcm_bytes(m)));
  }
  std::ofstream(path, std::ios::binary) << log_of(events);
  return path;
}

// The replay finds the headset's gaps on the recorded stamps, not on its own pace: a second's
// pause in the camera's frames, and two more dcod runs (frame numbers from 0 again) recorded
// into the same log.
TEST(LcmLogSource, GapsAreFoundOnTheRecordedStampsAndRuns) {
  dco::testing::TempDir dir;
  const std::int64_t paused = 1'000'000'000;
  const auto at = [](int i) { return recorded_capture_ns(i); };
  const std::int64_t later = 300'000'000;
  const auto path = log_of_pairs(dir.path() / "gaps.log", {{7, at(0), ""},
                                                           {8, at(1), ""},
                                                           {9, at(2) + paused, ""},
                                                           {10, at(3) + paused, ""},
                                                           {0, at(4) + paused, ""},
                                                           {1, at(5) + paused, ""},
                                                           {0, at(6) + 2 * paused, ""},
                                                           {1, at(6) + 2 * paused + later, ""},
                                                           {2, at(7) + 2 * paused + later, ""}});
  // Replayed as fast as taken and at 20 fps: the replay's own stamps have no such gaps.
  for (const char* fps : {"0", "20"}) {
    SCOPED_TRACE(fps);
    auto source = open_source("lcmlog://" + path.string() + "?fps=" + fps);
    Collect sink;
    source->start(sink);
    ASSERT_TRUE(sink.wait());
    source->stop();
    EXPECT_TRUE(sink.ended) << sink.error;
    // The third run, a second after the second, has its second frame 0.3 s after its first: a
    // gap as it was on the headset, whose new dcod knew no rate yet and no gap before, though it
    // comes right after the run's start. Each run finds its gaps afresh.
    EXPECT_EQ(sink.gaps,
              (std::vector<bool>{false, false, true, false, true, false, true, true, false}));
    EXPECT_EQ(sink.runs,
              (std::vector<bool>{false, false, false, false, true, false, true, false, false}));
  }
}

// The first two runs of the log share their keys, the third has others.
TEST(LcmLogSource, EachRunOfALogReplaysAloneAndOtherKeysAreNamed) {
  dco::testing::TempDir dir;
  const std::string a = "stereo.max_disparity=40\n", b = "stereo.max_disparity=32\n";
  // Frame i at recorded_capture_ns(i): the runs follow each other without a pause.
  const auto at = [](int i) { return recorded_capture_ns(i); };
  const auto path = log_of_pairs(dir.path() / "runs.log", {{5, at(0), a},
                                                           {6, at(1), a},
                                                           {0, at(2), a},
                                                           {1, at(3), a},
                                                           {0, at(4), b},
                                                           {1, at(5), b},
                                                           {2, at(6), b}});
  const auto replay = [&](const std::string& query, Collect& sink) {
    auto source = open_source("lcmlog://" + path.string() + "?fps=0" + query);
    source->start(sink);
    EXPECT_TRUE(sink.wait());
    source->stop();
    return source->info().recorded_pipeline;
  };
  {
    // The whole log: up to the run with other keys.
    Collect sink;
    EXPECT_EQ(replay("", sink), a);
    EXPECT_EQ(sink.seqs, (std::vector<std::uint64_t>{5, 6, 0, 1}));
    EXPECT_EQ(sink.gaps, (std::vector<bool>{false, false, true, false}));
    EXPECT_NE(sink.error.find("dcod run 3 (from frame 0) has other pipeline keys than the replay "
                              "started with; replay it alone: lcmlog://" +
                              path.string() + "?run=3"),
              std::string::npos)
        << sink.error;
  }
  for (const auto& [run, seqs, keys] : {std::tuple{2, std::vector<std::uint64_t>{0, 1}, a},
                                        std::tuple{3, std::vector<std::uint64_t>{0, 1, 2}, b}}) {
    SCOPED_TRACE(run);
    Collect sink;
    EXPECT_EQ(replay("&run=" + std::to_string(run), sink), keys);
    EXPECT_TRUE(sink.ended) << sink.error;
    EXPECT_EQ(sink.seqs, seqs);
    EXPECT_EQ(sink.gaps, std::vector<bool>(seqs.size(), false));
  }
  EXPECT_NE(dco::testing::error_of([&] {
              open_source("lcmlog://" + path.string() + "?run=4");
            }).find("run=4 asked for, the log holds 3 dcod run(s)"),
            std::string::npos);
  EXPECT_NE(dco::testing::error_of([&] {
              open_source("lcmlog://" + path.string() + "?run=0");
            }).find("run=0 must be an integer in [1, 1000000]"),
            std::string::npos);
  EXPECT_FALSE(replayed_log("lcmlog://" + path.string())->one_run);
  // A new run with another camera mode or another calibration replays alone too (the URI named
  // keeps the channel), and the first run alone ends cleanly before it.
  for (const auto& [second, differs] :
       {std::pair{RecordedPair{0, at(3), a, 96}, "another image size than"},
        std::pair{RecordedPair{0, at(3), a, 64, "# moved\n"}, "another calibration than"}}) {
    SCOPED_TRACE(differs);
    const auto two =
        log_of_pairs(dir.path() / "two.log", {{0, at(0), a}, {1, at(1), a}, second}, "CAM_RAW");
    const std::string uri = "lcmlog://" + two.string();
    for (const char* query : {"?fps=0&channel=CAM_RAW", "?fps=0&channel=CAM_RAW&run=1"}) {
      auto source = open_source(uri + query);
      Collect sink;
      source->start(sink);
      ASSERT_TRUE(sink.wait());
      source->stop();
      EXPECT_EQ(sink.seqs.size(), 2u);
      if (std::string(query).ends_with("run=1"))
        EXPECT_TRUE(sink.ended) << sink.error;
      else
        EXPECT_NE(sink.error.find(std::string("dcod run 2 (from frame 0) has ") + differs +
                                  " the replay started with; replay it alone: " + uri +
                                  "?run=2&channel=CAM_RAW"),
                  std::string::npos)
            << sink.error;
    }
  }
  // A reload on the headset changed the keys within a run: the replay ends there.
  const auto reloaded =
      log_of_pairs(dir.path() / "reload.log", {{0, at(0), a}, {1, at(1), a}, {2, at(2), b}});
  auto source = open_source("lcmlog://" + reloaded.string() + "?fps=0");
  Collect sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait());
  source->stop();
  EXPECT_EQ(sink.seqs.size(), 2u);
  EXPECT_NE(sink.error.find("the pipeline keys change at frame 2 (the headset reloaded its "
                            "settings): the replay ends here"),
            std::string::npos)
      << sink.error;
}

TEST(LcmLogSource, ReplaysTheRecordedPairsAndNamesDamage) {
  dco::testing::TempDir dir;
  const std::string log = recorded_log(5, 96, 64);
  const auto path = dir.path() / "rec.log";
  std::ofstream(path, std::ios::binary) << log;
  {
    auto source = open_source("lcmlog://" + path.string() + "?fps=0");
    EXPECT_EQ(source->info().width, 96);
    EXPECT_EQ(source->info().height, 64);
    EXPECT_NE(source->info().description.find("lcmlog"), std::string::npos);
    synthetic::SceneRenderer scene(synthetic::preset("hand", 96, 64));
    EXPECT_EQ(calibration_to_toml(source->calibration()), calibration_to_toml(scene.calibration()));
    Collect sink;
    source->start(sink);
    ASSERT_TRUE(sink.wait());
    source->stop();
    EXPECT_TRUE(sink.ended) << sink.error;
    ASSERT_EQ(sink.lefts.size(), 5u);
    synthetic::StereoSample s;
    scene.render(4, s);
    for (int y = 0; y < 64; ++y)
      ASSERT_EQ(0,
                std::memcmp(&sink.lefts[4][static_cast<std::size_t>(y) * 96], s.left.row(y), 96));
    // The headset's frame numbers and IMU samples come with the pairs (their stamps: below).
    EXPECT_EQ(sink.seqs, (std::vector<std::uint64_t>{100, 101, 102, 103, 104}));
    for (std::size_t i = 0; i < 5; ++i) {
      ASSERT_EQ(sink.imus[i].size(), i);
      for (std::size_t k = 0; k < i; ++k) {
        EXPECT_EQ(sink.imus[i][k].accel_mps2[0], static_cast<float>(i));
        EXPECT_EQ(sink.imus[i][k].gyro_radps[1], static_cast<float>(k));
      }
    }
  }
  // Cut inside the fourth pair: three pairs, then the place of the cut.
  const auto cut = dir.path() / "cut.log";
  const std::size_t fourth = log.size() * 3 / 5 + 100;
  std::ofstream(cut, std::ios::binary) << log.substr(0, fourth);
  {
    auto source = open_source("lcmlog://" + cut.string() + "?fps=0");
    Collect sink;
    source->start(sink);
    ASSERT_TRUE(sink.wait());
    source->stop();
    EXPECT_EQ(sink.lefts.size(), 3u);
    EXPECT_NE(sink.error.find("ends inside the event"), std::string::npos) << sink.error;
    EXPECT_NE(sink.error.find("the 6 events before it are good"), std::string::npos) << sink.error;
    // The file is named once, after the URI's scheme.
    EXPECT_EQ(sink.error.rfind("lcmlog://" + cut.string() + ": event ", 0), 0u) << sink.error;
  }
  // A log without DCO_RAW, and a file that is no log.
  const auto stats_only = dir.path() / "stats.log";
  std::ofstream(stats_only, std::ios::binary) << log_of({event_of(0, "DCO_STATS", {1})});
  try {
    open_source("lcmlog://" + stats_only.string());
    ADD_FAILURE() << "opened a log without raw pairs";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no DCO_RAW message in 1 events"), std::string::npos)
        << e.what();
  }
  const auto text = dir.path() / "notes.txt";
  std::ofstream(text) << "not a log at all, just some words\n";
  try {
    open_source("lcmlog://" + text.string());
    ADD_FAILURE() << "opened a text file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no LCM sync word"), std::string::npos) << e.what();
  }
}

TEST(LcmLogSource, ImuSamplesKeepTheirOffsetsToTheFrameOnTheReplaysClock) {
  dco::testing::TempDir dir;
  const auto path = dir.path() / "rec.log";
  std::ofstream(path, std::ios::binary) << recorded_log(6, 64, 48);
  const auto steady_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  };
  const std::int64_t before = steady_ns();
  auto source = open_source("lcmlog://" + path.string() + "?fps=0");
  Collect sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait());
  source->stop();
  const std::int64_t after = steady_ns();
  EXPECT_TRUE(sink.ended) << sink.error;
  ASSERT_EQ(sink.captures.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    SCOPED_TRACE(i);
    // Frames are stamped on the replay's clock, not the headset's...
    EXPECT_GE(sink.captures[i], before);
    EXPECT_LE(sink.captures[i], after);
    // ...and so are their samples, as far from the frame as they were when recorded (the last
    // one of each frame at least: the replay runs faster than the recording, so a frame's first
    // samples would fall before the last frame's, and they come right after those instead).
    ASSERT_EQ(sink.imus[i].size(), i);
    if (i > 0) {
      EXPECT_EQ(sink.imus[i][i - 1].capture_ns - sink.captures[i],
                recorded_imu_offset_ns(static_cast<int>(i), static_cast<int>(i - 1)));
    }
    for (const ImuSample& s : sink.imus[i]) EXPECT_LT(s.capture_ns, sink.captures[i]);
  }
  // Every sample after the one before, across frames too.
  std::int64_t last = 0;
  for (const auto& frame_imu : sink.imus)
    for (const ImuSample& s : frame_imu) {
      EXPECT_GT(s.capture_ns, last);
      last = s.capture_ns;
    }
}

}  // namespace
}  // namespace dco::drivers
