// The real-time runtime: bit-identical to DepthPipeline when deterministic, drops at the entry
// (and nowhere else) when the input outruns it, clean start/stop/restart, no allocation per frame
// once warm, errors of a stage thread reported to the producer.

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/runtime/depth_runtime.hpp"
#include "support/allocation_counter.hpp"
#include "support/same_bytes.hpp"
#include "support/thread_names.hpp"
#include "support/time_slice_probe.hpp"

namespace dco::pipeline::runtime {
namespace {

using dco::testing::same_bytes;

using ::testing::HasSubstr;
using namespace std::chrono_literals;

constexpr int kWidth = 160, kHeight = 96;

struct Sequence {
  std::vector<synthetic::StereoSample> frames;
  PipelineParams params;
};

Sequence make_sequence(const char* name, int count) {
  const synthetic::SceneRenderer scene(synthetic::preset(name, kWidth, kHeight));
  Sequence s;
  s.frames.resize(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) scene.render(i, s.frames[static_cast<std::size_t>(i)]);
  s.params.stereo.max_disparity = synthetic::covering_max_disparity(scene.config());
  // The flow worker and the stages' row helpers (started with the stages where 4 or more CPUs
  // are usable) stay out of the thread counts below; the deterministic test turns them on.
  s.params.contour.parallel_flow = "off";
  s.params.stereo.row_threads = s.params.contour.row_threads = s.params.densify.row_threads = 1;
  return s;
}

std::vector<DepthResult> offline(const Sequence& s) {
  DepthPipeline pipeline(s.params);
  std::vector<DepthResult> out;
  DepthResult r;
  for (const auto& f : s.frames)
    if (pipeline.push(f.left.cview(), f.right.cview(), r)) out.push_back(r);
  while (pipeline.finish(r)) out.push_back(r);
  return out;
}

// Collects copies of every published result (copying allocates: not for the allocation test).
struct Collector {
  std::mutex mutex;
  std::vector<DepthResult> results;
  std::vector<FrameTimes> times;
  DepthRuntime::ResultCallback callback() {
    return [this](const DepthResult& r, const FrameTimes& t) {
      std::lock_guard lock(mutex);
      results.push_back(r);
      times.push_back(t);
    };
  }
};

// The threads the runtime names ("dco-stereo", "dco-rows", ...). Not every thread of the
// process: OpenCV starts its worker pool when a loop first asks for it, which can fall inside a
// test and made whole-process counts fail now and then.
int thread_count() {
  const std::vector<std::string> names = dco::testing::thread_names();
  return static_cast<int>(std::count_if(names.begin(), names.end(), [](const std::string& name) {
    return name.starts_with("dco-");
  }));
}

// The kernel clears a thread's id (which releases pthread_join) a moment before the thread leaves
// /proc/self/task, so a count taken right after a join may still see it: give it a second.
int settled_thread_count(int expected) {
  int n = thread_count();
  for (int i = 0; i < 200 && n != expected; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    n = thread_count();
  }
  return n;
}

void expect_identical(const std::vector<DepthResult>& expected, const std::vector<DepthResult>& got,
                      const std::string& what) {
  ASSERT_EQ(got.size(), expected.size()) << what;
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE(what + ", result " + std::to_string(i));
    EXPECT_EQ(got[i].index, expected[i].index);
    EXPECT_EQ(got[i].flow_cue, expected[i].flow_cue);
    EXPECT_TRUE(same_bytes(got[i].dense, expected[i].dense));
    EXPECT_TRUE(same_bytes(got[i].sparse, expected[i].sparse));
    EXPECT_TRUE(same_bytes(got[i].contours, expected[i].contours));
    EXPECT_TRUE(same_bytes(got[i].m_fuse, expected[i].m_fuse));
    EXPECT_TRUE(same_bytes(got[i].image, expected[i].image));
    EXPECT_EQ(got[i].solver.iterations, expected[i].solver.iterations);
  }
}

TEST(DepthRuntime, DeterministicModeEqualsTheOfflinePipelineBitForBit) {
  // "temporal": the stereo stage's guide follows the previous frame (this scene's search is
  // too narrow for "auto" to guide it).
  for (const auto& [lookahead, search_range] :
       {std::pair{1, "auto"}, std::pair{0, "auto"}, std::pair{1, "temporal"}}) {
    Sequence s = make_sequence("hand", 6);
    s.params.contour.lookahead = lookahead;
    s.params.stereo.search_range = search_range;
    const std::vector<DepthResult> expected = offline(s);
    ASSERT_EQ(expected.size(), 6u);
    // The runtime computes the two flow fields on two threads and shares each stage's rows among
    // three: the same output.
    PipelineParams parallel = s.params;
    parallel.contour.parallel_flow = "on";
    parallel.stereo.row_threads = parallel.contour.row_threads = parallel.densify.row_threads = 3;
    for (int threads : {1, 2, 3}) {
      RuntimeParams rp;
      rp.deterministic = true;
      rp.threads = threads;
      Collector c;
      DepthRuntime runtime(parallel, rp, c.callback());
      runtime.start();
      // Twice: drain ends a sequence and the next one starts afresh (no stability term from the
      // first one's last frame).
      for (int round = 0; round < 2; ++round) {
        for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
        runtime.drain();
        expect_identical(expected, c.results,
                         "lookahead " + std::to_string(lookahead) + ", " + search_range + ", " +
                             std::to_string(threads) + " thread(s), round " +
                             std::to_string(round));
        c.results.clear();
      }
      const RuntimeStats st = runtime.stats();
      EXPECT_EQ(st.pushed, 12);
      EXPECT_EQ(st.dropped, 0);
      EXPECT_EQ(st.published, 12);
      EXPECT_EQ(st.latency.count, 12);
    }
  }
}

// A solve many times the stereo stage's time (heavy_densify), or a stereo stage many times the
// rest.
void make_one_stage_heavy(PipelineParams& p, bool heavy_densify) {
  if (heavy_densify) {
    p.densify.tolerance = 1e-9;
    p.densify.max_iterations = 400;
    p.densify.multigrid = false;
  } else {
    p.stereo.aggregation_passes = 8;
    p.stereo.search_range = "full";
    p.densify.max_iterations = 1;
  }
}

// The sequence through a deterministic runtime of `threads` stage threads, as one sequence.
struct DeterministicRun {
  std::vector<DepthResult> results;
  RuntimeStats stats;
};
DeterministicRun run_deterministic(const Sequence& s, int threads,
                                   const StageFactories& stages = {},
                                   DepthRuntime::StageHook hook = {}) {
  RuntimeParams rp;
  rp.deterministic = true;
  rp.threads = threads;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback(), std::move(hook), stages);
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  return {std::move(c.results), runtime.stats()};
}

// The match planes (a densify step) and the early contour work (the intensity gradients and the
// stereo cue) go to the stereo thread while it has less other work, and the bytes are those of
// the offline pipeline.
TEST(DepthRuntime, MovableStepsRunOnTheThreadWithLessOtherWorkAndNoByteChanges) {
  for (const bool heavy_densify : {true, false}) {
    Sequence s = make_sequence("hand", 16);
    s.params.contour.use_flow = false;
    make_one_stage_heavy(s.params, heavy_densify);
    const std::vector<DepthResult> expected = offline(s);
    // A heavy solve also sleeps, so that the contour + densify thread is busy without taking the
    // CPU the stereo thread needs to get ahead (on two loaded CPUs the solve alone left it 1-9
    // shares).
    const DeterministicRun run = run_deterministic(s, 2, {}, [&](Stage stage, int) {
      if (heavy_densify && stage == Stage::kDensify) std::this_thread::sleep_for(30ms);
    });
    expect_identical(expected, run.results, heavy_densify ? "heavy densify" : "heavy stereo");
    const RuntimeStats& st = run.stats;
    // Decided from the published frames' times: the first frames go to the stereo thread before
    // the second result is known (the first is no sample of the work per frame): 3 here, one or
    // two more when a busy machine holds the other thread's results back. The same busy machine
    // can make one stereo step look as long as a sleeping solve (15 of 16 in a CI run).
    if (heavy_densify) {
      EXPECT_GE(st.planes_on_stereo_thread, 14);
      EXPECT_GE(st.early_contour_on_stereo_thread, 14);
    } else {
      EXPECT_LE(st.planes_on_stereo_thread, 5);
      EXPECT_LE(st.early_contour_on_stereo_thread, 5);
    }
    long planes = 0, early = 0;
    for (const DepthResult& r : run.results) {
      planes += r.planes_done;
      early += r.early_contour_done;
      EXPECT_GT(r.contour_timings.gaussian_ms, 0) << "the gradients' time, either thread";
      EXPECT_GT(r.contour_timings.stereo_cue_ms, 0) << "the stereo cue's";
    }
    EXPECT_EQ(planes, st.planes_on_stereo_thread);
    EXPECT_EQ(early, st.early_contour_on_stereo_thread);
  }
}

// The CPU stereo stage, its first match slower by kExtra: the search of the whole disparity range
// and of the camera alignment that a sequence's first frame makes, made long enough to show.
class SlowFirstMatch final : public stereo::StereoStageWrapper {
 public:
  static constexpr auto kExtra = 100ms;
  explicit SlowFirstMatch(const stereo::StereoParams& params)
      : StereoStageWrapper(stereo::make_cpu_stereo_matcher(params)) {}
  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    if (first_) std::this_thread::sleep_for(kExtra);
    first_ = false;
    inner().compute(left, right, disparity);
  }

 private:
  bool first_ = true;
};

// Which thread takes the movable steps follows the work per frame, and a sequence's first frame
// is no sample of it: taken as one, a first stereo step 100 ms long would have kept them off the
// stereo thread for about twenty frames, though the solve takes several times its later steps.
TEST(DepthRuntime, ASequencesFirstFrameIsNoSampleOfTheWorkPerFrame) {
  Sequence s = make_sequence("hand", 12);
  s.params.contour.use_flow = false;
  make_one_stage_heavy(s.params, /*heavy_densify=*/true);
  StageFactories stages;
  stages.stereo = [](const stereo::StereoParams& p) { return std::make_unique<SlowFirstMatch>(p); };
  // The solve also sleeps, as above: on two loaded CPUs a solve that only computes takes the CPU
  // the stereo thread needs to get ahead. A busy machine can still make one stereo step look as
  // long as a sleeping solve; a first frame taken as a sample keeps nearly all of them away.
  const DeterministicRun run = run_deterministic(s, 2, stages, [](Stage stage, int) {
    if (stage == Stage::kDensify) std::this_thread::sleep_for(30ms);
  });
  ASSERT_EQ(run.results.size(), 12u);
  EXPECT_GE(run.stats.stereo.max_ms, 100.0) << "the slow first frame was timed";
  EXPECT_GE(run.stats.planes_on_stereo_thread, 10);
  EXPECT_GE(run.stats.early_contour_on_stereo_thread, 10);
}

// The work that a frame's contour results allow for the next frame's (the reused flow field
// turned round, with its steps up to the fusion) goes to the stereo thread when it ends a frame
// while the contour + densify thread is busy, and stays the contour step's while that thread
// waits for the stereo stage: the bytes of the offline pipeline either way.
TEST(DepthRuntime, NextContourWorkGoesToTheStereoThreadOnlyWhileTheOtherIsBusy) {
  for (const bool heavy_densify : {true, false}) {
    Sequence s = make_sequence("hand", 12);
    s.params.contour.lookahead = 1;  // the window whose next step has a share to prepare
    make_one_stage_heavy(s.params, heavy_densify);
    const std::vector<DepthResult> expected = offline(s);
    // A heavy solve also sleeps, so that the contour + densify thread is busy without taking the
    // CPU the stereo thread needs to get ahead (on two loaded CPUs the solve alone left it 1-9
    // shares).
    const DeterministicRun run = run_deterministic(s, 2, {}, [&](Stage stage, int) {
      if (heavy_densify && stage == Stage::kDensify) std::this_thread::sleep_for(30ms);
    });
    expect_identical(expected, run.results, heavy_densify ? "heavy densify" : "heavy stereo");
    const long on_stereo = run.stats.next_contour_on_stereo_thread;
    std::printf("%s: the stereo thread did %ld of the next contour steps' shares\n",
                heavy_densify ? "heavy densify" : "heavy stereo", on_stereo);
    // Eleven contour steps have a previous one; some find the stereo thread still busy. How many
    // depends on the two threads' timing: most with the densify stage the heavy one, never above
    // 2 with the stereo stage the heavy one.
    if (heavy_densify)
      EXPECT_GE(on_stereo, 3);
    else
      EXPECT_LE(on_stereo, 2);
  }
  // Three stage threads or no flow cue: nothing to take.
  for (const bool three_threads : {true, false}) {
    Sequence s = make_sequence("hand", 6);
    s.params.contour.lookahead = 1;
    make_one_stage_heavy(s.params, /*heavy_densify=*/true);
    if (!three_threads) s.params.contour.use_flow = false;
    const std::vector<DepthResult> expected = offline(s);
    const DeterministicRun run = run_deterministic(s, three_threads ? 3 : 2);
    expect_identical(expected, run.results, three_threads ? "three threads" : "no flow cue");
    EXPECT_EQ(run.stats.next_contour_on_stereo_thread, 0);
  }
}

TEST(DepthRuntime, ColourInputAtHalfResolutionEqualsTheOfflinePipeline) {
  Sequence s = make_sequence("boxes", 3);
  for (auto& f : s.frames) {  // a colour pair: the grey replicated with a tint
    Image<std::uint8_t> l(kWidth, kHeight, 3), r(kWidth, kHeight, 3);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        for (int ch = 0; ch < 3; ++ch) {
          l.at(x, y, ch) = static_cast<std::uint8_t>(f.left.at(x, y) / (ch + 1) + 20 * ch);
          r.at(x, y, ch) = static_cast<std::uint8_t>(f.right.at(x, y) / (ch + 1) + 20 * ch);
        }
    f.left = std::move(l);
    f.right = std::move(r);
  }
  s.params.stereo.internal_resolution = "half";
  s.params.contour.use_flow = false;  // DIS needs more than the halved 80x48
  const std::vector<DepthResult> expected = offline(s);
  expect_identical(expected, run_deterministic(s, RuntimeParams{}.threads).results,
                   "colour, half resolution");
}

TEST(DepthRuntime, FramesCarryTheirTimesInStageOrder) {
  Sequence s = make_sequence("hand", 4);
  RuntimeParams rp;
  rp.deterministic = true;
  rp.threads = 3;
  rp.release_latency_ms = 1000;  // a replay does not wait for release times
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  // Each frame captured 5 ms before its push: a slow build (a sanitizer's) adds the frames before
  // it to no frame's time.
  std::vector<Clock::time_point> captures;
  for (const auto& f : s.frames) {
    captures.push_back(Clock::now() - 5ms);
    runtime.push(f.left.cview(), f.right.cview(), captures.back());
  }
  runtime.drain();
  ASSERT_EQ(c.times.size(), 4u);
  for (std::size_t k = 0; k < c.times.size(); ++k) {
    const FrameTimes& t = c.times[k];
    EXPECT_EQ(t.capture, captures.at(static_cast<std::size_t>(c.results[k].index)));
    EXPECT_LE(t.capture, t.entry);
    EXPECT_LE(t.entry, t.stereo_start);
    EXPECT_LE(t.stereo_start, t.stereo_end);
    EXPECT_LE(t.stereo_start + t.stereo_blocked, t.stereo_end);
    EXPECT_LE(t.stereo_end, t.contour_start);
    EXPECT_LE(t.contour_start, t.contour_end);
    EXPECT_LE(t.contour_end, t.densify_start);
    EXPECT_LE(t.densify_start, t.densify_end);
    EXPECT_LE(t.densify_end, t.release);
    EXPECT_LT(t.release - t.capture, 1000ms);
  }
  const RuntimeStats st = runtime.stats();
  EXPECT_EQ(st.stereo.count, 4);
  EXPECT_EQ(st.overdue, 0);
  EXPECT_GE(st.latency.p50_ms, 5.0);  // at least the 5 ms between capture and push
  EXPECT_GE(st.latency.p99_ms, st.latency.p50_ms);
  EXPECT_GT(st.stereo.mean_ms, 0.0);
  EXPECT_GT(st.densify.max_ms, 0.0);
}

// The CPU stereo stage, whose frame k (k >= first) does not end before the stage hook has seen
// the contour thread begin frame k's flow cue, or 10 s have passed. Frames are counted from 0.
class StereoWaitingForTheFlowCue final : public stereo::StereoMatcher {
 public:
  StereoWaitingForTheFlowCue(const stereo::StereoParams& params, int first)
      : inner_(stereo::make_cpu_stereo_matcher(params)), first_(first) {}

  void flow_cue_began(int index) {
    std::lock_guard lock(mutex_);
    flow_cue_began_.push_back(index);
    changed_.notify_all();
  }
  // The frames whose stereo the flow cue began during.
  std::vector<int> overlapped() {
    std::lock_guard lock(mutex_);
    return overlapped_;
  }

  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    const int k = frame_++;
    inner_->compute(left, right, disparity);
    if (k < first_) return;
    std::unique_lock lock(mutex_);
    const auto began = [&] {
      return std::find(flow_cue_began_.begin(), flow_cue_began_.end(), k) != flow_cue_began_.end();
    };
    if (changed_.wait_for(lock, 10s, began)) overlapped_.push_back(k);
  }
  void reset() override { inner_->reset(); }
  const stereo::StereoTimings& last_timings() const override { return inner_->last_timings(); }
  stereo::CameraCorrection last_correction() const override { return inner_->last_correction(); }
  int last_scale() const override { return inner_->last_scale(); }
  ImageView<const std::uint8_t> internal_left_gray() const override {
    return inner_->internal_left_gray();
  }
  ImageView<const float> internal_raw_disparity() const override {
    return inner_->internal_raw_disparity();
  }
  ImageView<const float> internal_sparse_disparity() const override {
    return inner_->internal_sparse_disparity();
  }
  const stereo::StereoParams& params() const override { return inner_->params(); }

 private:
  std::unique_ptr<stereo::StereoMatcher> inner_;
  const int first_;
  int frame_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<int> flow_cue_began_, overlapped_;
};

// The causal window's flow cue (lookahead 0) needs no disparity: the contour thread makes it
// while the frame's stereo runs, and only the rest of the contour step waits for the stereo.
TEST(DepthRuntime, TheCausalWindowsFlowCueIsMadeWhileTheFramesStereoRuns) {
  Sequence s = make_sequence("hand", 6);
  s.params.contour.lookahead = 0;
  RuntimeParams rp;
  rp.deterministic = true;
  rp.threads = 2;
  Collector c;
  StereoWaitingForTheFlowCue* stereo = nullptr;
  StageFactories stages;
  stages.stereo = [&](const stereo::StereoParams& p) {
    auto made = std::make_unique<StereoWaitingForTheFlowCue>(p, 2);  // 0 and 1 have no cue
    stereo = made.get();
    return made;
  };
  DepthRuntime runtime(
      s.params, rp, c.callback(),
      [&](Stage stage, int index) {
        if (stage == Stage::kFlowCue) stereo->flow_cue_began(index);
      },
      stages);
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  ASSERT_EQ(c.times.size(), s.frames.size());
  EXPECT_THAT(stereo->overlapped(), ::testing::ElementsAre(2, 3, 4, 5));
  double contour_ms = 0;
  for (std::size_t k = 0; k < c.times.size(); ++k) {
    const FrameTimes& t = c.times[k];
    EXPECT_EQ(c.results[k].flow_cue, k >= 2);
    EXPECT_EQ(t.contour_early > Clock::duration::zero(), k >= 2) << k;
    contour_ms +=
        std::chrono::duration<double, std::milli>(t.contour_end - t.contour_start + t.contour_early)
            .count();
  }
  // The stage's time holds the flow cue made ahead.
  EXPECT_NEAR(runtime.stats().contour.mean_ms, contour_ms / static_cast<double>(c.times.size()),
              0.01);
  // And the outputs are the offline pipeline's.
  expect_identical(offline(s), c.results, "flow cue made ahead");
}

// With the centred window the flow cue waits for the frame after it: nothing is made ahead.
TEST(DepthRuntime, TheCentredWindowMakesNoFlowCueAhead) {
  Sequence s = make_sequence("hand", 5);
  s.params.contour.lookahead = 1;
  RuntimeParams rp;
  rp.deterministic = true;
  rp.threads = 2;
  Collector c;
  std::atomic<int> flow_cue_hooks = 0;  // the hook runs on every stage thread
  DepthRuntime runtime(s.params, rp, c.callback(), [&](Stage stage, int) {
    if (stage == Stage::kFlowCue) ++flow_cue_hooks;
  });
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  ASSERT_EQ(c.times.size(), s.frames.size());
  EXPECT_EQ(flow_cue_hooks, 0);
  for (const FrameTimes& t : c.times) EXPECT_EQ(t.contour_early, Clock::duration::zero());
}

TEST(DepthRuntime, TheStereoStagesTimeLeavesOutItsWaitForASlowContourThread) {
  Sequence s = make_sequence("hand", 8);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.deterministic = true;
  rp.threads = 2;
  Collector c;
  // A contour thread far slower than the stereo stage: the stereo thread waits to hand frames on.
  DepthRuntime runtime(s.params, rp, c.callback(), [](Stage stage, int) {
    if (stage == Stage::kContour) std::this_thread::sleep_for(100ms);
  });
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  ASSERT_EQ(c.times.size(), s.frames.size());
  double span_ms = 0, blocked_ms = 0;
  for (const FrameTimes& t : c.times) {
    EXPECT_GE(t.stereo_blocked, Clock::duration::zero());
    EXPECT_LE(t.stereo_start + t.stereo_blocked, t.stereo_end);
    span_ms += std::chrono::duration<double, std::milli>(t.stereo_end - t.stereo_start).count();
    blocked_ms += std::chrono::duration<double, std::milli>(t.stereo_blocked).count();
  }
  const double n = static_cast<double>(c.times.size());
  EXPECT_GT(blocked_ms / n, 20.0);  // it did wait
  const RuntimeStats st = runtime.stats();
  EXPECT_NEAR(st.stereo.mean_ms, (span_ms - blocked_ms) / n, 0.01);
  EXPECT_LT(st.stereo.mean_ms, span_ms / n - 20.0);
}

TEST(DepthRuntime, WhenTheInputOutrunsItFramesAreDroppedAtTheEntryOnly) {
  Sequence s = make_sequence("hand", 4);
  for (int threads : {1, 2, 3}) {
    RuntimeParams rp;
    rp.threads = threads;
    rp.queue_depth = 2;
    rp.entry_deadline_ms = 0;  // the newest frame waits however long: no frame is late
    Collector c;
    // A stereo stage far slower than the producer.
    DepthRuntime runtime(s.params, rp, c.callback(), [](Stage stage, int) {
      if (stage == Stage::kStereo) std::this_thread::sleep_for(20ms);
    });
    runtime.start();
    constexpr int kPushed = 40;
    for (int i = 0; i < kPushed; ++i) {
      const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
      runtime.push(f.left.cview(), f.right.cview());
      std::this_thread::sleep_for(1ms);
    }
    runtime.drain();
    const RuntimeStats st = runtime.stats();
    SCOPED_TRACE(std::to_string(threads) + " thread(s)");
    EXPECT_EQ(st.pushed, kPushed);
    EXPECT_GT(st.dropped, kPushed / 2);
    EXPECT_EQ(st.late, 0);
    // Every frame that got past the entry came out, newest last.
    EXPECT_EQ(st.published + st.dropped, st.pushed);
    ASSERT_EQ(c.results.size(), static_cast<std::size_t>(st.published));
    for (std::size_t i = 1; i < c.results.size(); ++i)
      EXPECT_LT(c.results[i - 1].index, c.results[i].index);
    EXPECT_EQ(c.results.back().index, kPushed - 1);
    EXPECT_LE(st.entry_high_water, 1u);
    EXPECT_LE(st.stereo_queue_high_water, 2u);
    EXPECT_LE(st.densify_queue_high_water, 2u);
  }
}

// The contour fields DepthPipeline gives frame `centre` of `s` in the window of the camera
// frames around it (the flow neighbours centre - 1 and centre + 1).
DepthResult offline_window(const Sequence& s, int centre) {
  DepthPipeline pipeline(s.params);
  DepthResult r;
  const bool causal = s.params.contour.lookahead == 0;
  const int first = causal ? centre - 2 : centre - 1;
  for (int i = first; i <= first + 2; ++i) {
    const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
    if (pipeline.push(f.left.cview(), f.right.cview(), r) && r.index == centre - first) return r;
  }
  ADD_FAILURE() << "no result for the window's centre";
  return r;
}

TEST(DepthRuntime, AFrameLateAtTheEntryGetsNoDepthButStaysItsNeighboursFlowFrame) {
  Sequence s = make_sequence("hand", 4);
  for (const auto& [lookahead, threads] :
       {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 1}, std::pair{1, 2}}) {
    SCOPED_TRACE("lookahead " + std::to_string(lookahead) + ", " + std::to_string(threads) +
                 " thread(s)");
    s.params.contour.lookahead = lookahead;
    // Each frame's flow cue from its own two DIS runs, as offline_window makes it: with reuse a
    // window after an on-time one would carry that one's field on.
    s.params.contour.reuse_flow = false;
    RuntimeParams rp;
    rp.threads = threads;
    rp.entry_deadline_ms = 5;
    rp.entry_deadline_share = 0;  // the fixed deadline alone (the next test takes the share)
    std::mutex mutex;
    std::vector<std::pair<int, Clock::time_point>> taken;  // (index, when its stereo began)
    Collector c;
    DepthRuntime runtime(s.params, rp, c.callback(), [&](Stage stage, int index) {
      if (stage != Stage::kStereo) return;
      {
        std::lock_guard lock(mutex);
        taken.emplace_back(index, Clock::now());
      }
      std::this_thread::sleep_for(60ms);
    });
    const auto stereo_took = [&](int index) {
      std::lock_guard lock(mutex);
      return !taken.empty() && taken.back().first == index;
    };
    runtime.start();
    constexpr int kPushed = 12;
    long late = 0;
    for (int i = 0; i < kPushed; ++i) {
      const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
      runtime.push(f.left.cview(), f.right.cview());
      if (i + 1 == kPushed) break;
      // The next frame follows once this one was taken, so none is replaced at the entry and
      // the frames around each one are its camera neighbours, whatever the machine's speed. It
      // comes 10 ms into a stereo run of 60 ms, so it waits past the deadline and is late.
      const auto until = Clock::now() + 20s;
      while (!stereo_took(i) && runtime.stats().late == late && Clock::now() < until)
        std::this_thread::sleep_for(1ms);
      ASSERT_LT(Clock::now(), until) << "frame " << i << " was never taken";
      if (runtime.stats().late > late)
        late = runtime.stats().late;
      else
        std::this_thread::sleep_for(10ms);
    }
    runtime.drain();
    const RuntimeStats st = runtime.stats();
    EXPECT_EQ(st.pushed, kPushed);
    EXPECT_GE(st.late, 3);
    EXPECT_EQ(st.published + st.dropped, st.pushed);
    ASSERT_EQ(c.results.size(), static_cast<std::size_t>(st.published));
    ASSERT_EQ(taken.size(), static_cast<std::size_t>(st.published));
    for (std::size_t k = 0; k < c.results.size(); ++k) {
      const DepthResult& r = c.results[k];
      SCOPED_TRACE("frame " + std::to_string(r.index));
      ASSERT_EQ(taken[k].first, r.index);
      // The last frame waits however long: drain() said no newer one comes. Without the
      // deadline the frame pushed 10 ms into a 60 ms stereo run would wait 50 ms.
      if (r.index != kPushed - 1) {
        EXPECT_LT(taken[k].second - c.times[k].entry, 15ms);
      }
      // Its flow neighbours were the camera frames next to it, late or not.
      const bool whole_window =
          lookahead == 0 ? r.index >= 2 : r.index >= 1 && r.index < kPushed - 1;
      EXPECT_EQ(r.flow_cue, whole_window);
      if (!whole_window) continue;
      const DepthResult expected = offline_window(s, r.index);
      EXPECT_TRUE(same_bytes(r.m_fuse, expected.m_fuse));
      EXPECT_TRUE(same_bytes(r.contours, expected.contours));
    }
  }
}

// How long DepthPipeline takes per frame of `s` in this build (sanitised builds are far slower).
Clock::duration offline_frame_time(const Sequence& s) {
  const Clock::time_point start = Clock::now();
  offline(s);
  return (Clock::now() - start) / static_cast<int>(s.frames.size());
}

// Pushes frame i of `s` (cycling) once the stereo stage took frame i - 1, so none is replaced at
// the entry whatever the machine's speed; `took` is what the stereo hook last saw.
struct PacedProducer {
  std::mutex mutex;
  int took = -1;
  DepthRuntime::StageHook hook(std::function<void(Stage, int)> more = {}) {
    return [this, more](Stage stage, int index) {
      if (stage == Stage::kStereo) {
        std::lock_guard lock(mutex);
        took = index;
      }
      if (more) more(stage, index);
    };
  }
  void push(DepthRuntime& runtime, const Sequence& s, int i) {
    const auto until = Clock::now() + 60s;
    while (Clock::now() < until) {
      {
        std::lock_guard lock(mutex);
        if (took == i - 1) break;
      }
      std::this_thread::sleep_for(1ms);
    }
    const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
    runtime.push(f.left.cview(), f.right.cview());
  }
  // Waits until the stereo stage took frame i - 1, or found a frame late since the last wait (a
  // late frame never reaches the hook); false when neither happened within 60 s.
  long late_seen = 0;
  bool wait_for_previous(DepthRuntime& runtime, int i) {
    const auto until = Clock::now() + 60s;
    bool seen = false;
    while (!seen && Clock::now() < until) {
      {
        std::lock_guard lock(mutex);
        seen = took == i - 1;
      }
      seen = seen || runtime.stats().late > late_seen;
      if (!seen) std::this_thread::sleep_for(1ms);
    }
    late_seen = runtime.stats().late;
    return seen;
  }
};

// Waits until frames 0..last were published or dropped; false when that took over 60 s.
bool wait_until_out(DepthRuntime& runtime, int last) {
  const auto until = Clock::now() + 60s;
  while (Clock::now() < until) {
    const RuntimeStats st = runtime.stats();
    if (st.published + st.dropped >= last + 1) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

TEST(DepthRuntime, AFrameThatWaitedLessThanItsShareOfTheFrameIntervalStillGetsDepth) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  // The camera's frames are 990 ms apart (their capture times say so), so with a share of 0.9 a
  // frame may wait 891 ms: a sanitised build on a busy machine takes a few hundred ms for the
  // work of a frame before the next one is taken. Each frame arrives as the stereo stage starts on
  // the one before, and that stage takes 15 ms more than its work: every frame waits 15 ms and more
  // at the entry. With a share, a frame is pushed only once frame i - 3 is out (its contour step
  // runs when frame i - 2 arrives there, lookahead 1), so the contour + densify thread, slower
  // than the stereo stage in a sanitised build on two cores, is free when the stereo stage hands
  // frame i - 1 on: it never holds the stereo thread up while frame i waits, a wait that is late
  // whatever the share (the next test).
  constexpr auto kInterval = 990ms;
  constexpr int kPushed = 8;
  for (const double share : {0.9, 0.0}) {
    for (int threads : {1, 2}) {
      SCOPED_TRACE("share " + std::to_string(share) + ", " + std::to_string(threads) +
                   " thread(s)");
      RuntimeParams rp;
      rp.threads = threads;
      rp.entry_deadline_ms = 5;
      rp.entry_deadline_share = share;
      Collector c;
      PacedProducer producer;
      DepthRuntime runtime(s.params, rp, c.callback(), producer.hook([](Stage stage, int) {
        if (stage == Stage::kStereo) std::this_thread::sleep_for(15ms);
      }));
      runtime.start();
      const Clock::time_point first_capture = Clock::now() - kPushed * kInterval;
      for (int i = 0; i < kPushed; ++i) {
        if (share > 0) {
          ASSERT_TRUE(wait_until_out(runtime, i - 3)) << "frame " << i - 3 << " never came out";
        }
        ASSERT_TRUE(producer.wait_for_previous(runtime, i))
            << "frame " << i - 1 << " was never taken";
        const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
        runtime.push(f.left.cview(), f.right.cview(), first_capture + i * kInterval);
        std::this_thread::sleep_for(2ms);
      }
      runtime.drain();
      const RuntimeStats st = runtime.stats();
      EXPECT_EQ(st.pushed, kPushed);
      EXPECT_EQ(st.published + st.dropped, st.pushed);
      if (share > 0) {
        // 15 ms and the work of a frame of 160x96 are far below 891 ms; only frame 1, which waits
        // for a new runtime's first frame (its buffers touched for the first time), may take
        // longer in a sanitised build on a busy machine.
        EXPECT_LE(st.late, 1);
        std::vector<int> published;
        for (const DepthResult& r : c.results) published.push_back(r.index);
        for (int i = 2; i < kPushed; ++i)
          EXPECT_NE(std::find(published.begin(), published.end(), i), published.end())
              << "frame " << i << " got no depth";
      } else {
        // The 5 ms deadline alone: whatever arrived during a stereo run is late, the frame after
        // it meets a free stage (and the last one never is late: nothing newer comes).
        EXPECT_GE(st.late, kPushed / 2 - 1);
      }
    }
  }
}

TEST(DepthRuntime, AFrameThatWaitedForTheLaterStagesIsLateWhateverTheShare) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.threads = 2;
  rp.entry_deadline_ms = 5;
  rp.entry_deadline_share = 0.9;  // of 990 ms: 891 ms
  Collector c;
  PacedProducer producer;
  // The contour + densify thread takes 500 ms a frame, so the stereo thread soon waits for room
  // in the queue to it before each frame's stereo.
  DepthRuntime runtime(s.params, rp, c.callback(), producer.hook([](Stage stage, int) {
    if (stage == Stage::kContour) std::this_thread::sleep_for(500ms);
  }));
  runtime.start();
  constexpr int kPushed = 8;
  const Clock::time_point first_capture = Clock::now() - kPushed * 990ms;
  for (int i = 0; i < kPushed; ++i) {
    // Each frame arrives 20 ms after the one before was taken (or found late), while the stereo
    // thread prepares that one and then waits for the contour + densify thread.
    ASSERT_TRUE(producer.wait_for_previous(runtime, i)) << "frame " << i - 1 << " was never taken";
    std::this_thread::sleep_for(20ms);
    const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
    runtime.push(f.left.cview(), f.right.cview(), first_capture + i * 990ms);
  }
  runtime.drain();
  const RuntimeStats st = runtime.stats();
  EXPECT_EQ(st.published + st.dropped, st.pushed);
  // Far inside the share, but held up by the later stages: a fresher frame will be as soon.
  EXPECT_GE(st.late, 2);
}

TEST(DepthRuntime, WithAReleaseLatencyEveryResultIsHandedOnAtItsCaptureTimePlusThatLatency) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  // Above this build's time for a frame, and the hook's 80 ms.
  const auto latency = std::min<Clock::duration>(150ms + 3 * offline_frame_time(s), 1000ms);
  for (int threads : {2, 3}) {
    SCOPED_TRACE(std::to_string(threads) + " thread(s)");
    RuntimeParams rp;
    rp.threads = threads;
    rp.release_latency_ms = std::chrono::duration<double, std::milli>(latency).count();
    rp.entry_deadline_ms = 0;  // paced: each frame waits for nothing but the stage to be free
    Collector c;
    PacedProducer producer;
    // Every other frame's densify stage takes 80 ms longer, so results are ready at ages about
    // 80 ms apart.
    DepthRuntime runtime(s.params, rp, c.callback(), producer.hook([](Stage stage, int index) {
      if (stage == Stage::kDensify && index % 2 == 1) std::this_thread::sleep_for(80ms);
    }));
    runtime.start();
    constexpr int kPushed = 8;
    for (int i = 0; i < kPushed; ++i) {
      producer.push(runtime, s, i);
      // At most three results wait for release at once, under the four release slots.
      std::this_thread::sleep_for(latency / 3);
    }
    runtime.drain();
    const RuntimeStats st = runtime.stats();
    EXPECT_EQ(st.dropped, 0);
    EXPECT_EQ(st.published, kPushed);
    EXPECT_EQ(st.early, 0);
    ASSERT_EQ(c.times.size(), static_cast<std::size_t>(st.published));
    long overdue = 0;
    std::vector<Clock::duration> ready, age;  // of the results that were ready in time
    for (std::size_t k = 0; k < c.times.size(); ++k) {
      SCOPED_TRACE("result " + std::to_string(k));
      const FrameTimes& t = c.times[k];
      EXPECT_EQ(c.results[k].index, static_cast<int>(k));
      if (t.densify_end - t.capture > latency) {  // went at once
        ++overdue;
        EXPECT_LT(t.release - t.densify_end, 20ms);
        continue;
      }
      EXPECT_GE(t.release - t.capture, latency);
      ready.push_back(t.densify_end - t.capture);
      age.push_back(t.release - t.capture);
    }
    EXPECT_EQ(st.overdue, overdue);
    ASSERT_GE(ready.size(), 4u);
    const auto [ready_min, ready_max] = std::minmax_element(ready.begin(), ready.end());
    const auto [age_min, age_max] = std::minmax_element(age.begin(), age.end());
    EXPECT_GE(*ready_max - *ready_min, 40ms);  // the stages did vary
    EXPECT_LT(*age_max - *age_min, 20ms);      // what the callback saw did not
  }
}

TEST(DepthRuntime, AResultReadyAfterItsReleaseTimeGoesAtOnceAndCountsAsOverdue) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.release_latency_ms = 5;
  rp.entry_deadline_ms = 0;
  Collector c;
  PacedProducer producer;
  DepthRuntime runtime(s.params, rp, c.callback(), producer.hook([](Stage stage, int) {
    if (stage == Stage::kDensify) std::this_thread::sleep_for(20ms);
  }));
  runtime.start();
  for (int i = 0; i < 4; ++i) producer.push(runtime, s, i);
  runtime.drain();
  const RuntimeStats st = runtime.stats();
  EXPECT_EQ(st.published, 4);
  EXPECT_EQ(st.overdue, 4);
  EXPECT_EQ(st.early, 0);
  for (const FrameTimes& t : c.times) {
    EXPECT_GT(t.densify_end - t.capture, 5ms);
    EXPECT_LT(t.release - t.densify_end, 20ms);  // not held any longer
  }
}

// A camera stamp in the future (a clock fault) must not hold its result, and every one behind
// it, until that time: the release counts from the entry when the stamp lies after it.
TEST(DepthRuntime, AFutureCaptureStampIsReleasedFromItsEntry) {
  Sequence s = make_sequence("hand", 3);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.release_latency_ms = 50;
  rp.entry_deadline_ms = 0;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  const auto start = Clock::now();
  for (int i = 0; i < 3; ++i) {
    // One at a time: no frame is left behind as late, each result is the one of its push.
    runtime.push(s.frames[i].left.cview(), s.frames[i].right.cview(),
                 Clock::now() + (i == 1 ? 3s : 0s));
    const auto until = Clock::now() + 5s;
    while (Clock::now() < until) {
      {
        std::lock_guard lock(c.mutex);
        if (c.times.size() == static_cast<std::size_t>(i + 1)) break;
      }
      std::this_thread::sleep_for(1ms);
    }
  }
  runtime.drain();
  EXPECT_LT(Clock::now() - start, 2s) << "a result was held until its stamp";
  ASSERT_EQ(c.times.size(), 3u);
  for (const FrameTimes& t : c.times) EXPECT_LT(t.release - t.entry, 1s);
}

// Whether a thread of this process may move itself to SCHED_FIFO at `priority`, tried on a thread
// of its own.
bool may_use_fifo_priority(int priority) {
  bool ok = false;
  std::thread([&] { ok = dco::request_fifo_priority(priority); }).join();
  return ok;
}

// The callback runs on the release thread: what it sees there, over a short sequence.
struct ReleaseThreadView {
  std::vector<int> policies, priorities;
  std::vector<std::string> names;
  RuntimeStats stats;
  bool realtime_at_start = false;
};

ReleaseThreadView view_release_thread(int release_priority) {
  const Sequence s = make_sequence("hand", 2);
  RuntimeParams rp;
  rp.release_latency_ms = 20;
  rp.release_priority = release_priority;
  ReleaseThreadView v;
  std::mutex mutex;
  DepthRuntime runtime(s.params, rp, [&](const DepthResult&, const FrameTimes&) {
    sched_param param{};
    int policy = -1;
    pthread_getschedparam(pthread_self(), &policy, &param);
    char name[16] = {};
    pthread_getname_np(pthread_self(), name, sizeof name);
    std::lock_guard lock(mutex);
    v.policies.push_back(policy);
    v.priorities.push_back(param.sched_priority);
    v.names.emplace_back(name);
  });
  runtime.start();
  v.realtime_at_start = runtime.stats().release_realtime;
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  v.stats = runtime.stats();
  return v;
}

TEST(DepthRuntime, TheReleaseThreadRunsAtTheRealTimePriorityAskedForWhereTheProcessMayUseIt) {
  const bool allowed = may_use_fifo_priority(3);
  const ReleaseThreadView v = view_release_thread(3);
  ASSERT_FALSE(v.policies.empty());         // newest wins at the entry: not every frame gets depth
  EXPECT_EQ(v.realtime_at_start, allowed);  // known as soon as start returns
  EXPECT_EQ(v.stats.release_realtime, allowed);
  for (std::size_t i = 0; i < v.policies.size(); ++i) {
    EXPECT_EQ(v.policies[i], allowed ? SCHED_FIFO : SCHED_OTHER);
    EXPECT_EQ(v.priorities[i], allowed ? 3 : 0);
    EXPECT_EQ(v.names[i], "dco-release");
  }
  if (!allowed) std::cout << "[ NOTE     ] this process may not use SCHED_FIFO: fallback checked\n";
}

TEST(DepthRuntime, AReleasePriorityOfZeroKeepsTheReleaseThreadNormal) {
  const ReleaseThreadView v = view_release_thread(0);
  ASSERT_FALSE(v.policies.empty());  // newest wins at the entry: not every frame gets depth
  EXPECT_FALSE(v.stats.release_realtime);
  for (int policy : v.policies) EXPECT_EQ(policy, SCHED_OTHER);
}

TEST(DepthRuntime, TheReleaseThreadAsksForAShortTimeSliceAndKeepsItsNiceValue) {
  if (!dco::testing::kernel_keeps_time_slices())
    GTEST_SKIP() << "this kernel does not keep time slices";

  const Sequence s = make_sequence("hand", 2);
  std::vector<SchedAttr> seen;
  // The runtime starts from a thread with a nice value of its own, which its threads inherit:
  // a service run at a raised (or, here, lowered) priority keeps it in every thread.
  std::thread([&] {
    ASSERT_EQ(setpriority(PRIO_PROCESS, 0, 4), 0);
    ASSERT_TRUE(dco::testing::set_time_slice(2'000'000));  // inherited by the runtime's threads
    RuntimeParams rp;
    rp.release_latency_ms = 50;
    rp.release_priority = 0;  // a normal thread
    std::mutex mutex;
    DepthRuntime runtime(s.params, rp, [&](const DepthResult&, const FrameTimes&) {
      SchedAttr a;
      if (!thread_sched_attr(0, a)) return;
      std::lock_guard lock(mutex);
      seen.push_back(a);
    });
    runtime.start();
    for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
    runtime.drain();
  }).join();
  ASSERT_FALSE(seen.empty());
  for (const SchedAttr& a : seen) {  // the callback runs on the release thread
    EXPECT_EQ(a.sched_runtime, 100'000u);
    EXPECT_EQ(a.sched_nice, 4);
  }
}

TEST(DepthRuntime, WithEveryReleaseSlotTakenTheOldestResultGoesEarlyAndNoStageWaits) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.release_latency_ms = 1000;
  rp.entry_deadline_ms = 0;  // no frame is late, however long it waits for the stereo stage
  Collector c;
  PacedProducer producer;
  DepthRuntime runtime(s.params, rp, c.callback(), producer.hook());
  runtime.start();
  constexpr int kPushed = 7;
  const Clock::time_point start = Clock::now();
  for (int i = 0; i < kPushed; ++i) producer.push(runtime, s, i);
  runtime.drain();
  const RuntimeStats st = runtime.stats();
  EXPECT_EQ(st.dropped, 0);
  ASSERT_EQ(st.published, kPushed);
  ASSERT_EQ(c.times.size(), static_cast<std::size_t>(kPushed));
  long early = 0;
  for (int k = 0; k < kPushed; ++k) {
    SCOPED_TRACE("result " + std::to_string(k));
    const FrameTimes& t = c.times[static_cast<std::size_t>(k)];
    EXPECT_EQ(c.results[static_cast<std::size_t>(k)].index, k);
    if (t.release - t.capture >= 1000ms) continue;
    // Before its time only because a fifth result was ready and four waited.
    ++early;
    ASSERT_LT(k + 4, kPushed);
    EXPECT_GE(t.release, c.times[static_cast<std::size_t>(k) + 4].densify_end);
  }
  EXPECT_EQ(st.early, early);
  // Where no result reached its release time during the run, each of the last three sent one.
  if (c.times[0].capture + 1000ms > c.times.back().densify_end) {
    EXPECT_EQ(st.early, kPushed - 4);
  }
  EXPECT_GT(Clock::now() - start, 1000ms);  // drain waited for the last results' time
}

TEST(DepthRuntime, EachThreadCarriesTheNameOfWhatItRuns) {
  const Sequence s = make_sequence("hand", 1);
  for (int threads : {2, 3}) {
    RuntimeParams rp;
    rp.threads = threads;
    rp.release_latency_ms = 10;
    DepthRuntime runtime(s.params, rp, [](const DepthResult&, const FrameTimes&) {});
    runtime.start();
    const std::vector<std::string> names = dco::testing::thread_names();
    const auto count = [&](const char* name) { return dco::testing::count_named(names, name); };
    EXPECT_EQ(count("dco-stereo"), 1) << threads << " threads";
    EXPECT_EQ(count("dco-contour"), 1) << threads << " threads";
    EXPECT_EQ(count("dco-densify"), threads == 3 ? 1 : 0) << threads << " threads";
    EXPECT_EQ(count("dco-release"), 1) << threads << " threads";
    runtime.stop();
  }
}

TEST(DepthRuntime, StopDoesNotWaitForResultsHeldForTheirReleaseTime) {
  Sequence s = make_sequence("hand", 3);
  s.params.contour.use_flow = false;
  const int before = thread_count();
  RuntimeParams rp;
  rp.threads = 3;
  rp.release_latency_ms = 1000;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  EXPECT_EQ(settled_thread_count(before + 4), before + 4);  // three stages and the release
  for (const auto& f : s.frames) {
    runtime.push(f.left.cview(), f.right.cview());
    std::this_thread::sleep_for(20ms);
  }
  const Clock::time_point stopping = Clock::now();
  runtime.stop();
  EXPECT_LT(Clock::now() - stopping, 500ms);
  EXPECT_TRUE(c.results.empty());
  EXPECT_EQ(settled_thread_count(before), before);
}

TEST(DepthRuntime, ASlowDensifyStageMakesTheEntryDropWithoutAnyQueueGrowing) {
  Sequence s = make_sequence("hand", 4);
  RuntimeParams rp;
  rp.threads = 3;
  rp.queue_depth = 1;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback(), [](Stage stage, int) {
    if (stage == Stage::kDensify) std::this_thread::sleep_for(25ms);
  });
  runtime.start();
  for (int i = 0; i < 30; ++i) {
    const auto& f = s.frames[static_cast<std::size_t>(i) % s.frames.size()];
    runtime.push(f.left.cview(), f.right.cview());
    std::this_thread::sleep_for(2ms);
  }
  runtime.drain();
  const RuntimeStats st = runtime.stats();
  EXPECT_GT(st.dropped, 10);
  EXPECT_EQ(st.published + st.dropped, st.pushed);
  EXPECT_LE(st.stereo_queue_high_water, 1u);
  EXPECT_LE(st.densify_queue_high_water, 1u);
}

TEST(DepthRuntime, StartStopAndRestartLeaveNoThreadBehind) {
  Sequence s = make_sequence("static", 3);
  const int before = thread_count();
  for (int threads : {1, 2, 3}) {
    RuntimeParams rp;
    rp.threads = threads;
    rp.deterministic = true;
    Collector c;
    DepthRuntime runtime(s.params, rp, c.callback());
    EXPECT_FALSE(runtime.running());
    EXPECT_THROW(runtime.push(s.frames[0].left.cview(), s.frames[0].right.cview()), Error);
    for (int round = 0; round < 3; ++round) {
      runtime.start();
      EXPECT_TRUE(runtime.running());
      EXPECT_THROW(runtime.start(), Error);
      EXPECT_EQ(settled_thread_count(before + threads), before + threads);
      for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
      runtime.drain();
      EXPECT_EQ(runtime.stats().published, 3);  // statistics restart with the runtime
      runtime.stop();
      EXPECT_FALSE(runtime.running());
      EXPECT_EQ(settled_thread_count(before), before);
    }
    EXPECT_EQ(c.results.size(), 9u);
  }
}

TEST(DepthRuntime, ZeroThreadsRunTheCountItsStagesCallFor) {
  Sequence s = make_sequence("static", 3);
  const int before = thread_count();
  for (bool on_gpu : {false, true}) {
    RuntimeParams rp;  // threads = 0
    rp.deterministic = true;
    StageFactories stages;  // the CPU stages, also marked as a GPU's: the choice is the same
    stages.on_gpu = on_gpu;
    const int expected = usable_cpus() >= 4 ? 3 : 2;
    Collector c;
    DepthRuntime runtime(s.params, rp, c.callback(), {}, stages);
    EXPECT_EQ(runtime.runtime_params().threads, expected);
    runtime.start();
    EXPECT_EQ(settled_thread_count(before + expected), before + expected);
    for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
    runtime.drain();
    runtime.stop();
    EXPECT_EQ(c.results.size(), 3u);
  }
}

TEST(DepthRuntime, OpenCvsLoopsRunOnTheThreadsAskedForWhileItRuns) {
  const Sequence s = make_sequence("hand", 4);  // with the flow cue: DIS runs
  const int original = cv::getNumThreads();
  cv::setNumThreads(3);
  RuntimeParams rp;
  rp.threads = 2;
  rp.deterministic = true;
  rp.opencv_threads = 1;
  std::atomic<int> in_contour{-1};
  Collector c;
  {
    DepthRuntime runtime(s.params, rp, c.callback(), [&](Stage stage, int) {
      if (stage == Stage::kContour) in_contour = cv::getNumThreads();
    });
    EXPECT_EQ(runtime.runtime_params().opencv_threads, 1);
    EXPECT_EQ(cv::getNumThreads(), 3);  // not before start
    runtime.start();
    for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
    runtime.drain();
    EXPECT_EQ(in_contour.load(), 1);
    runtime.stop();
    EXPECT_EQ(cv::getNumThreads(), 3);  // given back
    runtime.start();
    EXPECT_EQ(cv::getNumThreads(), 1);
  }  // the destructor stops, and gives it back
  EXPECT_EQ(cv::getNumThreads(), 3);
  EXPECT_EQ(c.results.size(), 4u);
  // Auto: one thread where the two stage threads take every usable CPU, else OpenCV's choice.
  rp.opencv_threads = 0;
  const DepthRuntime automatic(s.params, rp, c.callback());
  EXPECT_EQ(automatic.runtime_params().opencv_threads, usable_cpus() <= 2 ? 1 : 0);
  cv::setNumThreads(original);
}

TEST(DepthRuntime, StopDiscardsFramesInFlightAndTheNextStartBeginsAfresh) {
  Sequence s = make_sequence("hand", 4);
  s.params.contour.use_flow = false;
  const int before = thread_count();
  RuntimeParams rp;
  rp.threads = 3;
  Collector c;
  {
    DepthRuntime runtime(s.params, rp, c.callback(),
                         [](Stage, int) { std::this_thread::sleep_for(10ms); });
    runtime.start();
    for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
    runtime.stop();  // frames still in the stages
    EXPECT_EQ(settled_thread_count(before), before);
    runtime.start();
    for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
    // Left running: the destructor stops it.
  }
  EXPECT_EQ(settled_thread_count(before), before);
}

TEST(DepthRuntime, AStageErrorReachesTheProducerAndARestartRecovers) {
  Sequence s = make_sequence("static", 3);
  RuntimeParams rp;
  rp.deterministic = true;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  // Smaller than the 9x7 census window: the stereo stage (on its thread) refuses it.
  const Image<std::uint8_t> tiny(6, 5);
  runtime.push(tiny.cview(), tiny.cview());
  try {
    runtime.drain();
    ADD_FAILURE() << "drain did not report the stereo stage's error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("census window"));
  }
  EXPECT_THROW(runtime.push(tiny.cview(), tiny.cview()), Error);
  runtime.stop();
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  EXPECT_EQ(c.results.size(), 3u);
}

TEST(DepthRuntime, BadInputIsRejectedAtTheEntry) {
  Sequence s = make_sequence("static", 1);
  const auto small = synthetic::SceneRenderer(synthetic::preset("static", 128, 96));
  synthetic::StereoSample other;
  small.render(0, other);
  RuntimeParams rp;
  rp.deterministic = true;
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  const auto& f = s.frames[0];
  EXPECT_THROW(runtime.push(f.left.cview(), other.right.cview()), Error);  // pair sizes differ
  const Image<std::uint8_t> two(kWidth, kHeight, 2);
  EXPECT_THROW(runtime.push(two.cview(), two.cview()), Error);
  runtime.push(f.left.cview(), f.right.cview());
  try {
    runtime.push(other.left.cview(), other.right.cview());
    ADD_FAILURE() << "a size change within a sequence was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("drain()"));
  }
  runtime.drain();
  runtime.push(other.left.cview(), other.right.cview());  // a new sequence may change size
  runtime.drain();
  ASSERT_EQ(c.results.size(), 2u);
  EXPECT_EQ(c.results[1].dense.width(), 128);
}

TEST(DepthRuntime, BadParamsAndUnavailableCpusAreRejected) {
  const Sequence s = make_sequence("static", 1);
  RuntimeParams rp;
  rp.threads = -1;
  EXPECT_THROW(DepthRuntime(s.params, rp, {}), Error);
  rp.threads = 4;
  EXPECT_THROW(DepthRuntime(s.params, rp, {}), Error);
  rp = {};
  rp.affinity = "0,zero";
  EXPECT_THROW(DepthRuntime(s.params, rp, {}), Error);
  PipelineParams bad = s.params;
  bad.densify.lambda_d = 0;
  EXPECT_THROW(DepthRuntime(bad, RuntimeParams{}, {}), Error);

  const int before = thread_count();
  rp = {};
  rp.affinity = "1000";  // a CPU no machine here has
  DepthRuntime runtime(s.params, rp, {});
  try {
    runtime.start();
    ADD_FAILURE() << "pinned a thread to CPU 1000";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("CPU 1000"));
  }
  EXPECT_FALSE(runtime.running());
  EXPECT_EQ(settled_thread_count(before), before);
}

TEST(DepthRuntime, PinnedThreadsProduceTheSameResults) {
  const Sequence s = make_sequence("hand", 3);
  const std::vector<DepthResult> expected = offline(s);
  RuntimeParams rp;
  rp.deterministic = true;
  rp.affinity = "0";
  Collector c;
  DepthRuntime runtime(s.params, rp, c.callback());
  runtime.start();
  for (const auto& f : s.frames) runtime.push(f.left.cview(), f.right.cview());
  runtime.drain();
  expect_identical(expected, c.results, "pinned to CPU 0");
}

TEST(DepthRuntime, WarmFramesDoNotAllocate) {
  if (!testing::kCountsAlignedAlloc) GTEST_SKIP() << "the sanitizer runtime owns the allocator";
  Sequence s = make_sequence("hand", 24);
  s.params.contour.use_flow = false;  // OpenCV's DIS allocates inside every call
  for (int threads : {1, 2, 3}) {
    RuntimeParams rp;
    rp.threads = threads;
    rp.deterministic = true;
    std::atomic<long> published{0};
    DepthRuntime runtime(s.params, rp,
                         [&](const DepthResult&, const FrameTimes&) { published.fetch_add(1); });
    runtime.start();
    // Four frames in and published: the first result gave every pooled result its room, and
    // frame 0's slot, freed when frame 2 was received, gave every free slot its room. That
    // happened before frame 3 was received, so before its result; a wait of fixed length
    // instead was too short for a debug build. Most entries of both pools have not been used yet.
    constexpr int kWarm = 4;
    for (int i = 0; i < kWarm; ++i) {
      const auto& f = s.frames[static_cast<std::size_t>(i)];
      runtime.push(f.left.cview(), f.right.cview());
    }
    while (published.load() < kWarm) std::this_thread::sleep_for(1ms);
    testing::start_counting_allocations();
    for (int i = kWarm; i < 24; ++i) {
      const auto& f = s.frames[static_cast<std::size_t>(i)];
      runtime.push(f.left.cview(), f.right.cview());
    }
    while (published.load() < 23) std::this_thread::sleep_for(1ms);
    EXPECT_EQ(testing::stop_counting_allocations().total(), 0) << threads << " thread(s)";
    runtime.drain();
    EXPECT_EQ(published.load(), 24);
  }
}

TEST(DepthRuntime, WarmFramesHeldForTheirReleaseTimeDoNotAllocate) {
  if (!testing::kCountsAlignedAlloc) GTEST_SKIP() << "the sanitizer runtime owns the allocator";
  Sequence s = make_sequence("hand", 24);
  s.params.contour.use_flow = false;
  RuntimeParams rp;
  rp.release_latency_ms = 30;
  std::atomic<long> published{0};
  DepthRuntime runtime(s.params, rp,
                       [&](const DepthResult&, const FrameTimes&) { published.fetch_add(1); });
  runtime.start();
  int pushed = 0;
  const auto push_next = [&] {  // every 10 ms, round the sequence again when it ends
    const auto& f = s.frames[static_cast<std::size_t>(pushed++) % s.frames.size()];
    runtime.push(f.left.cview(), f.right.cview());
    std::this_thread::sleep_for(10ms);
  };
  // However many frames a busy machine drops at the entry, six published ones are enough
  // warming: the first sizes every free pooled result (the release slots' included) and every
  // free stereo slot, and by the sixth the slots in flight then have come back and been sized.
  while (published.load() < 6) {
    ASSERT_LT(pushed, 1000) << "six frames were not published in 10 s";
    push_next();
  }
  std::this_thread::sleep_for(100ms);
  const long warm = published.load();
  testing::start_counting_allocations();
  for (int i = 0; i < 12; ++i) push_next();
  for (int waited = 0; published.load() < warm + 2 && waited < 5000; ++waited)
    std::this_thread::sleep_for(1ms);
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(testing::stop_counting_allocations().total(), 0);
  EXPECT_GE(published.load(), warm + 2);
  runtime.drain();
}

TEST(AllocationCounter, SeesAllocationsOnOtherThreads) {
  testing::start_counting_allocations();
  std::thread([] {
    auto* v = new std::vector<int>(100);
    testing::allocation_sink = v->data();
    delete v;
  }).join();
  EXPECT_GE(testing::stop_counting_allocations().new_calls, 1);
}

}  // namespace
}  // namespace dco::pipeline::runtime
