#include "dco/daemon/daemon.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <system_error>

#include <fmt/format.h>

#include "dco/core/depth_conversion.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/daemon/raw_recorder.hpp"
#include "dco/gpu/backend.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/row_team.hpp"
#include "replay_check.hpp"

namespace dco::daemon {
namespace {

// A recording's totals: what went out, and what did not and why.
std::string raw_totals(const RawRecorder::Counts& n) {
  return fmt::format(
      "{} pairs on DCO_RAW, {} dropped, {} larger than raw.max_message_bytes, {} failed to "
      "encode or send, {} still in their send after its wait",
      n.recorded, n.dropped, n.oversized, n.failed, n.held);
}

using pipeline::runtime::Clock;

std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

sigset_t service_signals() {
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGTERM);
  sigaddset(&mask, SIGINT);
  sigaddset(&mask, SIGHUP);
  return mask;
}

void block_service_signals() {
  const sigset_t mask = service_signals();
  pthread_sigmask(SIG_BLOCK, &mask, nullptr);
}

Daemon::Daemon(ConfigSources sources, LoadedConfig config, Logger& log, SourceOpener open_source)
    : sources_(std::move(sources)),
      open_source_(std::move(open_source)),
      loaded_(std::move(config)),
      log_(log) {
  event_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (event_fd_ < 0) throw Error(std::string("eventfd: ") + std::strerror(errno));
  max_frames_ = loaded_.config.max_frames;
  // What is logged before the publisher exists (the source, the log's settings) reaches DCO_LOG
  // once it does.
  log_.hold_for_forward();
}

Daemon::~Daemon() {
  // The logger outlives the daemon (main logs what ended it): no forward into a dead publisher.
  log_.set_forward({});
  stop_all();
  if (event_fd_ >= 0) close(event_fd_);
}

void Daemon::wake() {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = write(event_fd_, &one, sizeof one);
}

void Daemon::apply_source_hints(LoadedConfig& config) const {
  const auto& hint = source_->info().max_disparity;
  if (config.max_disparity_given || !hint) return;
  config.config.pipeline.stereo.max_disparity = std::clamp(*hint, 1, stereo::kMaxDisparityLimit);
  // The values say what runs (DCO_RAW records them, reloads compare them).
  for (auto& [key, value] : config.values)
    if (key == "stereo.max_disparity")
      value = std::to_string(config.config.pipeline.stereo.max_disparity);
}

void Daemon::open() {
  source_ = open_source_(loaded_.config.source);
  if (const std::string& recorded = source_->info().recorded_pipeline; !recorded.empty()) {
    // The headset's algorithm settings come with its log; the file and --set still win.
    sources_.recorded = recorded;
    LoadedConfig with_recorded = load_config(sources_);
    std::vector<std::string> from_log;
    for (const std::string& key : changed_keys(loaded_, with_recorded))
      for (const auto& [k, value] : with_recorded.values)
        if (k == key) from_log.push_back(key + " = " + value);
    log_.info(from_log.empty() ? std::string("the log's pipeline settings are this configuration's")
                               : "from the log's pipeline settings: " + join(from_log));
    if (!with_recorded.recorded_skipped.empty())
      log_.warning("the log's pipeline settings name keys this build does not have, skipped: " +
                   join(with_recorded.recorded_skipped));
    loaded_ = std::move(with_recorded);
    max_frames_ = loaded_.config.max_frames;
  }
  apply_source_hints(loaded_);
  const DaemonConfig& c = loaded_.config;
  if (const auto& needed = source_->info().max_disparity; !loaded_.max_disparity_given && needed) {
    const int chosen = loaded_.config.pipeline.stereo.max_disparity;
    if (chosen >= *needed)
      log_.info(
          fmt::format("stereo.max_disparity = {} (covers the source's nearest depth)", chosen));
    else
      log_.warning(fmt::format(
          "the source's nearest depth needs {} px of disparity, stereo.max_disparity stops at {}: "
          "nearer surfaces are not measured",
          *needed, chosen));
  }
  open_replay_check();
  calibration_toml_ = calibration_to_toml(source_->calibration());
  Rectifier rectifier(source_->calibration());
  geometry_ = rectifier.geometry();
  if (rectifier.needs_remap()) rectifier_.emplace(std::move(rectifier));
  check_frame_size(loaded_.config.pipeline);

  ipc::RingOptions ring;
  ring.width = geometry_.width;
  ring.height = geometry_.height;
  ring.image_channels = c.ring_image ? 1 : 0;
  ring.slot_count = c.ring_slots;
  const std::filesystem::path path = c.ring_path.empty()
                                         ? ipc::RingWriter::default_directory() / "depth.shm"
                                         : std::filesystem::path(c.ring_path);
  ring_ = std::make_unique<ipc::RingWriter>(path, ring);

  ipc::PublisherOptions options;
  options.lcm_url = c.lcm_url;
  options.preview_hz = c.preview_hz;
  publisher_ = std::make_unique<ipc::DepthPublisher>(*ring_, options);
  if (const std::string problem = publisher_->lcm_problem(); !problem.empty())
    log_.warning(problem + ": depth reaches the ring's readers, LCM is tried again every " +
                 std::to_string(kLcmRetryNs / 1'000'000'000) + " s");
  lcm_retry_ns_ = monotonic_ns();
  log_.set_forward([this](LogLevel level, std::string_view text) {
    std::lock_guard lock(publish_mutex_);
    if (publisher_) publisher_->log(level, "dcod", text, monotonic_ns());
  });
}

void Daemon::check_frame_size(const pipeline::PipelineParams& stages) const {
  try {
    pipeline::check_frame_size(stages, geometry_.width, geometry_.height);
  } catch (const Error& e) {
    throw Error(
        fmt::format("the source's {}x{} frames: {}", geometry_.width, geometry_.height, e.what()));
  }
}

void Daemon::open_replay_check() {
  const auto log = drivers::replayed_log(loaded_.config.source);
  if (!log) return;
  if (!loaded_.config.runtime.deterministic) {
    log_.info(
        "the replay is not checked against the recorded depth (runtime.deterministic = false "
        "drops frames by timing)");
    return;
  }
  constexpr std::size_t kMaxPreviews = 100000;  // 2 Hz for 13 hours, under 1 GB
  drivers::RecordedPreviews recorded = drivers::read_recorded_previews(*log, kMaxPreviews);
  if (recorded.by_frame.empty()) {
    log_.info(
        "the log holds no DCO_DEPTH_PREVIEW of a recorded pair: the replay is not checked "
        "against it");
    return;
  }
  log_.info(fmt::format("checking the replay against {} recorded depth previews{}",
                        recorded.by_frame.size(),
                        recorded.truncated ? " (the first ones; the log holds more)" : ""));
  if (recorded.undecodable > 0)
    log_.warning(fmt::format("{} recorded depth previews do not decode and are not compared",
                             recorded.undecodable));
  replay_check_ = std::make_unique<ReplayCheck>(std::move(recorded), log->first_session);
}

void Daemon::start_pipeline() {
  const gpu::BackendChoice backend =
      gpu::choose_backend(loaded_.config.runtime.backend, loaded_.config.pipeline.stereo);
  if (backend.fell_back)
    log_.warning(backend.message);
  else
    log_.info(backend.message);
  // The source is not started yet, or (a restart) its thread waits for pipeline_mutex_: nothing
  // is rectifying.
  remapper_ = rectifier_ && backend.remapper ? backend.remapper(*rectifier_) : nullptr;
  auto next = std::make_unique<pipeline::runtime::DepthRuntime>(
      loaded_.config.pipeline, loaded_.config.runtime,
      [this](const pipeline::DepthResult& r, const pipeline::runtime::FrameTimes& t) {
        on_result(r, t);
      },
      pipeline::runtime::DepthRuntime::StageHook{}, backend.stages);
  const int opencv_threads = next->runtime_params().opencv_threads;
  if (!opencv_pin_) {
    opencv_pin_.emplace(opencv_threads);
    opencv_threads_asked_ = opencv_threads;
  } else if (opencv_threads != opencv_threads_asked_) {
    log_.warning(fmt::format(
        "OpenCV keeps the {} thread(s) it had as dcod started ({} now): its count changes only "
        "with a restart of dcod, as the source's thread may be in an OpenCV loop at any time",
        opencv_pin_->threads(),
        opencv_threads > 0 ? fmt::format("these stages would have it use {}", opencv_threads)
                           : std::string("these stages would leave it to OpenCV's own choice")));
  }
  if (runtime_) {
    // A restarted pipeline counts from 0: the daemon's totals keep what the one it replaces
    // dropped, and the rates measure the new one from its start.
    const pipeline::runtime::RuntimeStats before = runtime_->stats();
    earlier_.pushed += before.pushed;
    earlier_.dropped += before.dropped;
    earlier_.late += before.late;
    earlier_.published += before.published;
    early_reported_ = 0;
    early_pacer_ = WarningPacer{};
  }
  runtime_ = std::move(next);
  runtime_->start();
  pushed_in_sequence_ = false;  // the source's thread pushes nothing now (see above)
  cut_at_gaps_ = !loaded_.config.runtime.deterministic;
  const int threads = runtime_->runtime_params().threads;
  const pipeline::PipelineParams& stages = loaded_.config.pipeline;
  const int stereo_rows = pipeline::RowTeam::threads_for(stages.stereo.row_threads);
  const int contour_rows = pipeline::RowTeam::threads_for(stages.contour.row_threads);
  const int densify_rows = pipeline::RowTeam::threads_for(stages.densify.row_threads);
  log_.info(
      fmt::format("{} stage thread(s){}{}{}", threads,
                  loaded_.config.runtime.threads == 0
                      ? fmt::format(" (runtime.threads = 0, {} usable CPUs)", usable_cpus())
                      : "",
                  !contour::parallel_flow_fields(loaded_.config.pipeline.contour) ? ""
                  : loaded_.config.pipeline.contour.reuse_flow
                      ? ", the two flow fields on two threads where one cannot be reused"
                      : ", the two flow fields on two threads",
                  std::max({stereo_rows, contour_rows, densify_rows}) > 1
                      ? fmt::format(", rows on {} / {} / {} threads in stereo / contour / densify",
                                    stereo_rows, contour_rows, densify_rows)
                      : ""));
  const pipeline::runtime::RuntimeParams& rp = loaded_.config.runtime;
  if (runtime_->holds_results_for_release()) {
    // The results held for their release time are few: a latency longer than they span at the
    // camera's rate is not kept.
    const double fps = source_->info().fps;
    if (const double held_ms =
            static_cast<double>(pipeline::runtime::DepthRuntime::kReleaseSlots) * 1000.0 / fps;
        fps > 0 && rp.release_latency_ms > held_ms)
      log_.warning(fmt::format(
          "runtime.release_latency_ms {:g} is longer than the {} results the runtime holds span "
          "at {:g} fps ({:.0f} ms): results will go out early, at about that age",
          rp.release_latency_ms, pipeline::runtime::DepthRuntime::kReleaseSlots, fps, held_ms));
    if (runtime_->stats().release_realtime)
      log_.info(fmt::format("results go out {:g} ms after capture, from a SCHED_FIFO {} thread",
                            rp.release_latency_ms, rp.release_priority));
    else if (rp.release_priority > 0)
      log_.warning(fmt::format(
          "results go out {:g} ms after capture, but SCHED_FIFO {} was refused (no CAP_SYS_NICE, "
          "RLIMIT_RTPRIO below it, or the unit's RestrictRealtime): while the stages keep every "
          "CPU busy a release can slip by a scheduler tick",
          rp.release_latency_ms, rp.release_priority));
  }
  // Only the first start: a reload that restarts the stages is no sign that frames flow, and a
  // hung camera must not earn another stall_timeout_s of watchdog pings from one.
  if (pipeline_start_ns_ == 0) pipeline_start_ns_ = monotonic_ns();
}

void Daemon::start_source() {
  source_->start(*this);
}

void Daemon::stop_all() {
  // The source first: it pushes into the runtime, which must be idle before it stops.
  if (source_) source_->stop();
  if (runtime_) runtime_->stop();
}

void Daemon::finish_frames_in_flight() {
  if (!runtime_ || !runtime_->running()) return;  // stages that did not start hold no frame
  try {
    runtime_->drain();
  } catch (const std::exception& e) {
    on_error(e.what());  // a stage failed: nothing more can be finished
  }
}

void Daemon::on_frame(const drivers::StereoFrame& frame) {
  const std::lock_guard pipeline_lock(pipeline_mutex_);
  {
    std::lock_guard lock(raw_mutex_);
    if (raw_) raw_->offer(frame);
  }
  frame_numbers_.record(frame.capture_ns, frame.seq);
  // In deterministic mode push holds the camera up, so the frames' timing is the pipeline's: a
  // slow first frame of a sequence would look like a gap and cut again. There the frames run as
  // DepthPipeline would take them, cut only where a recorded dcod run started its own.
  if ((frame.starts_run || (frame.follows_gap && cut_at_gaps_)) && pushed_in_sequence_) {
    // The frames before the gap finish as a sequence of their own: none of them is this frame's
    // neighbour for the flow or the stability term. A replayed log cuts at the same frames.
    runtime_->drain();
    SequenceCuts& cuts = frame.starts_run ? log_runs_ : camera_gaps_;
    cuts.last_seq = frame.seq;
    ++cuts.count;
  }
  pushed_in_sequence_ = true;
  const Clock::time_point capture{std::chrono::nanoseconds(frame.capture_ns)};
  if (rectifier_) {
    rectifier_->rectify(frame.left, frame.right, rect_left_, rect_right_, remapper_.get());
    runtime_->push(rect_left_.cview(), rect_right_.cview(), capture);
  } else {
    runtime_->push(frame.left, frame.right, capture);
  }
}

void Daemon::on_end() {
  source_ended_ = true;
  wake();
}

void Daemon::on_error(const std::string& message) {
  {
    // The first failure is the cause; what follows from it is not reported in its place.
    std::lock_guard lock(error_mutex_);
    if (!failed_) error_ = message;
    failed_ = true;
  }
  wake();
}

void Daemon::on_result(const pipeline::DepthResult& result,
                       const pipeline::runtime::FrameTimes& times) {
  const int max_frames = max_frames_;
  if (max_frames > 0 && published_ >= max_frames) {
    // A reload can lower the limit below what is already published: that is reaching it too.
    max_reached_ = true;
    wake();
    return;
  }
  const std::int64_t capture_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(times.capture.time_since_epoch())
          .count();
  ipc::FrameMeta meta;
  meta.capture_ns = capture_ns;
  meta.frame_seq = frame_numbers_.take(capture_ns, static_cast<std::uint64_t>(result.index));
  meta.fx = meta.fy = geometry_.f;
  meta.cx = geometry_.cx_left;
  meta.cy = geometry_.cy;
  meta.baseline_m = geometry_.baseline_m;
  try {
    std::lock_guard lock(publish_mutex_);
    const ipc::RingWriter::Slot slot = publisher_->begin_write();
    disparity_to_depth(result.dense.cview(), geometry_, slot.depth);
    if (replay_check_) replay_check_->check(meta.frame_seq, slot.depth);
    if (!slot.image.empty())
      for (int y = 0; y < slot.image.height; ++y)
        std::memcpy(slot.image.row(y), result.image.row(y),
                    static_cast<std::size_t>(slot.image.width));
    publisher_->publish(meta);
  } catch (const std::exception& e) {
    on_error(std::string("publishing: ") + e.what());
    return;
  }
  last_publish_ns_ = monotonic_ns();
  if (++published_ == max_frames) {
    max_reached_ = true;
    wake();
  }
}

void Daemon::retry_lcm(std::int64_t now_ns) {
  // A set-up under way is looked at every tick (without waiting: the lock is the frames'); a new
  // one starts every kLcmRetryNs.
  if (!publisher_->lcm_setup_running()) {
    if (publisher_->lcm_ready() || now_ns - lcm_retry_ns_ < kLcmRetryNs) return;
    lcm_retry_ns_ = now_ns;
  }
  bool set_up = false;
  {
    std::lock_guard lock(publish_mutex_);
    set_up = publisher_->retry_lcm();
  }
  if (set_up) log_.info("LCM is set up now: DCO_DEPTH and the other channels go out");
}

void Daemon::report_lcm_failures(std::int64_t now_ns, bool last) {
  std::uint64_t failures = 0;
  std::string channel;
  {
    std::lock_guard lock(publish_mutex_);
    failures = publisher_->send_failures();
    channel = publisher_->last_failed_channel();
  }
  // Paced: a network that stays away must not fill the journal (the warning itself goes out on
  // DCO_LOG, which fails too).
  const bool news = failures > lcm_failures_reported_;
  if (!lcm_failure_pacer_.due(now_ns, news) && !last) return;
  if (!news) return;
  log_.warning(
      fmt::format("LCM could not send {} messages (the last on {}); depth still reaches "
                  "the ring's readers",
                  failures - lcm_failures_reported_, channel));
  lcm_failures_reported_ = failures;
}

void Daemon::report_sequence_cuts(std::int64_t now_ns, bool last) {
  // Paced: a camera that keeps dropping out must not fill the journal.
  const auto report = [&](SequenceCuts& cuts, const char* what, const char* where) {
    const std::uint64_t count = cuts.count.load();
    const bool news = count > cuts.reported;
    if (!(cuts.pacer.due(now_ns, news) || last) || !news) return;
    log_.info(
        fmt::format("{} {} since the last report (the last {} frame {}): depth started a "
                    "new sequence at each",
                    count - cuts.reported, what, where, cuts.last_seq.load()));
    cuts.reported = count;
  };
  report(camera_gaps_, "gap(s) in the camera's frames", "before");
  report(log_runs_, "new dcod run(s) in the replayed log", "from");
}

pipeline::runtime::RuntimeStats Daemon::run_stats() const {
  pipeline::runtime::RuntimeStats s = runtime_->stats();
  s.pushed += earlier_.pushed;
  s.dropped += earlier_.dropped;
  s.late += earlier_.late;
  s.published += earlier_.published;
  return s;
}

std::string Daemon::status_line(const pipeline::runtime::RuntimeStats& s) const {
  return fmt::format(
      "{}: {:.1f} fps in, {:.1f} fps out, {} published, {} dropped ({} late), latency p50 {:.1f} "
      "ms p99 {:.1f} ms{}{}",
      source_device_.empty() ? source_->info().description : source_device_, fps_in_, fps_out_,
      published_.load(), s.dropped, s.late, s.latency.p50_ms, s.latency.p99_ms,
      // With runtime.release_latency_ms the latency is fixed: what the stages took and the
      // results ready too late for it tell whether the setting suits the machine.
      runtime_->holds_results_for_release()
          ? fmt::format(" (ready p99 {:.1f} ms, {} overdue, {} early)", s.ready.p99_ms, s.overdue,
                        s.early)
          : std::string(),
      stalled_ ? "; STALLED" : "");
}

void Daemon::tick(std::int64_t now_ns) {
  // The source's state only while frames pause: status() builds strings, and a tick can come
  // with every frame.
  constexpr std::int64_t kPauseNs = 200'000'000;
  const std::int64_t last_publish = last_publish_ns_.load();
  const std::int64_t start = pipeline_start_ns_.load();
  const bool ok = stall_clock_.healthy(
      now_ns, last_publish, start,
      now_ns - last_publish > kPauseNs &&
          source_->status().state == drivers::SourceStatus::State::kDisconnected,
      loaded_.config.stall_timeout_s);
  if (!ok && !stalled_) {
    stalled_ = true;
    log_.warning(fmt::format(
        "no frame published for {:.1f} s: watchdog pings withheld",
        static_cast<double>(now_ns - stall_clock_.since_ns(last_publish, start)) * 1e-9));
  } else if (ok && stalled_) {
    stalled_ = false;
    log_.info("frames flow again");
  }
  if (const auto period = notifier_.watchdog_period();
      period && ok && now_ns - last_ping_ns_ >= period->count() * 1000 / 4) {
    notifier_.watchdog();
    last_ping_ns_ = now_ns;
  }
  retry_lcm(now_ns);
  report_lcm_failures(now_ns, false);
  report_sequence_cuts(now_ns, false);
  if (now_ns < next_stats_ns_) return;
  next_stats_ns_ = now_ns + static_cast<std::int64_t>(1e9 / loaded_.config.stats_hz);
  const pipeline::runtime::RuntimeStats stats = run_stats();
  if (last_rate_ns_ > 0 && now_ns > last_rate_ns_) {
    const double dt = static_cast<double>(now_ns - last_rate_ns_) * 1e-9;
    fps_in_ = static_cast<double>(std::max(0L, stats.pushed - last_pushed_)) / dt;
    fps_out_ = static_cast<double>(std::max(0L, stats.published - last_published_)) / dt;
  }
  last_rate_ns_ = now_ns;
  last_pushed_ = stats.pushed;
  last_published_ = stats.published;
  if (const bool early = stats.early > early_reported_; early_pacer_.due(now_ns, early) && early) {
    log_.warning(fmt::format(
        "{} result(s) went out before runtime.release_latency_ms ({:g} ms) since the last report: "
        "all {} release slots were taken (the latency spans more frames than they hold, or the "
        "stages caught up after a stall)",
        stats.early - early_reported_, loaded_.config.runtime.release_latency_ms,
        pipeline::runtime::DepthRuntime::kReleaseSlots));
    early_reported_ = stats.early;
  }
  // A field engineer's first question about a cheap stereo pair: how far apart its two cameras'
  // exposure and rows are. Logged when it changes (a restarted pipeline fits it anew).
  if (std::string correction = stereo::describe(stats.camera_correction);
      stats.published > 0 && correction != logged_correction_) {
    logged_correction_ = std::move(correction);
    log_.info("camera alignment: " + logged_correction_);
  }
  drivers::SourceStatus source = source_->status();
  ipc::DeviceStatus status;
  using State = ipc::DeviceStatus::State;
  switch (source.state) {
    case drivers::SourceStatus::State::kDisconnected:
      status.state = State::kDisconnected;
      break;
    case drivers::SourceStatus::State::kError:
      status.state = State::kError;
      break;
    case drivers::SourceStatus::State::kStarting:
      status.state = State::kStarting;
      break;
    case drivers::SourceStatus::State::kStreaming:
      status.state = published_ == 0 ? State::kStarting : ok ? State::kStreaming : State::kError;
      break;
  }
  source_device_ = source.device;
  status.device = std::move(source.device);
  status.serial = std::move(source.serial);
  status.firmware = std::move(source.firmware);
  status.usb_speed_mbps = source.usb_speed_mbps;
  status.error = std::move(source.error);
  status.counters = std::move(source.counters);
  if (source.state == drivers::SourceStatus::State::kStreaming && published_ != 0 && !ok)
    status.error = "no frame published within service.stall_timeout_s";
  try {
    std::lock_guard lock(publish_mutex_);
    publisher_->publish_stats(stats, now_ns);
    publisher_->publish_status(status, now_ns);
  } catch (const std::exception& e) {
    on_error(std::string("publishing statistics: ") + e.what());
  }
  notifier_.status(status_line(stats));
  report_raw_recording(now_ns, false);
}

void Daemon::configure_raw_recording() {
  const DaemonConfig& c = loaded_.config;
  const std::string pipeline = pipeline_keys(loaded_);
  const std::string settings =
      c.raw_enabled ? fmt::format("{} {} {}\n{}", c.raw_png_level, c.raw_max_message_bytes,
                                  c.runtime.deterministic, pipeline)
                    : std::string();
  if (settings == raw_settings_) return;
  std::unique_ptr<RawRecorder> next;
  if (c.raw_enabled) {
    RawRecorderOptions o;
    o.png_level = c.raw_png_level;
    o.max_message_bytes = static_cast<std::size_t>(c.raw_max_message_bytes);
    o.never_drop = c.runtime.deterministic;
    o.pipeline_config = pipeline;
    try {
      next = std::make_unique<RawRecorder>(
          calibration_toml_, o,
          [this](const ::dco::raw_stereo_t& m) {
            // Not under publish_mutex_: publish_raw waits for LCM to send the pair, which must
            // never hold up a frame on its way into the ring.
            return publisher_->publish_raw(m);
          },
          [this] { return publisher_->raw_can_go(); });
    } catch (const std::system_error& e) {
      throw Error(std::string("raw recording: its thread cannot start: ") + e.what());
    }
  }
  std::optional<RawRecorder::Counts> closed;
  {
    // The old recorder sends what it holds before the new one takes a pair, and the source's
    // offers wait meanwhile: DCO_RAW stays in frame order, which a replay plays it in.
    std::lock_guard lock(raw_mutex_);
    if (raw_) closed = raw_->close();
    raw_ = std::move(next);
  }
  if (closed) log_.info("raw recording stopped: " + raw_totals(*closed));
  raw_dropped_reported_ = raw_oversized_reported_ = raw_failed_reported_ = raw_held_reported_ = 0;
  raw_dropped_pacer_ = raw_failed_pacer_ = WarningPacer{};
  raw_settings_ = settings;
  if (c.raw_enabled)
    log_.info(fmt::format(
        "recording raw pairs on DCO_RAW (PNG level {}, messages up to {} bytes{})", c.raw_png_level,
        c.raw_max_message_bytes, c.runtime.deterministic ? ", none dropped" : ""));
}

void Daemon::report_raw_recording(std::int64_t now_ns, bool last) {
  RawRecorder::Counts n;
  std::string error;
  {
    std::lock_guard lock(raw_mutex_);
    if (!raw_) return;
    n = raw_->counts();
    error = raw_->last_error();
  }
  // Paced like LCM's failures: a fault that lasts is reported ever less often, with its counts.
  const bool dropped = n.dropped > raw_dropped_reported_;
  if ((raw_dropped_pacer_.due(now_ns, dropped) || last) && dropped) {
    log_.warning(
        fmt::format("raw recording: {} pairs dropped (compressing and sending them is slower "
                    "than the camera; a lower raw.png_level helps unless LCM holds them up)",
                    n.dropped - raw_dropped_reported_));
    raw_dropped_reported_ = n.dropped;
  }
  const bool lost = n.oversized > raw_oversized_reported_ || n.failed > raw_failed_reported_ ||
                    n.held > raw_held_reported_;
  if ((raw_failed_pacer_.due(now_ns, lost) || last) && lost) {
    // A pair still in its send when the wait ran out may go out yet: counted apart.
    const std::string held = n.held == 0
                                 ? std::string()
                                 : fmt::format(
                                       "; {} held in their send past its wait, {} since (each goes "
                                       "out if the network takes it)",
                                       n.held, n.held - raw_held_reported_);
    log_.warning(fmt::format(
        "raw recording: {} pairs not recorded, {} since the last report{}; the last: {}",
        n.oversized + n.failed,
        n.oversized + n.failed - raw_oversized_reported_ - raw_failed_reported_, held, error));
    raw_oversized_reported_ = n.oversized;
    raw_failed_reported_ = n.failed;
    raw_held_reported_ = n.held;
  }
}

void Daemon::apply_live_settings(bool raw_recording) {
  log_.set_level(parse_log_level(loaded_.config.log_level));
  // A new lcm.stats_hz applies at once, not after the old period.
  next_stats_ns_ = std::min<std::int64_t>(
      next_stats_ns_, monotonic_ns() + static_cast<std::int64_t>(1e9 / loaded_.config.stats_hz));
  max_frames_ = loaded_.config.max_frames;
  {
    std::lock_guard lock(publish_mutex_);
    publisher_->set_preview_hz(loaded_.config.preview_hz);
  }
  if (raw_recording) configure_raw_recording();
}

void Daemon::restart_pipeline() {
  // The frames already taken in are finished with the settings they came under: a reload loses
  // none (stop() would discard them).
  finish_frames_in_flight();
  runtime_->stop();
  // DCO_RAW records the pipeline keys each pair is processed with: the recorder changes with the
  // stages, while no frame comes in.
  configure_raw_recording();
  start_pipeline();
}

void Daemon::reload() {
  notifier_.reloading();
  LoadedConfig next;
  try {
    next = load_config(sources_);
    parse_log_level(next.config.log_level);
  } catch (const Error& e) {
    log_.error(std::string("reload failed, the running configuration stays: ") + e.what());
    notifier_.ready(status_line(run_stats()));
    return;
  }
  apply_source_hints(next);
  std::vector<std::string> live, restarted, refused;
  for (const std::string& key : changed_keys(loaded_, next)) {
    switch (reload_kind(key)) {
      case Reload::kLive:
        live.push_back(key);
        break;
      case Reload::kPipeline:
        restarted.push_back(key);
        break;
      case Reload::kRestart:
        refused.push_back(key);
        break;
    }
  }
  // What only a restart changes keeps its running value, so the next reload compares against it.
  for (std::size_t i = 0; i < next.values.size(); ++i)
    if (reload_kind(next.values[i].first) == Reload::kRestart) next.values[i] = loaded_.values[i];
  next.config.source = loaded_.config.source;
  next.config.ring_path = loaded_.config.ring_path;
  next.config.ring_slots = loaded_.config.ring_slots;
  next.config.ring_image = loaded_.config.ring_image;
  next.config.lcm_url = loaded_.config.lcm_url;
  next.config.runtime.opencv_threads = loaded_.config.runtime.opencv_threads;

  if (!restarted.empty()) {
    // Limits that depend on the frame size hold for the source's frames before anything stops:
    // otherwise the first frame would fail the new stages and end dcod.
    try {
      check_frame_size(next.config.pipeline);
    } catch (const Error& e) {
      log_.error(std::string("reload failed, the running configuration stays: ") + e.what());
      notifier_.ready(status_line(run_stats()));
      return;
    }
  }
  // Through the restart and, when it fails, the one with what ran: no frame reaches stages that
  // are not running.
  std::unique_lock pipeline_lock(pipeline_mutex_, std::defer_lock);
  if (!restarted.empty()) pipeline_lock.lock();
  LoadedConfig previous = std::move(loaded_);
  loaded_ = std::move(next);
  try {
    apply_live_settings(restarted.empty());  // else the restart changes the raw recording
  } catch (const std::exception& e) {
    // A recorder whose thread the system refuses (a task limit reached): the old one records on.
    log_.error(std::string("reload failed, the running configuration stays: ") + e.what());
    loaded_ = std::move(previous);
    apply_live_settings(false);
    notifier_.ready(status_line(run_stats()));
    return;
  }
  if (!restarted.empty()) {
    try {
      restart_pipeline();
    } catch (const std::exception& e) {
      // Some values pass every check and fail only when the stages start (a CPU the process may
      // not use, a backend this machine lacks): go back to what ran.
      log_.error(std::string("reload failed, the running configuration stays: restarting the "
                             "pipeline: ") +
                 e.what());
      loaded_ = std::move(previous);
      apply_live_settings(false);
      try {
        restart_pipeline();
      } catch (const std::exception& again) {
        on_error(std::string("restarting the pipeline with the running configuration: ") +
                 again.what());
        return;
      }
      notifier_.ready(status_line(run_stats()));
      return;
    }
  }
  std::string summary = "reloaded";
  if (live.empty() && restarted.empty() && refused.empty()) summary += ": nothing changed";
  if (!live.empty()) summary += "; applied " + join(live);
  if (!restarted.empty()) summary += "; restarted the pipeline for " + join(restarted);
  if (!refused.empty()) summary += "; not applied, need a restart of dcod: " + join(refused);
  if (refused.empty())
    log_.info(summary);
  else
    log_.warning(summary);
  notifier_.ready(status_line(run_stats()));
}

int Daemon::run() {
  try {
    open();
    start_pipeline();
    configure_raw_recording();
    start_source();
  } catch (const std::exception& e) {
    log_.error(e.what());
    stop_all();
    log_.set_forward({});
    return 1;
  }
  const sigset_t mask = service_signals();
  const int signal_fd = signalfd(-1, &mask, SFD_CLOEXEC | SFD_NONBLOCK);
  if (signal_fd < 0) {
    log_.error(std::string("signalfd: ") + std::strerror(errno));
    stop_all();
    log_.set_forward({});
    return 1;
  }
  log_.info(fmt::format("{} -> {} ({}x{}, {} slots)", source_->info().description,
                        ring_->path().string(), geometry_.width, geometry_.height,
                        ring_->options().slot_count));
  const std::int64_t start_ns = monotonic_ns();
  next_stats_ns_ = start_ns + static_cast<std::int64_t>(1e9 / loaded_.config.stats_hz);
  last_rate_ns_ = start_ns;
  notifier_.ready(status_line(run_stats()));
  if (notifier_.watchdog_period()) {
    notifier_.watchdog();
    last_ping_ns_ = start_ns;
  }

  int status = 0;
  for (bool running = true; running;) {
    int timeout_ms = 250;
    if (const auto period = notifier_.watchdog_period())
      timeout_ms = std::clamp(static_cast<int>(period->count() / 8000), 1, timeout_ms);
    pollfd fds[2] = {{signal_fd, POLLIN, 0}, {event_fd_, POLLIN, 0}};
    if (poll(fds, 2, timeout_ms) < 0 && errno != EINTR) {
      log_.error(std::string("poll: ") + std::strerror(errno));
      status = 1;
      break;
    }
    signalfd_siginfo info{};
    // The kernel hands pending signals over lowest number first, SIGHUP before SIGTERM: a stop
    // that came with a reload is not delayed by the reload's pipeline restart.
    bool reload_asked = false;
    while (read(signal_fd, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
      if (info.ssi_signo == SIGHUP) {
        reload_asked = true;
      } else {
        log_.info(fmt::format("stopping on {}", info.ssi_signo == SIGTERM ? "SIGTERM" : "SIGINT"));
        running = false;
      }
    }
    if (reload_asked && running) reload();
    std::uint64_t events = 0;
    [[maybe_unused]] const ssize_t n = read(event_fd_, &events, sizeof events);
    if (failed_) {
      // A source that fails (a log cut short, a camera error) leaves good frames in the stages:
      // they are published before the exit, as a failed stage's are not.
      source_->stop();
      finish_frames_in_flight();
      std::lock_guard lock(error_mutex_);
      log_.error(fmt::format("{} (after {} published frames)", error_, published_.load()));
      status = 1;
      break;
    }
    if (!running) break;
    if (max_reached_) {
      log_.info(
          fmt::format("published {} frames (service.max_frames): stopping", published_.load()));
      break;
    }
    if (source_ended_) {
      source_->stop();
      try {
        runtime_->drain();
      } catch (const std::exception& e) {
        log_.error(e.what());
        status = 1;
        break;
      }
      log_.info(
          fmt::format("the source ended after {} published frames: stopping", published_.load()));
      break;
    }
    tick(monotonic_ns());
  }
  notifier_.stopping();
  stop_all();
  report_raw_recording(monotonic_ns(), true);  // those since the last warnings
  report_sequence_cuts(monotonic_ns(), true);
  if (raw_) {
    std::lock_guard lock(raw_mutex_);
    const RawRecorder::Counts n = raw_->close();  // sends the pairs it still holds
    raw_.reset();
    log_.info("raw recording: " + raw_totals(n));
  }
  // What is queued goes out (or counts as failed) before LCM's failures are counted a last time;
  // a network that holds a send is not waited for long.
  constexpr std::chrono::milliseconds kFinalFlush{500};
  if (!publisher_->flush(kFinalFlush))
    log_.warning(
        "LCM had not sent every message as dcod stopped (its network holds a send): the rest are "
        "dropped");
  report_lcm_failures(monotonic_ns(), true);
  if (replay_check_) {
    if (const ReplayCheck::Result r = replay_check_->result(); r.identical == r.compared)
      log_.info(replay_check_->summary());
    else
      log_.warning(replay_check_->summary());
  }
  log_.info("stopped");
  log_.set_forward({});
  {
    std::lock_guard lock(publish_mutex_);
    publisher_.reset();
  }
  ring_.reset();
  close(signal_fd);
  return status;
}

}  // namespace dco::daemon
