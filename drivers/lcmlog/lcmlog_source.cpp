// lcmlog://FILE: the raw stereo pairs an LCM log recorded on DCO_RAW (dcod with raw.enabled),
// paced at `fps` (0 = as fast as the pipeline takes them), through the same pipeline as live;
// `run=N` replays the log's Nth dcod run alone. The log streams: one event at a time, never the
// whole file in memory.

#include <string_view>

#include <fmt/format.h>

#include "../src/paced_source.hpp"
#include "../src/sources.hpp"
#include "dco/core/error.hpp"
#include "dco/drivers/capture_gaps.hpp"
#include "dco/drivers/lcm_log.hpp"
#include "dco/drivers/raw_stereo.hpp"
#include "dco/drivers/recorded_previews.hpp"
#include "dco/ipc/lcm_messages.hpp"

namespace dco::drivers {
namespace {

class LcmLogSource final : public PacedSource {
 public:
  explicit LcmLogSource(SourceUri& uri) : path_(uri.path()) {
    info_.uri = uri.text();
    info_.fps = uri.fps(30, "as fast as taken");
    channel_ = uri.value("channel").value_or(ipc::channel::kRaw);
    run_ = uri.integer("run", 0, 1, kMaxRun);
    uri.finish();
    where_ = "lcmlog://" + path_;
    reader_ = std::make_unique<LcmLogReader>(path_);
    // The first pair (of the run asked for) says the size, calibration and pipeline keys every
    // later one must have. read_message() names damage itself.
    if (!read_message()) {
      throw Error(
          fmt::format("{}: no {} message in {} events (was dcod recording with "
                      "raw.enabled = true?)",
                      where_, channel_, reader_->events_read()));
    }
    last_run_ = runs_.session_of(message_.frame_seq);
    while (run_ > 0 && last_run_ < run_ - 1) {
      if (!read_message())
        throw Error(fmt::format("{}: run={} asked for, the log holds {} dcod run(s)", where_, run_,
                                last_run_ + 1));
      last_run_ = runs_.session_of(message_.frame_seq);
    }
    decode_pair();
    calibration_toml_ = message_.calibration;
    calibration_ = calibration_from_toml(calibration_toml_, where_ + " (recorded calibration)");
    if (calibration_.left.width != message_.width || calibration_.left.height != message_.height)
      throw Error(fmt::format("{}: frames of {}x{} but a calibration for {}x{}", where_,
                              message_.width, message_.height, calibration_.left.width,
                              calibration_.left.height));
    info_.recorded_pipeline = message_.pipeline_config;
    info_.width = message_.width;
    info_.height = message_.height;
    info_.channels = left_.channels();
    info_.description = fmt::format(
        "lcmlog {}{} {}x{} @ {} fps", path_,
        run_ > 0 ? fmt::format(" run {}", run_) : std::string(), info_.width, info_.height,
        info_.fps > 0 ? fmt::format("{}", info_.fps) : std::string("max"));
    pending_ = true;
  }
  ~LcmLogSource() override { stop(); }

  const SourceInfo& info() const override { return info_; }
  const StereoCalibration& calibration() const override { return calibration_; }

 private:
  static constexpr int kMaxRun = 1'000'000;

  // The next recorded pair's message into message_, its images not decoded; false at the end of
  // the log. Damage ends the replay with an error naming where.
  bool read_message() {
    while (reader_->next(event_)) {
      if (event_.channel != channel_) continue;
      std::string problem;
      if (!ipc::decode_message(event_.data.data(), event_.data.size(), message_, problem))
        throw Error(fmt::format("{}: event {} at byte {} on {}: {}", where_, event_.number,
                                event_.offset, channel_, problem));
      return true;
    }
    // The reader's line starts with the file's name: the URI's scheme before it names it once.
    if (!reader_->damage().empty()) throw Error("lcmlog://" + reader_->damage());
    return false;
  }

  // The pair in message_ has other settings than the replay's first: a new dcod run replays on
  // its own (`other_than`), a change within a run (`changes`: a reload) ends the replay.
  Error settings_error(bool new_run, std::int64_t run, std::string_view other_than,
                       std::string_view changes) const {
    if (new_run)
      return Error(
          fmt::format("{}: dcod run {} (from frame {}) has {} the replay started with; "
                      "replay it alone: {}?run={}{}",
                      where_, run + 1, message_.frame_seq, other_than, where_, run + 1,
                      channel_ == ipc::channel::kRaw ? "" : "&channel=" + channel_));
    return Error(
        fmt::format("{}: {} at frame {} (the headset reloaded its settings): the replay "
                    "ends here",
                    where_, changes, message_.frame_seq));
  }

  void decode_pair() {
    decode_raw_stereo(message_, left_, right_);
    decode_raw_imu(message_, imu_);
  }

  bool produce(std::uint64_t, ImageView<const std::uint8_t>& left,
               ImageView<const std::uint8_t>& right) override {
    std::int64_t run = last_run_;  // the first pair's, read at open
    if (!pending_) {
      if (!read_message()) return false;
      run = runs_.session_of(message_.frame_seq);
      if (run_ > 0 && run != run_ - 1) return false;  // the run asked for ended
      // The headset made its depth with the recorded keys, and a replay with others would not be
      // its depth. A new run may have new keys (a new configuration) and is replayed alone; a
      // reload within a run restarted the headset's pipeline with them, which a replay from one
      // set of keys cannot follow.
      const bool new_run = run != last_run_;
      // Before the PNGs are decoded: a pair that says it is larger than the log's frames would
      // take its size in memory first.
      if (message_.width != info_.width || message_.height != info_.height) {
        if (new_run) throw settings_error(true, run, "another image size than", "");
        throw Error(fmt::format("{}: frame {} is {}x{}, the log started with {}x{}", where_,
                                message_.frame_seq, message_.width, message_.height, info_.width,
                                info_.height));
      }
      if (message_.pipeline_config != info_.recorded_pipeline)
        throw settings_error(new_run, run, "other pipeline keys than", "the pipeline keys change");
      if (message_.calibration != calibration_toml_)
        throw settings_error(new_run, run, "another calibration than", "the calibration changes");
      decode_pair();
    }
    pending_ = false;
    starts_run_ = run != last_run_;
    // The size was checked before the PNGs were decoded; they say grey or colour.
    if (left_.channels() != info_.channels) {
      if (starts_run_) throw settings_error(true, run, "other image channels than", "");
      throw Error(fmt::format("{}: frame {} has {} channels, the log started with {}", where_,
                              message_.frame_seq, left_.channels(), info_.channels));
    }
    // Found on the recorded stamps, as the headset found its gaps, so the replay cuts its
    // sequences where the headset did. Another dcod run started its own, and its gaps afresh.
    if (starts_run_) gaps_ = CaptureGaps{};
    gap_ = gaps_.follows_gap(message_.capture_ns) || starts_run_;
    last_run_ = run;
    left = left_.cview();
    right = right_.cview();
    return true;
  }
  void mark_sequence(StereoFrame& frame) const override {
    frame.follows_gap = gap_;
    frame.starts_run = starts_run_;
  }

  // Replayed frames keep the numbers the headset gave them, so its log and the replay's agree.
  std::uint64_t frame_number(std::uint64_t) const override {
    return static_cast<std::uint64_t>(message_.frame_seq);
  }
  // The replay stamps a frame when it delivers it; the samples carry the headset's clock. Each
  // keeps its offset to the recorded frame's capture time, moved onto the replay's time line, so
  // a frame and its samples share one clock (and a re-recorded replay keeps them together).
  // Between frames the samples follow the replay's pace, not the recorded one; a replay faster
  // than the recording would put a frame's first samples before the last frame's, so each
  // sample comes at least a nanosecond after the one before (IMU consumers integrate in order,
  // as the camera's own stream promises). The arithmetic wraps instead of overflowing on a
  // damaged log's stamps.
  std::span<const ImuSample> frame_imu(std::int64_t capture_ns) override {
    replayed_imu_.assign(imu_.begin(), imu_.end());
    const auto shift =
        static_cast<std::uint64_t>(capture_ns) - static_cast<std::uint64_t>(message_.capture_ns);
    for (ImuSample& s : replayed_imu_) {
      s.capture_ns = static_cast<std::int64_t>(static_cast<std::uint64_t>(s.capture_ns) + shift);
      if (last_imu_ns_ && s.capture_ns <= *last_imu_ns_) s.capture_ns = *last_imu_ns_ + 1;
      last_imu_ns_ = s.capture_ns;
    }
    return replayed_imu_;
  }

  std::string path_, where_, channel_, calibration_toml_;
  std::unique_ptr<LcmLogReader> reader_;
  LcmLogEvent event_;
  ::dco::raw_stereo_t message_;
  Image<std::uint8_t> left_, right_;
  std::vector<ImuSample> imu_;               // as recorded
  std::vector<ImuSample> replayed_imu_;      // on the replay's time line
  std::optional<std::int64_t> last_imu_ns_;  // the last sample handed on
  bool pending_ = false;                     // the first pair, read at open, not yet delivered
  CaptureGaps gaps_;
  bool gap_ = false, starts_run_ = false;  // of the pair produce() made
  int run_ = 0;                            // the one dcod run to replay (1, 2, ...; 0: all)
  FrameSessions runs_;
  // The dcod run (0, 1, ...) of the pair delivered last (before the first: of the one read at
  // open).
  std::int64_t last_run_ = 0;
  StereoCalibration calibration_;
  SourceInfo info_;
};

}  // namespace

std::unique_ptr<FrameSource> open_lcmlog(SourceUri& uri) {
  return std::make_unique<LcmLogSource>(uri);
}

}  // namespace dco::drivers
