#pragma once

#include <signal.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "dco/core/image.hpp"
#include "dco/core/priority_inheritance_mutex.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/daemon/daemon_config.hpp"
#include "dco/daemon/frame_numbers.hpp"
#include "dco/daemon/logger.hpp"
#include "dco/daemon/service_notifier.hpp"
#include "dco/daemon/stall_clock.hpp"
#include "dco/daemon/warning_pacer.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/ipc/publisher.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "dco/pipeline/runtime/depth_runtime.hpp"

namespace dco::daemon {
class RawRecorder;
class ReplayCheck;
}  // namespace dco::daemon

namespace dco::daemon {

// SIGTERM, SIGINT and SIGHUP: what the daemon reads from its signalfd.
sigset_t service_signals();
// Blocks service_signals() in the calling thread. Called before any thread starts, every thread
// inherits the mask and the signals reach the daemon's signalfd only.
void block_service_signals();

// dcod's wiring and lifecycle: source -> rectify -> real-time runtime -> depth ring + LCM, with
// the service manager told about readiness, status and health. The source delivers on its own
// thread, the runtime publishes on its last stage's thread, and the thread that calls run()
// handles signals, statistics, status and the watchdog.
class Daemon final : public drivers::FrameSink {
 public:
  // How a source URI becomes a source: drivers::open_source, or a simulated device in tests.
  using SourceOpener = std::function<std::unique_ptr<drivers::FrameSource>(std::string_view)>;

  Daemon(ConfigSources sources, LoadedConfig config, Logger& log,
         SourceOpener open_source = drivers::open_source);
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;
  ~Daemon() override;

  // Runs until SIGTERM or SIGINT, the end of a finite source, service.max_frames, or a failure.
  // The caller must have blocked SIGTERM, SIGINT and SIGHUP in every thread (they are read from
  // a signalfd). Returns the exit status: 0 after a clean stop, 1 after a failure (logged).
  int run();

 private:
  void on_frame(const drivers::StereoFrame& frame) override;
  void on_end() override;
  void on_error(const std::string& message) override;
  void on_result(const pipeline::DepthResult& result, const pipeline::runtime::FrameTimes& times);

  void open();  // source, rectifier, ring, publisher; throws dco::Error
  // What the source knows better than a default (the disparity range of a synthetic scene).
  void apply_source_hints(LoadedConfig& config) const;
  void start_pipeline();  // a new runtime from the current config, started
  void start_source();
  void stop_all();
  // Waits until the runtime has published every frame it took in (the source stopped first); a
  // failed stage is reported through on_error.
  void finish_frames_in_flight();
  // Reads the recorded depth previews when the source replays a field log deterministically.
  void open_replay_check();
  void reload();
  // What a reload applies without restarting the pipeline, from loaded_; the raw recording
  // too unless the pipeline restarts, which changes it with the stages.
  void apply_live_settings(bool raw_recording = true);
  // The stage threads again with loaded_, between two frames: the caller holds pipeline_mutex_,
  // so the source's thread waits in on_frame meanwhile.
  void restart_pipeline();
  // Starts, stops or re-creates the DCO_RAW recorder as the configuration says.
  void configure_raw_recording();
  // Warnings of pairs dropped or not sent since the last ones, paced; `last`: at the exit,
  // whatever the pace.
  void report_raw_recording(std::int64_t now_ns, bool last);
  void tick(std::int64_t now_ns);
  // Sets LCM up when it could not be at the start (no multicast route yet, a tcpq server that
  // does not answer): a set-up under way is looked at every tick, a new one starts every
  // kLcmRetryNs.
  void retry_lcm(std::int64_t now_ns);
  static constexpr std::int64_t kLcmRetryNs = 2'000'000'000;
  // A warning when LCM failed to send since the last one (the ring is unaffected); `last`: at
  // the exit, whenever the last warning was.
  void report_lcm_failures(std::int64_t now_ns, bool last);
  // Info lines when the source's frames had gaps, or a replayed log new dcod runs, since the last
  // ones (a sequence cut at each), paced like the warnings; `last`: at the exit, whatever the
  // pace.
  void report_sequence_cuts(std::int64_t now_ns, bool last);
  // The running runtime's statistics with the counts of those that reloads replaced added: the
  // counters of dcod's whole run, as the status line and DCO_STATS give them.
  pipeline::runtime::RuntimeStats run_stats() const;
  std::string status_line(const pipeline::runtime::RuntimeStats& run) const;
  // Throws dco::Error, naming the source's frame size, when its frames cannot go through stages
  // with these params (pipeline::check_frame_size).
  void check_frame_size(const pipeline::PipelineParams& stages) const;
  void wake();

  ConfigSources sources_;  // plus the pipeline keys a replayed log recorded
  const SourceOpener open_source_;
  LoadedConfig loaded_;
  Logger& log_;
  ServiceNotifier notifier_;

  std::unique_ptr<drivers::FrameSource> source_;
  std::optional<Rectifier> rectifier_;      // only when frames need remapping
  std::unique_ptr<PairRemapper> remapper_;  // the GPU's, with the CUDA backend
  RectifiedGeometry geometry_;
  Image<std::uint8_t> rect_left_, rect_right_;
  std::unique_ptr<ipc::RingWriter> ring_;
  // The publisher: frames (runtime thread), stats and logs (others). Never held across a wait
  // for the network: the publisher's own thread sends.
  // Taken by the release thread (SCHED_FIFO with runtime.release_priority) and normal threads.
  PriorityInheritanceMutex publish_mutex_;
  std::unique_ptr<ipc::DepthPublisher> publisher_;
  std::unique_ptr<pipeline::runtime::DepthRuntime> runtime_;
  // OpenCV's thread count, set as the first stages start and kept through restarts: the source's
  // thread may be in an OpenCV loop (rendering, decoding) when they restart, and a changed count
  // crashes it.
  std::optional<pipeline::runtime::OpenCvThreadsPin> opencv_pin_;
  int opencv_threads_asked_ = 0;  // what the stages the pin was made for resolved it to
  std::string calibration_toml_;  // the source's, as DCO_RAW carries it
  // Held by on_frame while it hands a frame to the recorder and the stages, and by a reload
  // while it replaces them: the source runs on through a reload (a USB camera is not stopped and
  // negotiated afresh, and a replayed USB capture sees no calls it did not record); its thread
  // waits, as behind any slow consumer. Taken before raw_mutex_.
  std::mutex pipeline_mutex_;
  std::mutex raw_mutex_;  // the recorder: offered frames (source thread), reloads (main)
  std::unique_ptr<RawRecorder> raw_;
  std::string raw_settings_;  // what raw_ was made with
  std::uint64_t raw_dropped_reported_ = 0, raw_oversized_reported_ = 0, raw_failed_reported_ = 0;
  std::uint64_t raw_held_reported_ = 0;
  // The source's device as of the last statistics tick (a camera's rate may change on a replug).
  std::string source_device_;
  WarningPacer raw_dropped_pacer_, raw_failed_pacer_;
  std::unique_ptr<ReplayCheck> replay_check_;  // replaying a field log in deterministic mode
  std::uint64_t lcm_failures_reported_ = 0;
  WarningPacer lcm_failure_pacer_;
  std::int64_t lcm_retry_ns_ = 0;  // when LCM, not set up at the start, was last tried

  FrameNumbers frame_numbers_;
  // The source thread's (under pipeline_mutex_): a frame since the last start or cut, and
  // whether a gap in the camera's frames cuts the sequence (not in deterministic mode).
  bool pushed_in_sequence_ = false, cut_at_gaps_ = true;
  // Where a sequence was cut: counted on the source thread, reported on the main thread.
  struct SequenceCuts {
    std::atomic<std::uint64_t> count{0}, last_seq{0};
    std::uint64_t reported = 0;
    WarningPacer pacer;
  };
  SequenceCuts camera_gaps_, log_runs_;  // gaps in the camera's frames; a replayed log's runs

  std::atomic<std::int64_t> last_publish_ns_{0};
  std::atomic<std::int64_t> pipeline_start_ns_{0};
  StallClock stall_clock_;  // the main thread's
  std::atomic<long> published_{0};
  std::atomic<int> max_frames_{0};
  std::atomic<bool> source_ended_{false}, max_reached_{false}, failed_{false};
  std::mutex error_mutex_;
  std::string error_;

  int event_fd_ = -1;
  bool stalled_ = false;
  std::int64_t next_stats_ns_ = 0, last_ping_ns_ = 0;
  long last_pushed_ = 0, last_published_ = 0;
  struct EarlierCounts {
    long pushed = 0, dropped = 0, late = 0, published = 0;
  } earlier_;  // of the runtimes that reloads replaced
  // Results that went out before runtime.release_latency_ms (every release slot taken), as last
  // reported; the running runtime's count.
  long early_reported_ = 0;
  WarningPacer early_pacer_;
  std::int64_t last_rate_ns_ = 0;
  double fps_in_ = 0, fps_out_ = 0;
  // The stereo stage's correction of the right camera as last written to the log.
  std::string logged_correction_ = stereo::describe(stereo::CameraCorrection{});
};

}  // namespace dco::daemon
