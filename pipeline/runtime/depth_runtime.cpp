#include "dco/pipeline/runtime/depth_runtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"
#include "dco/core/time_slice.hpp"
#include "dco/core/usable_cpus.hpp"

namespace dco::pipeline::runtime {
namespace {

// What a fixed release time counts from: the capture, or the entry when the camera's stamp lies
// after it (a stamp in the future would hold the result, and every one behind it, that long).
Clock::time_point release_base(const FrameTimes& t) {
  return std::min(t.capture, t.entry);
}

std::vector<int> checked_cpus(const RuntimeParams& params) {
  validate(params);
  return parse_affinity(params.affinity);
}

double ms_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

DurationSummary summary(const Histogram& h) {
  return {h.count(), h.percentile(50), h.percentile(99), h.mean_ms(), h.max_ms()};
}

// Takes the first free entry after the last one taken, so every entry is used (and its buffers
// sized) within the first frames, and none allocates later.
template <typename Flags>
int take_free(Flags& free, std::size_t& cursor) {
  for (std::size_t k = 1; k <= free.size(); ++k) {
    const std::size_t i = (cursor + k) % free.size();
    if (free[i]) {
      free[i] = false;
      cursor = i;
      return static_cast<int>(i);
    }
  }
  return -1;
}

std::string size_text(ImageView<const std::uint8_t> v) {
  return std::to_string(v.width) + "x" + std::to_string(v.height) + "x" +
         std::to_string(v.channels);
}

// Without real-time priority the release thread asks for a 0.1 ms time slice. With the stage
// threads keeping every CPU busy, a thread woken at a deadline otherwise waits for the running
// one's slice to end: on a 2-vCPU VM 4 ms at p99, 0.15 ms with it. It is not enough on its own:
// a thread that ran just before the CPU went idle wakes behind the stage threads (it was owed no
// time), and then waits for the next scheduler tick, up to 6 ms in all, where SCHED_FIFO took
// 0.2 ms. Kernels before 6.12 ignore the slice, which costs only precision.
constexpr std::uint64_t kReleaseSliceNs = 100'000;

RuntimeParams with_stage_threads(RuntimeParams params) {
  params.threads = stage_threads(params);
  params.opencv_threads = opencv_threads_for(params.opencv_threads, params.threads, usable_cpus());
  return params;
}

}  // namespace

double stereo_stage_ms(const FrameTimes& t) {
  return ms_between(t.stereo_start + t.stereo_blocked, t.stereo_end);
}

double contour_stage_ms(const FrameTimes& t) {
  return ms_between(t.contour_start, t.contour_end) +
         std::chrono::duration<double, std::milli>(t.contour_early).count();
}

DepthRuntime::DepthRuntime(const PipelineParams& pipeline, const RuntimeParams& runtime,
                           ResultCallback on_result, StageHook hook, const StageFactories& stages)
    : pipeline_(pipeline),
      params_(with_stage_threads(runtime)),
      cpus_(checked_cpus(runtime)),
      releasing_(runtime.release_latency_ms > 0 && !runtime.deterministic),
      release_latency_(std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double, std::milli>(runtime.release_latency_ms))),
      on_result_(std::move(on_result)),
      hook_(std::move(hook)),
      stereo_(stereo::make_stereo_matcher(stages.stereo, pipeline.stereo)),
      contour_(contour::make_contour_extractor(stages.contour, pipeline.contour)),
      densifier_(pipeline.densify, stages.densify_solver, stages.photometric_refinement),
      early_contour_moves_(params_.threads == 2 && !stages.on_gpu),
      // In flight at once: the contour window (3 frames), a full stereo queue and the frame in
      // the stereo stage.
      slots_(static_cast<std::size_t>(runtime.queue_depth) + 4),
      slot_free_(slots_.size(), true),
      stereo_queue_(static_cast<std::size_t>(runtime.queue_depth)),
      // One in the contour stage, a full densify queue, one in the densify stage, and with a
      // release latency a full release queue and the one being handed on.
      results_(static_cast<std::size_t>(runtime.queue_depth) + 2 +
               (releasing_ ? kReleaseSlots + 1 : 0)),
      result_free_(results_.size(), true),
      densify_queue_(static_cast<std::size_t>(runtime.queue_depth)),
      release_queue_(kReleaseSlots + 1) {  // the results and the end of their sequence
  validate(pipeline_);
  reset_state();
}

DepthRuntime::~DepthRuntime() {
  stop();
}

void DepthRuntime::reset_state() {
  hold_ups_.clear();
  input_free_.fill(true);
  waiting_input_ = -1;
  end_requested_ = false;
  next_index_ = 0;
  width_ = height_ = channels_ = 0;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    slot_free_[i] = true;
    slots_[i].stereo_done = false;
  }
  stereo_queue_.clear();
  received_ = 0;
  next_contour_ = NextContour::kNone;
  contour_waiting_ = false;
  for (std::size_t i = 0; i < results_.size(); ++i) result_free_[i] = true;
  densify_queue_.clear();
  release_queue_.clear();
  held_for_release_ = 0;
  release_wanted_ = false;
  release_thread_ready_ = false;
  stereo_->reset();
  densifier_.reset();
  failure_ = nullptr;
}

void DepthRuntime::start() {
  if (running()) throw Error("runtime: start while already running");
  {
    std::lock_guard lock(mutex_);
    reset_state();
    latency_.clear();
    ready_.clear();
    stereo_ms_.clear();
    contour_ms_.clear();
    densify_ms_.clear();
    pushed_ = dropped_ = late_ = published_ = overdue_ = early_ = 0;
    camera_correction_ = {};
    stereo_work_ms_ = other_work_ms_ = planes_work_ms_ = early_contour_work_ms_ = 0;
    work_samples_ = planes_on_stereo_ = early_contour_on_stereo_ = next_contour_on_stereo_ = 0;
    sequence_recorded_ = false;
    entry_high_water_ = 0;
    // Fresh queues: their high-water marks are statistics too.
    stereo_queue_ = BoundedQueue<int>(stereo_queue_.capacity());
    densify_queue_ = BoundedQueue<int>(densify_queue_.capacity());
  }
  if (params_.opencv_threads > 0) opencv_threads_.emplace(params_.opencv_threads);
  threads_.reserve(4);
  try {
    threads_.emplace_back([this](std::stop_token stop) { stereo_loop(stop); });
    if (params_.threads >= 2)
      threads_.emplace_back([this](std::stop_token stop) { contour_loop(stop); });
    if (params_.threads >= 3)
      threads_.emplace_back([this](std::stop_token stop) { densify_loop(stop); });
    if (releasing_) threads_.emplace_back([this](std::stop_token stop) { release_loop(stop); });
  } catch (...) {
    stop();  // a thread the system refused (EAGAIN): nothing is left running
    throw;
  }
  name_threads();
  if (releasing_) {  // so stats() tells from the start whether it runs at real-time priority
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return release_thread_ready_; });
  }
  if (cpus_.empty()) return;
  for (std::size_t i = 0; i < threads_.size(); ++i) {
    const int cpu = cpus_[i % cpus_.size()];
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    const int err = pthread_setaffinity_np(threads_[i].native_handle(), sizeof(set), &set);
    if (err != 0) {
      stop();
      throw Error("runtime.affinity: cannot run a stage thread on CPU " + std::to_string(cpu) +
                  ": " + std::strerror(err));
    }
  }
}

void DepthRuntime::name_threads() {
  // From here rather than by each thread, so the names are there when start returns.
  std::size_t i = 0;
  name_thread(threads_[i++].native_handle(), "dco-stereo");
  if (params_.threads >= 2) name_thread(threads_[i++].native_handle(), "dco-contour");
  if (params_.threads >= 3) name_thread(threads_[i++].native_handle(), "dco-densify");
  if (releasing_) name_thread(threads_[i++].native_handle(), "dco-release");
}

void DepthRuntime::stop() {
  for (std::jthread& t : threads_) t.request_stop();
  threads_.clear();  // joins
  opencv_threads_.reset();
  std::lock_guard lock(mutex_);
  reset_state();
}

void DepthRuntime::rethrow_failure() {
  if (failure_) std::rethrow_exception(failure_);
}

void DepthRuntime::fail(std::exception_ptr error) {
  std::lock_guard lock(mutex_);
  if (!failure_) failure_ = std::move(error);
  changed_.notify_all();
}

void DepthRuntime::push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                        Clock::time_point capture) {
  if (left.empty() || right.empty()) throw Error("runtime: empty input image");
  if (!left.same_size(right) || left.channels != right.channels)
    throw Error("runtime: left image is " + size_text(left) + " but right image is " +
                size_text(right) + "; a rectified pair has one size");
  if (left.channels != 1 && left.channels != 3)
    throw Error("runtime: images need 1 or 3 channels, not " + std::to_string(left.channels));
  int input = -1;
  {
    std::unique_lock lock(mutex_);
    rethrow_failure();
    if (!running()) throw Error("runtime: push before start");
    if (next_index_ > 0 &&
        (left.width != width_ || left.height != height_ || left.channels != channels_))
      throw Error("runtime: frame " + std::to_string(next_index_) + " is " + size_text(left) +
                  " but the sequence started at " + std::to_string(width_) + "x" +
                  std::to_string(height_) + "x" + std::to_string(channels_) +
                  "; drain() before a new sequence");
    if (params_.deterministic) changed_.wait(lock, [&] { return failure_ || waiting_input_ < 0; });
    rethrow_failure();
    // At most one input is in the stereo stage and one waits, so one of three is always free.
    input = take_free(input_free_, input_cursor_);
    width_ = left.width;
    height_ = left.height;
    channels_ = left.channels;
    ++pushed_;
  }
  Input& in = inputs_[static_cast<std::size_t>(input)];
  in.left.resize(left.width, left.height, left.channels);
  in.right.resize(right.width, right.height, right.channels);
  in.left.copy_from(left);
  in.right.copy_from(right);
  in.capture = capture;
  in.entry = Clock::now();
  std::lock_guard lock(mutex_);
  if (next_index_ == 0) frame_interval_.clear();
  frame_interval_.add(capture);
  in.index = next_index_++;
  if (waiting_input_ >= 0) {  // newest wins
    input_free_[static_cast<std::size_t>(waiting_input_)] = true;
    ++dropped_;
  }
  waiting_input_ = input;
  entry_high_water_ = 1;
  changed_.notify_all();
}

void DepthRuntime::drain() {
  std::unique_lock lock(mutex_);
  rethrow_failure();
  if (!running()) throw Error("runtime: drain before start");
  const long target = drained_ + 1;
  end_requested_ = true;
  changed_.notify_all();
  changed_.wait(lock, [&] { return failure_ || drained_ >= target; });
  rethrow_failure();
  next_index_ = 0;
}

bool DepthRuntime::hand_on(std::stop_token stop, BoundedQueue<int>& queue, int item) {
  std::unique_lock lock(mutex_);
  if (!changed_.wait(lock, stop, [&] { return !queue.full(); })) return false;
  queue.push(item);
  changed_.notify_all();
  return true;
}

int DepthRuntime::acquire_slot(std::stop_token stop, bool neighbour_only) {
  std::unique_lock lock(mutex_);
  int slot = -1;
  if (!stereo_wait(lock, stop, [&] { return (slot = take_free(slot_free_, slot_cursor_)) >= 0; }))
    return -1;
  slots_[static_cast<std::size_t>(slot)].stereo_done = false;
  slots_[static_cast<std::size_t>(slot)].neighbour_only = neighbour_only;
  return slot;
}

void DepthRuntime::release_slot(int slot, int fallback_model) {
  std::lock_guard lock(mutex_);
  const auto filled = [&](int s) {
    return s >= 0 && slots_[static_cast<std::size_t>(s)].stereo_done;
  };
  const int model = filled(slot) ? slot : filled(fallback_model) ? fallback_model : -1;
  slot_free_[static_cast<std::size_t>(slot)] = true;
  if (model >= 0) {
    const StereoSlot& m = slots_[static_cast<std::size_t>(model)].slot;
    try {
      for (std::size_t i = 0; i < slots_.size(); ++i)
        if (slot_free_[i] && static_cast<int>(i) != model) size_like(m, slots_[i].slot);
    } catch (...) {
      // Out of memory at a new size: a failure push() reports, not a terminated process.
      if (!failure_) failure_ = std::current_exception();
    }
  }
  changed_.notify_all();
}

bool DepthRuntime::is_late(const Input& input) const {
  // Nothing newer comes after the end of a sequence, and a deterministic run drops nothing.
  if (params_.deterministic || end_requested_) return false;
  const Clock::time_point now = Clock::now();
  return late_at_entry(ms_between(input.entry, now), hold_ups_.ms_within(input.entry, now),
                       params_.entry_deadline_ms, params_.entry_deadline_share,
                       frame_interval_.ms());
}

void DepthRuntime::stereo_loop(std::stop_token stop) {
  while (true) {
    int input = -1;
    bool late = false;
    bool planes_here = true;
    bool early_contour_here = false;
    {
      std::unique_lock lock(mutex_);
      // Not stereo_wait: a frame arriving meanwhile would wait for the next contour step's share.
      if (!changed_.wait(lock, stop, [&] { return waiting_input_ >= 0 || end_requested_; })) return;
      if (waiting_input_ >= 0) {
        input = std::exchange(waiting_input_, -1);
        late = is_late(inputs_[static_cast<std::size_t>(input)]);
        planes_here = planes_on_stereo_thread();
        planes_on_stereo_ += planes_here && !late;
        early_contour_here = early_contour_on_stereo_thread(planes_here);
        early_contour_on_stereo_ += early_contour_here && !late;
        dropped_ += late;
        late_ += late;
        changed_.notify_all();  // room at the entry
      } else {
        end_requested_ = false;
      }
    }
    if (input < 0) {     // the end of the sequence follows the frames before it
      stereo_->reset();  // the next frame starts another sequence
      if (params_.threads == 1) {
        contour_end(stop);
        continue;
      }
      if (!stereo_hand_on(stop, kEnd)) return;
      continue;
    }
    const int slot = acquire_slot(stop, late);
    if (slot < 0) return;
    const Input& in = inputs_[static_cast<std::size_t>(input)];
    SlotEntry& entry = slots_[static_cast<std::size_t>(slot)];
    entry.times = {};
    entry.times.capture = in.capture;
    entry.times.entry = in.entry;
    try {
      if (hook_ && !late) hook_(Stage::kStereo, in.index);
      entry.times.stereo_start = Clock::now();
      prepare_frame(pipeline_.stereo, in.left.cview(), in.index, entry.slot);
      if (params_.threads > 1) {
        // Hand the frame on before its stereo: the previous frame's contours need only its
        // grey image, and run meanwhile.
        const Clock::time_point waiting = Clock::now();
        if (!stereo_hand_on(stop, slot)) return;
        entry.times.stereo_blocked = Clock::now() - waiting;
      }
      if (!late) {
        stereo_frame(*stereo_, in.left.cview(), in.right.cview(), entry.slot,
                     densifier_.refines(in.left.width(), in.left.height()));
        plane_frame(pipeline_.densify, planes_, entry.slot, planes_here);
        early_contour_frame(pipeline_.contour, early_contour_, entry.slot, early_contour_here);
      }
    } catch (...) {
      fail(std::current_exception());
      return;
    }
    bool prepare_contour = false;
    {
      std::lock_guard lock(mutex_);
      entry.times.stereo_end = Clock::now();
      entry.stereo_done = !late;
      input_free_[static_cast<std::size_t>(input)] = true;
      prepare_contour = claim_next_contour();
      changed_.notify_all();
    }
    if (prepare_contour) prepare_next_contour();
    if (params_.threads == 1) contour_receive(stop, slot);
  }
}

void DepthRuntime::contour_loop(std::stop_token stop) {
  while (!stop.stop_requested()) {
    int item = kEnd;
    {
      std::unique_lock lock(mutex_);
      contour_waiting_ = true;
      const bool woken = changed_.wait(lock, stop, [&] { return !stereo_queue_.empty(); });
      contour_waiting_ = false;
      if (!woken) return;
      item = stereo_queue_.pop();
      changed_.notify_all();
    }
    if (item == kEnd)
      contour_end(stop);
    else
      contour_receive(stop, item);
  }
}

int DepthRuntime::window_slot(FrameIndex frame) const {
  return frame >= 0 ? window_[static_cast<std::size_t>(frame) % window_.size()] : -1;
}

bool DepthRuntime::has_depth(FrameIndex frame) const {
  return frame >= 0 && !slots_[static_cast<std::size_t>(window_slot(frame))].neighbour_only;
}

void DepthRuntime::contour_receive(std::stop_token stop, int slot) {
  // Frames are numbered in the order they passed the entry, as DepthPipeline numbers its pushes.
  const FrameIndex t = received_++;
  window_[static_cast<std::size_t>(t) % window_.size()] = slot;
  const ContourWindow w = window_on_arrival(pipeline_.contour.lookahead, t);
  if (has_depth(w.centre)) {
    // The causal window's flow cue needs only the grey images, which came before the centre's
    // stereo: made here, the contour step after the stereo is left the short part.
    if (pipeline_.contour.lookahead == 0 && pipeline_.contour.use_flow && w.neighbour_b >= 0 &&
        params_.threads > 1) {
      const auto entry_of = [this](FrameIndex frame) -> SlotEntry& {
        return slots_[static_cast<std::size_t>(window_slot(frame))];
      };
      SlotEntry& centre = entry_of(w.centre);
      try {
        if (hook_) hook_(Stage::kFlowCue, centre.slot.index);
        const Clock::time_point start = Clock::now();
        flow_cue_frame(*contour_, centre.slot, entry_of(w.neighbour_a).slot,
                       entry_of(w.neighbour_b).slot);
        centre.times.contour_early = Clock::now() - start;
      } catch (...) {
        fail(std::current_exception());
        return;
      }
    }
    run_contour(stop, window_slot(w.centre), window_slot(w.neighbour_a), window_slot(w.neighbour_b),
                /*last=*/false);
  }
  // In no later window, either lookahead.
  if (t >= 2) release_slot(window_slot(t - 2), window_slot(w.centre));
}

void DepthRuntime::contour_end(std::stop_token stop) {
  if (pipeline_.contour.lookahead == 1 && received_ > 0) {
    const ContourWindow w = window_at_end(received_ - 1);
    if (has_depth(w.centre))
      run_contour(stop, window_slot(w.centre), window_slot(w.neighbour_a),
                  window_slot(w.neighbour_b), /*last=*/true);
  }
  for (FrameIndex t = std::max<FrameIndex>(received_ - 2, 0); t < received_; ++t)
    release_slot(window_slot(t), window_slot(received_ - 1));
  received_ = 0;
  if (params_.threads < 3) {
    densify_end(stop);
    return;
  }
  hand_on(stop, densify_queue_, kEnd);
}

void DepthRuntime::run_contour(std::stop_token stop, int centre, int neighbour_a, int neighbour_b,
                               bool last) {
  SlotEntry& c = slots_[static_cast<std::size_t>(centre)];
  int result = -1;
  {
    std::unique_lock lock(mutex_);
    // The stereo thread's share of this step, when it took it, must be done first.
    const auto ready = [&] {
      return c.stereo_done && next_contour_ != NextContour::kPreparing &&
             (result = take_free(result_free_, result_cursor_)) >= 0;
    };
    contour_waiting_ = true;
    const bool woken = changed_.wait(lock, stop, ready);
    contour_waiting_ = false;
    if (!woken) return;
    next_contour_ = NextContour::kNone;  // what was not taken this step makes itself
  }
  ResultEntry& r = results_[static_cast<std::size_t>(result)];
  const auto neighbour = [&](int slot) {
    return slot >= 0 ? &slots_[static_cast<std::size_t>(slot)].slot : nullptr;
  };
  try {
    if (hook_) hook_(Stage::kContour, c.slot.index);
    r.times = c.times;
    r.times.contour_start = Clock::now();
    contour_frame_moving_maps(*contour_, c.slot, neighbour(neighbour_a), neighbour(neighbour_b),
                              r.result);
    r.times.contour_end = Clock::now();
  } catch (...) {
    fail(std::current_exception());
    return;
  }
  // The sequence's last step has no next one, and the causal window's has none to prepare (its
  // flow cue is made by this thread, which must not meet prepare_next).
  if (early_contour_moves_ && !last && pipeline_.contour.lookahead == 1) {
    {
      std::lock_guard lock(mutex_);
      next_contour_ = NextContour::kReady;
    }
    // The stereo thread may be asleep in a wait that takes this step's share.
    changed_.notify_all();
  }
  if (params_.threads < 3) {
    densify_receive(stop, result);
    return;
  }
  hand_on(stop, densify_queue_, result);
}

bool DepthRuntime::stereo_hand_on(std::stop_token stop, int item) {
  std::unique_lock lock(mutex_);
  if (!stereo_wait(lock, stop, [&] { return !stereo_queue_.full(); })) return false;
  stereo_queue_.push(item);
  changed_.notify_all();
  return true;
}

bool DepthRuntime::claim_next_contour() {
  // The contour + densify thread is busy with an earlier frame: the next contour step's work
  // that the last one's results allow is the stereo thread's. Not while that thread waits, which
  // would then wait for it.
  if (next_contour_ != NextContour::kReady || contour_waiting_) return false;
  next_contour_ = NextContour::kPreparing;
  return true;
}

void DepthRuntime::prepare_next_contour() {
  bool done = false;
  try {
    done = contour_->prepare_next();
  } catch (...) {
    fail(std::current_exception());
  }
  std::lock_guard lock(mutex_);
  next_contour_ = NextContour::kNone;
  next_contour_on_stereo_ += done;
  changed_.notify_all();
}

void DepthRuntime::densify_loop(std::stop_token stop) {
  while (!stop.stop_requested()) {
    int item = kEnd;
    {
      std::unique_lock lock(mutex_);
      if (!changed_.wait(lock, stop, [&] { return !densify_queue_.empty(); })) return;
      item = densify_queue_.pop();
      changed_.notify_all();
    }
    if (item == kEnd)
      densify_end(stop);
    else
      densify_receive(stop, item);
  }
}

void DepthRuntime::densify_receive(std::stop_token stop, int result) {
  ResultEntry& r = results_[static_cast<std::size_t>(result)];
  try {
    if (hook_) hook_(Stage::kDensify, r.result.index);
    r.times.densify_start = Clock::now();
    densify_frame(densifier_, r.result);
    r.times.densify_end = Clock::now();
  } catch (...) {
    fail(std::current_exception());
    return;
  }
  if (!releasing_) {
    deliver(result, false);
    return;
  }
  std::unique_lock lock(mutex_);
  release_wanted_ = true;
  // With every release slot taken, the oldest result goes now. The release thread is woken only
  // when what it waits for changed: each needless run preempts a stage thread.
  if (held_for_release_ == kReleaseSlots) release_changed_.notify_all();
  if (!changed_.wait(lock, stop, [&] { return held_for_release_ < kReleaseSlots; })) return;
  release_wanted_ = false;
  const bool was_empty = release_queue_.empty();
  release_queue_.push(result);
  ++held_for_release_;
  if (was_empty) release_changed_.notify_all();
}

void DepthRuntime::densify_end(std::stop_token stop) {
  densifier_.reset();
  if (!releasing_) {
    end_sequence();
    return;
  }
  // The end takes no release slot (the queue has one more place), so it sends no result early.
  if (hand_on(stop, release_queue_, kEnd)) release_changed_.notify_all();
}

void DepthRuntime::release_loop(std::stop_token stop) {
  const bool realtime =
      params_.release_priority > 0 && request_fifo_priority(params_.release_priority);
  if (!realtime) request_time_slice(kReleaseSliceNs);
  {
    std::lock_guard lock(mutex_);
    release_thread_ready_ = true;
    release_realtime_ = realtime;
  }
  changed_.notify_all();
  while (true) {
    int item = kEnd;
    bool early = false;
    {
      std::unique_lock lock(mutex_);
      if (!release_changed_.wait(lock, stop, [&] { return !release_queue_.empty(); })) return;
      item = release_queue_.front();
      if (item != kEnd) {
        const Clock::time_point due =
            release_base(results_[static_cast<std::size_t>(item)].times) + release_latency_;
        release_changed_.wait_until(
            lock, stop, due, [&] { return release_wanted_ && held_for_release_ == kReleaseSlots; });
        if (stop.stop_requested()) return;
        early = Clock::now() < due;
        --held_for_release_;
      }
      release_queue_.pop();
      changed_.notify_all();
    }
    if (item == kEnd)
      end_sequence();
    else
      deliver(item, early);
  }
}

void DepthRuntime::deliver(int result, bool early) {
  ResultEntry& r = results_[static_cast<std::size_t>(result)];
  try {
    r.times.release = Clock::now();
    if (on_result_) on_result_(r.result, r.times);
  } catch (...) {
    fail(std::current_exception());
    return;
  }
  std::lock_guard lock(mutex_);
  const FrameTimes& t = r.times;
  latency_.record(ms_between(t.capture, t.release));
  ready_.record(ms_between(t.capture, t.densify_end));
  const double stereo_ms = stereo_stage_ms(t);
  const double contour_ms = contour_stage_ms(t);
  const double densify_ms = ms_between(t.densify_start, t.densify_end);
  stereo_ms_.record(stereo_ms);
  contour_ms_.record(contour_ms);
  densify_ms_.record(densify_ms);
  // What decides which thread runs the match planes and the early contour work
  // (planes_on_stereo_thread, early_contour_on_stereo_thread).
  const double planes_ms = r.result.densify_timings.planes_ms;
  const double early_ms =
      r.result.contour_timings.gaussian_ms + r.result.contour_timings.stereo_cue_ms;
  const double planes_stereo = r.result.planes_done ? planes_ms : 0.0;
  const double early_stereo = r.result.early_contour_done ? early_ms : 0.0;
  const double stereo_own = stereo_ms - planes_stereo - early_stereo;
  const double other_own =
      params_.threads >= 3
          ? densify_ms - (planes_ms - planes_stereo)
          : contour_ms + densify_ms - (planes_ms - planes_stereo) - (early_ms - early_stereo);
  // A sequence's first frame is no sample of the work per frame: the stages search the whole
  // disparity range and the camera alignment, and the solver starts cold (on the 160x96 hand its
  // stereo step's own work is about ten times the next frames', its solve twice).
  if (sequence_recorded_) {
    constexpr double kWeight = 0.125;  // about the last eight frames
    const double weight = work_samples_ == 0 ? 1.0 : kWeight;
    stereo_work_ms_ += weight * (stereo_own - stereo_work_ms_);
    other_work_ms_ += weight * (other_own - other_work_ms_);
    planes_work_ms_ += weight * (planes_ms - planes_work_ms_);
    early_contour_work_ms_ += weight * (early_ms - early_contour_work_ms_);
    ++work_samples_;
  }
  sequence_recorded_ = true;
  ++published_;
  camera_correction_ = r.result.camera_correction;
  if (releasing_ && t.densify_end - release_base(t) > release_latency_) ++overdue_;
  early_ += early;
  // Every free result gets this one's room, so none allocates when it is first taken, however
  // late in the sequence that is (frames dropped at the entry leave entries unused).
  try {
    for (std::size_t i = 0; i < results_.size(); ++i)
      if (result_free_[i]) size_like(r.result, results_[i].result);
  } catch (...) {
    if (!failure_) failure_ = std::current_exception();  // as in release_slot
  }
  result_free_[static_cast<std::size_t>(result)] = true;
  changed_.notify_all();
}

void DepthRuntime::end_sequence() {
  std::lock_guard lock(mutex_);
  ++drained_;
  sequence_recorded_ = false;
  changed_.notify_all();
}

bool DepthRuntime::planes_on_stereo_thread() const {
  // One thread runs everything; before the first result either choice is as good.
  if (params_.threads < 2 || work_samples_ == 0) return true;
  // The stereo thread takes them unless its own work already exceeds the other thread's with
  // them. Between those bounds either thread ends up the longer by less than the planes' time,
  // and the stereo thread is the better one: it runs up to a queue's length ahead, so its extra
  // time waits in the queue's slack, while the other thread's delays every result (measured on
  // the 1280x720 hand: 31.3 ms per frame with the planes always on the stereo thread, 32.2
  // choosing by the smaller of the two thread times, 32.7 always in the densify step).
  return stereo_work_ms_ <= other_work_ms_ + planes_work_ms_;
}

bool DepthRuntime::early_contour_on_stereo_thread(bool planes_here) const {
  if (!early_contour_moves_) return false;
  if (work_samples_ == 0) return true;  // as the planes
  // The planes' rule again, with the planes where they go: the stereo thread takes the work
  // unless its own already exceeds the other thread's with it.
  const double stereo = stereo_work_ms_ + (planes_here ? planes_work_ms_ : 0.0);
  const double other = other_work_ms_ + (planes_here ? 0.0 : planes_work_ms_);
  return stereo <= other + early_contour_work_ms_;
}

RuntimeStats DepthRuntime::stats() const {
  std::lock_guard lock(mutex_);
  RuntimeStats s;
  s.latency = summary(latency_);
  s.ready = summary(ready_);
  s.stereo = summary(stereo_ms_);
  s.contour = summary(contour_ms_);
  s.densify = summary(densify_ms_);
  s.pushed = pushed_;
  s.dropped = dropped_;
  s.late = late_;
  s.published = published_;
  s.overdue = overdue_;
  s.early = early_;
  s.release_realtime = release_realtime_;
  s.entry_high_water = entry_high_water_;
  s.stereo_queue_high_water = stereo_queue_.high_water();
  s.densify_queue_high_water = densify_queue_.high_water();
  s.planes_on_stereo_thread = planes_on_stereo_;
  s.early_contour_on_stereo_thread = early_contour_on_stereo_;
  s.next_contour_on_stereo_thread = next_contour_on_stereo_;
  s.camera_correction = camera_correction_;
  return s;
}

}  // namespace dco::pipeline::runtime
