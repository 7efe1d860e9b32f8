#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/drivers/frame_source.hpp"
#include "support/synthetic_recording.hpp"
#include "support/temp_dir.hpp"

namespace dco::drivers {
namespace {

using namespace std::chrono_literals;

// Records what a source delivers; frames are copied since their views live for the call only.
class RecordingSink : public FrameSink {
 public:
  struct Frame {
    std::uint64_t seq = 0;
    std::int64_t capture_ns = 0;
    Image<std::uint8_t> left, right;
  };

  void on_frame(const StereoFrame& f) override {
    Frame copy;
    copy.seq = f.seq;
    copy.capture_ns = f.capture_ns;
    copy.left.resize(f.left.width, f.left.height, f.left.channels);
    copy.left.copy_from(f.left);
    copy.right.resize(f.right.width, f.right.height, f.right.channels);
    copy.right.copy_from(f.right);
    std::lock_guard lock(mutex_);
    frames_.push_back(std::move(copy));
    changed_.notify_all();
  }
  void on_end() override {
    std::lock_guard lock(mutex_);
    ended_ = true;
    changed_.notify_all();
  }
  void on_error(const std::string& message) override {
    std::lock_guard lock(mutex_);
    error_ = message;
    changed_.notify_all();
  }

  bool wait_for_end(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return ended_ || !error_.empty(); });
  }
  std::size_t count() {
    std::lock_guard lock(mutex_);
    return frames_.size();
  }
  // Whether `n` frames came within `timeout` (a loaded machine delivers them late, not fewer).
  bool wait_for_count(std::size_t n, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return frames_.size() >= n; });
  }
  std::vector<Frame> frames() {
    std::lock_guard lock(mutex_);
    return frames_;
  }
  bool ended() {
    std::lock_guard lock(mutex_);
    return ended_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Frame> frames_;
  bool ended_ = false;
  std::string error_;
};

bool same_pixels(ImageView<const std::uint8_t> a, ImageView<const std::uint8_t> b) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels) return false;
  for (int y = 0; y < a.height; ++y)
    if (std::memcmp(a.row(y), b.row(y), static_cast<std::size_t>(a.width * a.channels)) != 0)
      return false;
  return true;
}

TEST(SyntheticSource, DeliversTheRenderersFramesAtItsPace) {
  auto source = open_source("synthetic://hand?width=160&height=96&fps=50");
  EXPECT_EQ(source->info().width, 160);
  EXPECT_EQ(source->info().height, 96);
  ASSERT_TRUE(source->info().max_disparity.has_value());
  EXPECT_TRUE(source->calibration().is_rectified);
  RecordingSink sink;
  source->start(sink);
  std::this_thread::sleep_for(500ms);
  source->stop();
  const auto frames = sink.frames();
  // 50 fps for 0.5 s: about 25 frames; a loaded machine may deliver fewer, never a burst.
  EXPECT_GE(frames.size(), 10u);
  EXPECT_LE(frames.size(), 27u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].seq, i);
    if (i > 0) {
      EXPECT_GT(frames[i].capture_ns, frames[i - 1].capture_ns);
    }
  }
  // The scene moves in real time at the delivered rate: frame 3 shows it at 3/50 s.
  synthetic::SceneConfig at_50 = synthetic::preset("hand", 160, 96);
  at_50.fps = 50;
  synthetic::StereoSample sample;
  synthetic::SceneRenderer(at_50).render(3, sample);
  EXPECT_TRUE(same_pixels(frames[3].left.cview(), sample.left.cview()));
  EXPECT_TRUE(same_pixels(frames[3].right.cview(), sample.right.cview()));
  synthetic::SceneRenderer(synthetic::preset("hand", 160, 96)).render(3, sample);  // at 3/30 s
  EXPECT_FALSE(same_pixels(frames[3].left.cview(), sample.left.cview()));
}

TEST(SyntheticSource, AFiniteSourceEndsAndARestartGoesOn) {
  auto source = open_source("synthetic://boxes?width=96&height=64&fps=0&frames=5");
  RecordingSink sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait_for_end(10s));
  source->stop();
  EXPECT_EQ(sink.count(), 5u);
  EXPECT_TRUE(sink.ended());
  // Delivered as fast as taken, the scene keeps its preset's clock (30 Hz).
  synthetic::StereoSample sample;
  synthetic::SceneRenderer(synthetic::preset("boxes", 96, 64)).render(3, sample);
  EXPECT_TRUE(same_pixels(sink.frames()[3].left.cview(), sample.left.cview()));

  auto endless = open_source("synthetic://boxes?width=96&height=64&fps=200");
  RecordingSink first, second;
  endless->start(first);
  EXPECT_THROW(endless->start(first), Error) << "started twice";
  ASSERT_TRUE(first.wait_for_count(1, 10s));
  endless->stop();
  const std::size_t n = first.count();
  endless->start(second);
  ASSERT_TRUE(second.wait_for_count(1, 10s));
  endless->stop();
  EXPECT_EQ(second.frames().front().seq, n) << "a restart continues the sequence";
}

// Frame 1 of a two-frame boxes source with `query` against the renderer with `set` applied to the
// preset: both views the same bytes.
void expect_source_renders(const std::string& query, void (*set)(synthetic::SceneConfig&)) {
  auto source = open_source("synthetic://boxes?width=96&height=64&fps=0&frames=2&" + query);
  RecordingSink sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait_for_end(10s)) << query;
  source->stop();
  synthetic::SceneConfig config = synthetic::preset("boxes", 96, 64);
  set(config);
  synthetic::StereoSample sample;
  synthetic::SceneRenderer(config).render(1, sample);
  EXPECT_TRUE(same_pixels(sink.frames()[1].left.cview(), sample.left.cview())) << query;
  EXPECT_TRUE(same_pixels(sink.frames()[1].right.cview(), sample.right.cview())) << query;
}

TEST(SyntheticSource, TheCamerasCanRunAnotherGainBlackLevelRowRollAndLensFalloff) {
  expect_source_renders("right_gain=1.1&right_offset=-3", [](synthetic::SceneConfig& c) {
    c.right_gain = 1.1;
    c.right_offset = -3;
  });
  expect_source_renders("right_rows=-0.75",
                        [](synthetic::SceneConfig& c) { c.right_rows = -0.75; });
  expect_source_renders("right_roll_deg=0.3",
                        [](synthetic::SceneConfig& c) { c.right_roll_deg = 0.3; });
  expect_source_renders("lens_falloff=0.3",
                        [](synthetic::SceneConfig& c) { c.lens_falloff = 0.3; });
  for (const char* bad :
       {"right_gain=0.1", "right_gain=5", "right_offset=-200", "right_gain=x", "right_rows=9",
        "right_roll_deg=2", "lens_falloff=0.9", "lens_falloff=-0.1"})
    EXPECT_THROW(open_source(std::string("synthetic://boxes?width=96&height=64&") + bad), Error)
        << bad;
}

TEST(SyntheticSource, StallAfterStopsDeliveringWithoutEnding) {
  auto source = open_source("synthetic://hand?width=96&height=64&fps=0&stall_after=4");
  RecordingSink sink;
  source->start(sink);
  ASSERT_TRUE(sink.wait_for_count(4, 10s));
  std::this_thread::sleep_for(300ms);  // no fifth frame comes, and no end
  EXPECT_EQ(sink.count(), 4u);
  EXPECT_FALSE(sink.ended());
  const auto before = std::chrono::steady_clock::now();
  source->stop();
  EXPECT_LT(std::chrono::steady_clock::now() - before, 200ms) << "stop wakes a stalled source";
}

// A sink that holds frame `slow_seq` for `hold`, as a pipeline that hiccups would.
class SlowSink : public RecordingSink {
 public:
  SlowSink(std::uint64_t slow_seq, std::chrono::milliseconds hold)
      : slow_seq_(slow_seq), hold_(hold) {}
  void on_frame(const StereoFrame& f) override {
    RecordingSink::on_frame(f);
    if (f.seq == slow_seq_) std::this_thread::sleep_for(hold_);
  }

 private:
  const std::uint64_t slow_seq_;
  const std::chrono::milliseconds hold_;
};

TEST(SyntheticSource, ASourceHeldUpDoesNotBurstAfterwards) {
  // 10 fps; frame 2 is held for 5 periods. Frame 3 goes out at once, late; frame 4 a period
  // after it, not right behind it.
  auto source = open_source("synthetic://hand?width=64&height=48&fps=10&frames=6");
  SlowSink sink(2, 500ms);
  source->start(sink);
  ASSERT_TRUE(sink.wait_for_end(10s));
  source->stop();
  const auto frames = sink.frames();
  ASSERT_EQ(frames.size(), 6u);
  const auto gap_ms = [&](std::size_t i) {
    return static_cast<double>(frames[i].capture_ns - frames[i - 1].capture_ns) / 1e6;
  };
  EXPECT_GE(gap_ms(3), 500.0) << "frame 3 waits for the held frame";
  for (std::size_t i = 4; i < frames.size(); ++i)
    EXPECT_GE(gap_ms(i), 50.0) << "frame " << i << " came in a burst";
}

using dco::testing::write_synthetic_recording;

// Every frame of a replay of `dir`, delivered as fast as taken.
std::vector<RecordingSink::Frame> replay_all(const std::filesystem::path& dir) {
  auto source = open_source("replay://" + dir.string() + "?fps=0");
  RecordingSink sink;
  source->start(sink);
  EXPECT_TRUE(sink.wait_for_end(10s));
  source->stop();
  return sink.frames();
}

TEST(ReplaySource, ReplaysTheFilesInOrderAndLoops) {
  dco::testing::TempDir dir;
  write_synthetic_recording(dir.path(), 3, 96, 64);
  const auto frames = replay_all(dir.path());
  ASSERT_EQ(frames.size(), 3u);
  synthetic::SceneRenderer renderer(synthetic::preset("hand", 96, 64));
  synthetic::StereoSample sample;
  for (int i = 0; i < 3; ++i) {
    renderer.render(i, sample);
    EXPECT_TRUE(same_pixels(frames[static_cast<std::size_t>(i)].left.cview(), sample.left.cview()));
    EXPECT_TRUE(
        same_pixels(frames[static_cast<std::size_t>(i)].right.cview(), sample.right.cview()));
  }

  auto looped = open_source("replay://" + dir.path().string() + "?fps=0&loop=1");
  RecordingSink loop_sink;
  looped->start(loop_sink);
  ASSERT_TRUE(loop_sink.wait_for_count(4, 10s));
  looped->stop();
  const auto loop_frames = loop_sink.frames();
  EXPECT_FALSE(loop_sink.ended());
  EXPECT_EQ(loop_frames[3].seq, 3u);
  EXPECT_TRUE(same_pixels(loop_frames[3].left.cview(), loop_frames[0].left.cview()));
}

TEST(ReplaySource, BrokenRecordingsAreRefusedWithTheReason) {
  const auto error_of = [](const std::filesystem::path& dir) -> std::string {
    try {
      open_source("replay://" + dir.string());
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  dco::testing::TempDir empty;
  EXPECT_NE(error_of(empty.path()).find("no frames"), std::string::npos);

  dco::testing::TempDir uneven;
  write_synthetic_recording(uneven.path(), 2, 96, 64);
  std::filesystem::remove(uneven.path() / "right" / "000001.png");
  EXPECT_NE(error_of(uneven.path()).find("000001.png has no right image of frame 1"),
            std::string::npos)
      << error_of(uneven.path());

  // As many files on each side, but not the same frames: never paired by position.
  dco::testing::TempDir gap;
  write_synthetic_recording(gap.path(), 4, 96, 64);
  std::filesystem::remove(gap.path() / "left" / "000002.png");
  std::filesystem::remove(gap.path() / "right" / "000001.png");
  EXPECT_NE(error_of(gap.path()).find("000001.png has no right image of frame 1"),
            std::string::npos)
      << error_of(gap.path());

  // Nanosecond capture times as names (19 digits, as exports of ROS bags write them), one frame
  // missing on each side: paired by the times, so the gap is named.
  dco::testing::TempDir nanoseconds;
  write_synthetic_recording(nanoseconds.path(), 4, 96, 64);
  for (const char* side : {"left", "right"})
    for (int i = 0; i < 4; ++i) {
      char from[16], to[32];
      std::snprintf(from, sizeof from, "%06d.png", i);
      std::snprintf(to, sizeof to, "14036365797635555%02d.png", i);
      std::filesystem::rename(nanoseconds.path() / side / from, nanoseconds.path() / side / to);
    }
  std::filesystem::remove(nanoseconds.path() / "left" / "1403636579763555502.png");
  std::filesystem::remove(nanoseconds.path() / "right" / "1403636579763555501.png");
  EXPECT_NE(error_of(nanoseconds.path())
                .find("1403636579763555501.png has no right image of frame 1403636579763555501"),
            std::string::npos)
      << error_of(nanoseconds.path());
  // A number past 64 bits cannot order the frames: said, never paired by position.
  dco::testing::TempDir huge;
  write_synthetic_recording(huge.path(), 1, 96, 64);
  for (const char* side : {"left", "right"})
    std::filesystem::rename(huge.path() / side / "000000.png",
                            huge.path() / side / "123456789012345678901.png");
  EXPECT_NE(error_of(huge.path()).find("a number of 21 digits, too long to order frames by"),
            std::string::npos)
      << error_of(huge.path());

  dco::testing::TempDir mixed;
  write_synthetic_recording(mixed.path(), 2, 96, 64);
  Image<std::uint8_t> colour(96, 64, 3);
  colour.fill(0);
  save_image(mixed.path() / "left" / "000001.png", colour.cview());
  save_image(mixed.path() / "right" / "000001.png", colour.cview());
  EXPECT_NE(error_of(mixed.path())
                .find("000001.png is 96x64x3, the calibration and the first "
                      "frame say 96x64x1"),
            std::string::npos)
      << error_of(mixed.path());

  dco::testing::TempDir uncalibrated;
  write_synthetic_recording(uncalibrated.path(), 1, 96, 64);
  std::filesystem::remove(uncalibrated.path() / "calib.toml");
  EXPECT_NE(error_of(uncalibrated.path()).find("no calibration"), std::string::npos);

  dco::testing::TempDir wrong_size;
  write_synthetic_recording(wrong_size.path(), 2, 96, 64);
  Image<std::uint8_t> narrow(80, 64);
  narrow.fill(0);
  save_image(wrong_size.path() / "right" / "000001.png", narrow.cview());
  EXPECT_NE(error_of(wrong_size.path()).find("000001.png is 80x64"), std::string::npos);

  for (const char* rate : {"1e-10", "0.001", "1001", "-1"})
    EXPECT_THROW(open_source(std::string("synthetic://hand?width=96&height=64&fps=") + rate), Error)
        << rate;
}

// Numbers without leading zeros: frame 9 comes before frame 10, as the numbers say.
TEST(ReplaySource, PairsAndOrdersByTheNumbersInTheNames) {
  dco::testing::TempDir dir;
  write_synthetic_recording(dir.path(), 2, 96, 64);
  for (const char* side : {"left", "right"}) {
    std::filesystem::rename(dir.path() / side / "000000.png", dir.path() / side / "9.png");
    std::filesystem::rename(dir.path() / side / "000001.png", dir.path() / side / "10.png");
  }
  const auto frames = replay_all(dir.path());
  ASSERT_EQ(frames.size(), 2u);
  synthetic::SceneRenderer renderer(synthetic::preset("hand", 96, 64));
  synthetic::StereoSample sample;
  renderer.render(0, sample);
  EXPECT_TRUE(same_pixels(frames[0].left.cview(), sample.left.cview()));
  renderer.render(1, sample);
  EXPECT_TRUE(same_pixels(frames[1].left.cview(), sample.left.cview()));
}

// Every number in a name counts, in order: capture times (seconds.microseconds) and KITTI's
// frame_camera names order as the numbers say; the Karlsruhe side prefixes do not count.
TEST(ReplaySource, OrdersByEveryNumberInTheNames) {
  const auto rename_all = [](const std::filesystem::path& dir,
                             const std::vector<std::string>& names) {
    for (const char* side : {"left", "right"})
      for (std::size_t i = 0; i < names.size(); ++i) {
        char old_name[32];
        std::snprintf(old_name, sizeof old_name, "%06zu.png", i);
        std::filesystem::rename(dir / side / old_name, dir / side / (names[i] + ".png"));
      }
  };
  const auto in_order = [](const std::vector<RecordingSink::Frame>& frames, std::size_t n) {
    if (frames.size() != n) return false;
    synthetic::SceneRenderer renderer(synthetic::preset("hand", 96, 64));
    synthetic::StereoSample sample;
    for (std::size_t i = 0; i < n; ++i) {
      renderer.render(static_cast<int>(i), sample);
      if (!same_pixels(frames[i].left.cview(), sample.left.cview()) ||
          !same_pixels(frames[i].right.cview(), sample.right.cview()))
        return false;
    }
    return true;
  };

  dco::testing::TempDir timed;
  write_synthetic_recording(timed.path(), 4, 96, 64);
  rename_all(timed.path(),
             {"1305031102.175304", "1305031102.943210", "1305031103.211000", "1305031103.600001"});
  EXPECT_TRUE(in_order(replay_all(timed.path()), 4)) << "by capture time";

  // Times written without their trailing zeros: the digits after the point are a fraction.
  dco::testing::TempDir short_times;
  write_synthetic_recording(short_times.path(), 5, 96, 64);
  rename_all(short_times.path(), {"100.1", "100.15", "100.2", "100.25", "100.3"});
  EXPECT_TRUE(in_order(replay_all(short_times.path()), 5)) << "by time, fractions of any length";

  dco::testing::TempDir kitti;
  write_synthetic_recording(kitti.path(), 3, 96, 64);
  rename_all(kitti.path(), {"000046_10", "000047_10", "000048_10"});
  EXPECT_TRUE(in_order(replay_all(kitti.path()), 3)) << "by KITTI frame";

  dco::testing::TempDir karlsruhe;
  write_synthetic_recording(karlsruhe.path(), 2, 96, 64);
  std::filesystem::create_directories(karlsruhe.path() / "images");
  for (const auto& [side, prefix] : {std::pair{"left", "I1_"}, std::pair{"right", "I2_"}}) {
    for (const char* name : {"000000.png", "000001.png"})
      std::filesystem::rename(karlsruhe.path() / side / name,
                              karlsruhe.path() / "images" / (std::string(prefix) + name));
    std::filesystem::remove(karlsruhe.path() / side);
  }
  EXPECT_TRUE(in_order(replay_all(karlsruhe.path()), 2)) << "Karlsruhe I1_/I2_";

  // Two names with the same numbers are still one frame twice.
  std::filesystem::copy_file(kitti.path() / "left" / "000047_10.png",
                             kitti.path() / "left" / "47_10.png");
  try {
    open_source("replay://" + kitti.path().string());
    ADD_FAILURE() << "opened a recording with a frame twice";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("000047_10.png and 47_10.png are both frame 47_10"),
              std::string::npos)
        << e.what();
  }
}

// A Karlsruhe calib.txt without roi gives no image size: the images give it.
TEST(ReplaySource, ARectifiedCalibrationWithoutSizeTakesTheImages) {
  dco::testing::TempDir dir;
  write_synthetic_recording(dir.path(), 2, 96, 64);
  std::filesystem::remove(dir.path() / "calib.toml");
  std::ofstream(dir.path() / "calib.txt")
      << "P1_roi: 80 0 48 0 0 80 32 0 0 0 1 0\nP2_roi: 80 0 48 -8 0 80 32 0 0 0 1 0\n";
  auto source = open_source("replay://" + dir.path().string() + "?fps=0");
  EXPECT_EQ(source->info().width, 96);
  EXPECT_EQ(source->info().height, 64);
  EXPECT_EQ(source->calibration().rectified.width, 96);
  EXPECT_EQ(replay_all(dir.path()).size(), 2u);
}

}  // namespace
}  // namespace dco::drivers
