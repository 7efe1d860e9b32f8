#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <thread>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/core/priority_inheritance_condition.hpp"
#include "dco/core/priority_inheritance_mutex.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/runtime/bounded_queue.hpp"
#include "dco/pipeline/runtime/entry_deadline.hpp"
#include "dco/pipeline/runtime/histogram.hpp"
#include "dco/pipeline/runtime/opencv_threads.hpp"
#include "dco/pipeline/runtime/runtime_params.hpp"

namespace dco::pipeline::runtime {

using Clock = std::chrono::steady_clock;

// kFlowCue: the contour stage's flow cue of the causal window (contour.lookahead 0), which the
// contour thread makes while the frame's stereo runs.
enum class Stage { kStereo, kFlowCue, kContour, kDensify };

// When one frame passed each point of the runtime.
struct FrameTimes {
  Clock::time_point capture;  // given by the producer (the camera's timestamp)
  Clock::time_point entry;    // push accepted it
  Clock::time_point stereo_start, stereo_end;
  // Of stereo_start..stereo_end, the wait for room in the queue to the contour thread: the stereo
  // stage's time (RuntimeStats::stereo) leaves it out, it is the contour thread's slowness.
  Clock::duration stereo_blocked{};
  Clock::time_point contour_start, contour_end;
  // Before contour_start, while the frame's stereo ran: the contour thread's work on the frame's
  // flow cue (contour.lookahead 0). Part of the contour stage's time (RuntimeStats::contour).
  Clock::duration contour_early{};
  Clock::time_point densify_start, densify_end;
  Clock::time_point release;  // handed to the result callback
};

// The stages' own times of a frame, in ms, as RuntimeStats records them: the stereo stage without
// its wait to hand the frame on, the contour stage with the flow cue it made ahead.
double stereo_stage_ms(const FrameTimes& t);
double contour_stage_ms(const FrameTimes& t);

struct DurationSummary {
  long count = 0;
  double p50_ms = 0, p99_ms = 0, mean_ms = 0, max_ms = 0;
};

struct RuntimeStats {
  DurationSummary latency;  // capture to publication
  // Capture to the end of densify: the latency unless runtime.release_latency_ms holds results.
  DurationSummary ready;
  DurationSummary stereo, contour, densify;  // each stage's own work, waits left out
  long pushed = 0;                           // frames given to push
  // Frames with no depth of their own: replaced at the entry by a newer frame before the stereo
  // stage took them, or late.
  long dropped = 0;
  // Of those, taken after waiting longer than runtime.entry_deadline_ms: their images still
  // served as their neighbours' flow frames.
  long late = 0;
  long published = 0;  // results handed to the callback
  // With runtime.release_latency_ms: results ready after their release time (handed on at once),
  // and results handed on before it because every release slot was taken.
  long overdue = 0, early = 0;
  // With runtime.release_latency_ms: whether the release thread got the real-time priority of
  // runtime.release_priority (false: a normal thread, whose release times can slip by a
  // scheduler tick while the stage threads keep the CPUs busy).
  bool release_realtime = false;
  // The most frames each queue ever held: the entry (a single waiting frame), stereo -> contour
  // and contour -> densify. None can exceed its capacity, so latency cannot grow.
  std::size_t entry_high_water = 0, stereo_queue_high_water = 0, densify_queue_high_water = 0;
  // Frames whose match planes (the densify stage's first step, plane_frame) the stereo thread
  // ran: while its own work was not longer than the other thread's with the planes. The others'
  // ran in the densify step.
  long planes_on_stereo_thread = 0;
  // Frames whose early contour work (the contour step's work on the frame alone: the intensity
  // gradients and the stereo cue, early_contour_frame) the stereo thread did, by the same rule
  // after the planes' share; the others' was the contour step's. With two stage threads and a
  // CPU contour stage only.
  long early_contour_on_stereo_thread = 0;
  // Times the stereo thread did the work that a contour step's results allow for the next one
  // (ContourExtractor::prepare_next): it takes that work when it ends a frame or waits for a slot
  // or room in the queue while the contour + densify thread is busy, else the next contour step
  // does it. With two stage threads
  // and a CPU contour stage only.
  long next_contour_on_stereo_thread = 0;
  // The stereo stage's correction of the right camera as of the last result handed on
  // (stereo.exposure_balance, stereo.vertical_alignment): identity before the first.
  stereo::CameraCorrection camera_correction;
};

// The depth pipeline in real time: the stereo, contour and densify steps of DepthPipeline on their
// own threads, joined by bounded queues, with every buffer allocated up front. With
// contour.lookahead = 1 frame t's contours need only the internal grey image of t+1, which the
// stereo thread hands on before it starts t+1's stereo, so t's contours and densification run
// while t+1's stereo does.
//
// When the input outruns the pipeline, a frame still waiting at the entry is replaced by the
// newer one and counted as dropped (newest wins). A frame that waited there longer than its
// deadline (runtime.entry_deadline_ms, or runtime.entry_deadline_share of the camera's frame
// interval when that is longer and the frame did not wait for the later stages) is late: the stereo
// thread only prepares its grey image, the flow neighbour of the frames around it, and takes the
// next frame as it arrives. So every depth map starts within the deadline of its entry, and its
// contour window still holds the camera frames next to it. Nothing else ever waits in a queue
// longer than its capacity, so the latency stays fixed. With runtime.release_latency_ms a release
// thread hands each result on at its capture time plus that latency, so its age no longer depends
// on how long the stages took. With runtime.deterministic, push waits instead and the results are
// bit for bit those of DepthPipeline on the same frames.
class DepthRuntime {
 public:
  // Called for every result, in order, on the last stage's thread (on the release thread with
  // runtime.release_latency_ms); it should return quickly, the next frame waits for it. The
  // references are valid during the call only.
  using ResultCallback = std::function<void(const DepthResult&, const FrameTimes&)>;
  // Called on a stage's thread right before that stage runs on a frame (tests slow stages down).
  using StageHook = std::function<void(Stage, FrameIndex index)>;

  // Results waiting for their release time (runtime.release_latency_ms). When all are taken, the
  // oldest goes early (RuntimeStats::early) rather than the densify stage waiting for it: a
  // latency longer than this many frame intervals is not held. Each is a whole result (several
  // full-size maps), so they are few.
  static constexpr std::size_t kReleaseSlots = 4;

  // Throws dco::Error on invalid params.
  // `stages` makes the stereo and contour stages and the densify solver (empty: the CPU ones).
  DepthRuntime(const PipelineParams& pipeline, const RuntimeParams& runtime,
               ResultCallback on_result, StageHook hook = {}, const StageFactories& stages = {});
  DepthRuntime(const DepthRuntime&) = delete;
  DepthRuntime& operator=(const DepthRuntime&) = delete;
  ~DepthRuntime();  // stops

  // Starts the stage threads and a new sequence with fresh statistics. Throws dco::Error when a
  // thread cannot be pinned to runtime.affinity (it then leaves nothing running).
  void start();
  // Joins the stage threads; frames in flight are discarded. A stopped runtime can start again.
  // start, stop, push and drain belong to one controlling thread (never the result callback).
  void stop();
  bool running() const { return !threads_.empty(); }

  // Hands in a rectified pair; it is copied, so the caller's buffers are free again on return.
  // Frames of one sequence have one size. Throws dco::Error on bad input or when a stage failed
  // (with that stage's message).
  void push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
            Clock::time_point capture = Clock::now());
  // Ends the sequence: waits until every accepted frame is published (with lookahead 1 the last
  // one without a successor), then forgets it, so the next push starts a new sequence.
  void drain();

  RuntimeStats stats() const;  // from any thread
  const PipelineParams& pipeline_params() const { return pipeline_; }
  // As it runs: runtime.threads = 0 resolved by stage_threads, runtime.opencv_threads by
  // opencv_threads_for (0: OpenCV's own choice).
  const RuntimeParams& runtime_params() const { return params_; }
  // Whether results wait for their capture time + runtime.release_latency_ms (never in a
  // deterministic run).
  bool holds_results_for_release() const { return releasing_; }

 private:
  struct Input {
    Image<std::uint8_t> left, right;
    Clock::time_point capture, entry;
    FrameIndex index = -1;
  };
  struct SlotEntry {
    StereoSlot slot;
    FrameTimes times;
    bool stereo_done = false;
    bool neighbour_only = false;  // a late frame: its grey images, no stereo, no depth
  };
  struct ResultEntry {
    DepthResult result;
    FrameTimes times;
  };
  static constexpr int kEnd = -1;            // queue item: the sequence ends here
  static constexpr std::size_t kInputs = 3;  // being filled, waiting, in the stereo stage
  void stereo_loop(std::stop_token stop);
  // True when the stereo stage should take `input`, which it has just taken from the entry, as
  // a flow neighbour only.
  bool is_late(const Input& input) const;
  void contour_loop(std::stop_token stop);
  void densify_loop(std::stop_token stop);
  // The steps after the stereo stage's hand-over, on whichever thread runs them.
  void contour_receive(std::stop_token stop, int slot);
  void contour_end(std::stop_token stop);
  int window_slot(FrameIndex frame) const;  // -1 for a frame before the first
  bool has_depth(FrameIndex frame) const;   // a received frame of the window that is not late
  // `last`: the sequence's last contour step.
  void run_contour(std::stop_token stop, int centre, int neighbour_a, int neighbour_b, bool last);
  // The stereo thread's share of the next contour step (ContourExtractor::prepare_next):
  // claim_next_contour (under mutex_) takes it when it is there to take, prepare_next_contour
  // (without) does it.
  bool claim_next_contour();
  void prepare_next_contour();
  // The stereo thread's waits for the stages after it (a slot, room in the stereo queue): until
  // `ready`,
  // doing the next contour step's share meanwhile when it can take it. False when stopped first.
  // `ready` is called once per wake-up and may take what it waits for.
  template <class Ready>
  bool stereo_wait(std::unique_lock<PriorityInheritanceMutex>& lock, std::stop_token stop,
                   Ready&& ready) {
    if (ready()) return true;
    // Held up by the later stages: the entry deadline's share does not cover this wait.
    hold_ups_.begin(Clock::now());
    const auto until_now = [this](bool result) {
      hold_ups_.end(Clock::now());
      return result;
    };
    while (true) {
      bool is_ready = false;
      const auto go_on = [&] {
        is_ready = ready();
        return is_ready || (next_contour_ == NextContour::kReady && !contour_waiting_);
      };
      if (!changed_.wait(lock, stop, go_on)) return until_now(false);
      if (is_ready) return until_now(true);
      claim_next_contour();
      lock.unlock();
      prepare_next_contour();
      lock.lock();
    }
  }
  bool stereo_hand_on(std::stop_token stop, int item);
  void densify_receive(std::stop_token stop, int result);
  void densify_end(std::stop_token stop);
  void release_loop(std::stop_token stop);
  // Hands a result to the callback and records it; `early`: before its release time.
  void deliver(int result, bool early);
  void end_sequence();  // every result of the sequence was handed on

  // Waits for room in `queue` and pushes `item`; false when stopped first.
  bool hand_on(std::stop_token stop, BoundedQueue<int>& queue, int item);
  int acquire_slot(std::stop_token stop, bool neighbour_only);
  // Frees `slot` and gives every free slot the room of a slot the stereo step filled: `slot`
  // itself, else `fallback_model` (a late frame's slot has no stereo output to copy). So a slot
  // first taken, or first given a stereo step, late in the sequence does not allocate.
  void release_slot(int slot, int fallback_model);
  void fail(std::exception_ptr error);
  void rethrow_failure();
  void reset_state();
  void name_threads();

  const PipelineParams pipeline_;
  const RuntimeParams params_;
  const std::vector<int> cpus_;
  const bool releasing_;  // runtime.release_latency_ms applies
  const Clock::duration release_latency_;
  ResultCallback on_result_;
  StageHook hook_;

  std::unique_ptr<stereo::StereoMatcher> stereo_;
  std::unique_ptr<contour::ContourExtractor> contour_;
  densify::Densifier densifier_;
  densify::MatchPlaneSmoother planes_;  // the stereo thread's (plane_frame)
  EarlyContourScratch early_contour_;   // the stereo thread's (early_contour_frame)
  // Two stage threads and a contour stage on the CPU: the early contour work can move.
  const bool early_contour_moves_;
  // Whether the stereo thread runs the match planes, and then the early contour work, of the
  // frame it takes next (under mutex_).
  bool planes_on_stereo_thread() const;
  bool early_contour_on_stereo_thread(bool planes_here) const;

  // Shared by the stage threads and the release thread, which may run at SCHED_FIFO: a stage
  // thread preempted while holding it runs at the release thread's priority until it lets go.
  mutable PriorityInheritanceMutex mutex_;
  PriorityInheritanceCondition changed_;  // any state below changed
  // Only what the release thread waits for (a result in an empty release queue, every release
  // slot taken while the densify stage wants one, the end): at real-time priority each needless
  // wake-up of it preempts a stage thread.
  PriorityInheritanceCondition release_changed_;

  // Entry (producer side).
  std::array<Input, kInputs> inputs_;
  std::array<bool, kInputs> input_free_{};
  std::size_t input_cursor_ = 0;
  int waiting_input_ = -1;  // the frame at the entry, -1 when none
  bool end_requested_ = false;
  FrameIndex next_index_ = 0;  // index of the next pushed frame of the sequence
  int width_ = 0, height_ = 0, channels_ = 0;
  std::size_t entry_high_water_ = 0;
  FrameInterval frame_interval_;  // of the sequence's capture times
  // The stereo thread's last waits for the later stages (a slot, room in the queue).
  HoldUps hold_ups_;

  // Stereo -> contour.
  std::vector<SlotEntry> slots_;
  std::vector<bool> slot_free_;
  std::size_t slot_cursor_ = 0;
  BoundedQueue<int> stereo_queue_;
  std::array<int, 3> window_{};  // slot of frame t at t mod 3, for the last three frames
  FrameIndex received_ = 0;      // frames of the sequence the contour step received
  // The work the last contour step's results allow for the next one: none to take, ready for the
  // stereo thread to take, or being done by it (the contour step then waits for it). Only while
  // early_contour_moves_.
  enum class NextContour { kNone, kReady, kPreparing };
  NextContour next_contour_ = NextContour::kNone;
  bool contour_waiting_ = false;  // the contour thread waits for a frame or its stereo

  // Contour -> densify.
  std::vector<ResultEntry> results_;
  std::vector<bool> result_free_;
  std::size_t result_cursor_ = 0;
  BoundedQueue<int> densify_queue_;

  // Densify -> release.
  BoundedQueue<int> release_queue_;
  std::size_t held_for_release_ = 0;   // results in release_queue_
  bool release_wanted_ = false;        // the densify stage waits for a release slot
  bool release_thread_ready_ = false;  // the release thread has chosen its scheduling
  bool release_realtime_ = false;      // ... and got runtime.release_priority

  long drained_ = 0;  // sequences fully published
  std::exception_ptr failure_;

  Histogram latency_, ready_, stereo_ms_, contour_ms_, densify_ms_;
  long pushed_ = 0, dropped_ = 0, late_ = 0, published_ = 0, overdue_ = 0, early_ = 0;
  stereo::CameraCorrection camera_correction_;
  // Running means of each thread's work per frame, the match planes and the early contour work
  // left out: the stereo thread's, and the contour + densify steps' (the densify thread's alone
  // with three threads); and of those two steps.
  double stereo_work_ms_ = 0, other_work_ms_ = 0, planes_work_ms_ = 0, early_contour_work_ms_ = 0;
  long work_samples_ = 0, planes_on_stereo_ = 0, early_contour_on_stereo_ = 0;
  long next_contour_on_stereo_ = 0;
  bool sequence_recorded_ = false;  // a result of the sequence going on was recorded

  std::optional<OpenCvThreadsLease> opencv_threads_;  // while running, with opencv_threads > 0
  std::vector<std::jthread> threads_;
};

}  // namespace dco::pipeline::runtime
