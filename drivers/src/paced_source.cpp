#include "paced_source.hpp"

#include <exception>

#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"

namespace dco::drivers {
namespace {

std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

void PacedSource::start(FrameSink& sink) {
  if (thread_.joinable()) throw Error(info().uri + ": source already started");
  thread_ = std::jthread([this, &sink](std::stop_token stop) {
    name_this_thread("dco-source");
    run(stop, sink);
  });
}

void PacedSource::stop() {
  if (!thread_.joinable()) return;
  thread_.request_stop();
  thread_.join();
  thread_ = {};
}

void PacedSource::run(std::stop_token stop, FrameSink& sink) {
  using Clock = std::chrono::steady_clock;
  const double fps = info().fps;
  const auto period =
      fps > 0
          ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / fps))
          : Clock::duration::zero();
  auto due = Clock::now();
  StereoFrame frame;
  while (!stop.stop_requested()) {
    if (stall_after_ > 0 && next_seq_ >= stall_after_) {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, stop, [] { return false; });
      return;
    }
    if (period > Clock::duration::zero()) {
      std::unique_lock lock(mutex_);
      wake_.wait_until(lock, stop, due, [] { return false; });  // wakes early only on stop
      if (stop.stop_requested()) return;
      due += period;
      if (Clock::now() > due + period) due = Clock::now() + period;  // fell behind: no burst
    }
    try {
      if (!produce(next_seq_, frame.left, frame.right)) {
        sink.on_end();
        return;
      }
    } catch (const std::exception& e) {
      sink.on_error(e.what());
      return;
    }
    frame.seq = frame_number(next_seq_++);
    frame.capture_ns = monotonic_ns();
    frame.imu = frame_imu(frame.capture_ns);
    mark_sequence(frame);
    try {
      sink.on_frame(frame);
    } catch (const std::exception& e) {
      sink.on_error(e.what());
      return;
    }
  }
}

}  // namespace dco::drivers
