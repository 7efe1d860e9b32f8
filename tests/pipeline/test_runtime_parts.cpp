// The runtime's building blocks: duration histograms, bounded queues and the runtime.* params.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/pipeline/runtime/bounded_queue.hpp"
#include "dco/pipeline/runtime/entry_deadline.hpp"
#include "dco/pipeline/runtime/histogram.hpp"
#include "dco/pipeline/runtime/opencv_threads.hpp"
#include "dco/pipeline/runtime/runtime_params.hpp"
#include "support/one_cpu.hpp"

namespace dco::pipeline::runtime {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;

TEST(Histogram, PercentilesOfAUniformSpreadAreWithinOneBucket) {
  Histogram h;
  for (int i = 1; i <= 1000; ++i) h.record(i * 0.05);  // 0.05 .. 50 ms
  EXPECT_EQ(h.count(), 1000);
  EXPECT_NEAR(h.percentile(50), 25.0, Histogram::kLinearStepMs);
  EXPECT_NEAR(h.percentile(99), 49.5, Histogram::kLinearStepMs);
  EXPECT_DOUBLE_EQ(h.percentile(100), 50.0);
  EXPECT_NEAR(h.percentile(0), 0.05, Histogram::kLinearStepMs);
  EXPECT_NEAR(h.mean_ms(), 25.025, 1e-9);
  EXPECT_DOUBLE_EQ(h.max_ms(), 50.0);
}

TEST(Histogram, ATailShowsInP99ButNotInP50) {
  Histogram h;
  for (int i = 0; i < 980; ++i) h.record(20.0);
  for (int i = 0; i < 20; ++i) h.record(300.0);
  EXPECT_NEAR(h.percentile(50), 20.0, Histogram::kLinearStepMs);
  EXPECT_NEAR(h.percentile(98), 20.0, Histogram::kLinearStepMs);
  // Beyond 100 ms buckets are 0.5 % wide.
  EXPECT_NEAR(h.percentile(99), 300.0, 300.0 * (Histogram::kGrowth - 1));
}

TEST(Histogram, LongDurationsKeepARelativeResolutionAndOverflowToTheMaximum) {
  Histogram h;
  h.record(1234.5);
  EXPECT_DOUBLE_EQ(h.percentile(50), 1234.5);  // one value: kept within [min, max]
  h.record(1.0e6);                             // beyond the last bucket
  EXPECT_DOUBLE_EQ(h.percentile(100), 1.0e6);
  EXPECT_EQ(Histogram::bucket_of(1.0e6), Histogram::bucket_count() - 1);
  EXPECT_EQ(Histogram::bucket_of(INFINITY), Histogram::bucket_count() - 1);
  for (double ms : {0.01, 0.5, 99.99, 100.0, 150.0, 5000.0, 59000.0}) {
    const int b = Histogram::bucket_of(ms);
    EXPECT_LE(Histogram::bucket_low(b), ms) << ms;
    EXPECT_GT(Histogram::bucket_high(b), ms) << ms;
    EXPECT_LE(Histogram::bucket_high(b) - Histogram::bucket_low(b),
              std::max(Histogram::kLinearStepMs, ms * (Histogram::kGrowth - 1)) * 1.0001)
        << ms;
  }
}

TEST(Histogram, EmptyAndClearedReportZero) {
  Histogram h;
  EXPECT_EQ(h.percentile(50), 0.0);
  h.record(-3.0);  // a clock step backwards counts as 0
  EXPECT_EQ(h.percentile(50), 0.0);
  EXPECT_EQ(h.count(), 1);
  h.record(7.0);
  h.clear();
  EXPECT_EQ(h.count(), 0);
  EXPECT_EQ(h.percentile(99), 0.0);
  EXPECT_EQ(h.max_ms(), 0.0);
}

TEST(BoundedQueue, KeepsOrderAndRefusesToGrow) {
  BoundedQueue<int> q(2);
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_TRUE(q.full());
  EXPECT_FALSE(q.push(3));
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.front(), 1);  // looks without taking
  EXPECT_EQ(q.pop(), 1);
  EXPECT_TRUE(q.push(4));
  EXPECT_EQ(q.front(), 2);
  EXPECT_EQ(q.pop(), 2);
  EXPECT_EQ(q.pop(), 4);
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.high_water(), 2u);
  EXPECT_EQ(q.capacity(), 2u);
}

TEST(FrameInterval, IsTheMedianOfTheLastCaptureIntervals) {
  using Clock = FrameInterval::Clock;
  FrameInterval f;
  const Clock::time_point t0 = Clock::now();
  EXPECT_EQ(f.ms(), 0.0);
  f.add(t0);
  EXPECT_EQ(f.ms(), 0.0);  // one frame: no interval yet
  f.add(t0 + 20ms);
  EXPECT_DOUBLE_EQ(f.ms(), 20.0);
  // A camera at 50 fps that lost a frame now and then, and one late delivery.
  Clock::time_point t = t0 + 20ms;
  for (const auto gap : {20ms, 40ms, 20ms, 20ms, 35ms, 20ms, 40ms, 20ms}) f.add(t += gap);
  EXPECT_DOUBLE_EQ(f.ms(), 20.0);
  // Only the last kSamples count: the camera changed to 30 fps.
  for (std::size_t i = 0; i < FrameInterval::kSamples / 2 + 1; ++i) f.add(t += 33ms);
  EXPECT_DOUBLE_EQ(f.ms(), 33.0);
}

TEST(FrameInterval, IgnoresRepeatedAndBackwardTimesAndPauses) {
  using Clock = FrameInterval::Clock;
  FrameInterval f;
  Clock::time_point t = Clock::now();
  f.add(t);
  f.add(t);           // the same timestamp twice
  f.add(t - 10ms);    // a clock that went back
  f.add(t += 990ms);  // measured from the last time given: 1000 ms, a pause
  EXPECT_EQ(f.ms(), 0.0);
  f.add(t += 25ms);
  EXPECT_DOUBLE_EQ(f.ms(), 25.0);
  f.clear();
  EXPECT_EQ(f.ms(), 0.0);
  f.add(t += 5s);  // the first time of a new sequence: no interval from the old one
  EXPECT_EQ(f.ms(), 0.0);
  f.add(t += 16ms);
  EXPECT_DOUBLE_EQ(f.ms(), 16.0);
}

// Two waits of 1.5 ms since a frame came (a slot, then room in a queue) hold it up 3 ms, past a
// 2 ms deadline; waits before it came and after now do not count, one still going counts to now.
TEST(EntryDeadline, HoldUpsAddEveryWaitSinceTheFrameCame) {
  using Clock = HoldUps::Clock;
  using std::chrono::microseconds;
  const Clock::time_point t0{};
  const auto at = [&](int us) { return t0 + microseconds(us); };
  HoldUps h;
  EXPECT_EQ(h.ms_within(at(0), at(10'000)), 0.0);
  h.begin(at(0));
  h.end(at(2'000));  // before the frame came at 1 ms: 1 ms of it counts
  h.begin(at(3'000));
  h.end(at(4'500));
  h.begin(at(5'000));
  h.end(at(6'500));
  EXPECT_DOUBLE_EQ(h.ms_within(at(1'000), at(7'000)), 4.0);
  EXPECT_DOUBLE_EQ(h.ms_within(at(2'500), at(6'000)), 2.5);
  EXPECT_TRUE(late_at_entry(5.0, h.ms_within(at(2'500), at(7'500)), 2.0, 0.4, 16.7));
  h.begin(at(8'000));  // still waiting
  EXPECT_DOUBLE_EQ(h.ms_within(at(7'000), at(9'000)), 1.0);
  // Only the last kKept waits are kept: older ones have long ended.
  for (int i = 0; i < static_cast<int>(HoldUps::kKept); ++i) {
    h.begin(at(10'000 + i * 1'000));
    h.end(at(10'500 + i * 1'000));
  }
  EXPECT_DOUBLE_EQ(h.ms_within(at(0), at(100'000)), 0.5 * static_cast<double>(HoldUps::kKept));
  h.clear();
  EXPECT_EQ(h.ms_within(at(0), at(100'000)), 0.0);
}

TEST(EntryDeadline, AFrameIsLateBeyondTheFixedDeadlineOnlyPastItsShareOrWhenHeldUp) {
  // 30 fps, deadline 2 ms, share 0.4: 13.3 ms.
  EXPECT_FALSE(late_at_entry(1.9, 0.0, 2.0, 0.4, 33.3));
  EXPECT_FALSE(late_at_entry(5.0, 0.0, 2.0, 0.4, 33.3));  // waited for the stereo stage's work
  EXPECT_FALSE(late_at_entry(13.0, 1.5, 2.0, 0.4, 33.3));
  EXPECT_TRUE(late_at_entry(14.0, 0.0, 2.0, 0.4, 33.3));
  EXPECT_TRUE(late_at_entry(5.0, 3.0, 2.0, 0.4, 33.3));  // held up by the later stages
  EXPECT_TRUE(late_at_entry(5.0, 0.0, 2.0, 0.0, 33.3));  // no share: the fixed deadline alone
  EXPECT_TRUE(late_at_entry(5.0, 0.0, 2.0, 0.4, 0.0));   // no interval known yet
  EXPECT_FALSE(late_at_entry(2.0, 2.0, 2.0, 0.0, 33.3));
  EXPECT_FALSE(late_at_entry(1000.0, 1000.0, 0.0, 0.4, 33.3));  // no deadline at all
}

TEST(RuntimeParams, AreSetThroughTheSchema) {
  RuntimeParams p;
  ConfigSchema schema;
  register_params(schema, p);
  schema.load_string(
      "[runtime]\nthreads = 3\naffinity = \"0, 1\"\nqueue_depth = 2\ndeterministic = true\n"
      "entry_deadline_ms = 4.5\nentry_deadline_share = 0.25\nrelease_latency_ms = 120\n",
      "test");
  EXPECT_EQ(p.threads, 3);
  EXPECT_EQ(p.affinity, "0, 1");
  EXPECT_EQ(p.queue_depth, 2);
  EXPECT_TRUE(p.deterministic);
  EXPECT_EQ(p.entry_deadline_ms, 4.5);
  EXPECT_EQ(p.entry_deadline_share, 0.25);
  EXPECT_EQ(p.release_latency_ms, 120);
  EXPECT_NO_THROW(validate(p));
  EXPECT_EQ(parse_affinity(p.affinity), (std::vector<int>{0, 1}));
  EXPECT_THAT(schema.describe(), HasSubstr("runtime.affinity"));
}

TEST(RuntimeParams, OutOfRangeValuesAreRejected) {
  RuntimeParams p;
  ConfigSchema schema;
  register_params(schema, p);
  EXPECT_THROW(schema.set("runtime.threads=-1"), Error);
  EXPECT_THROW(schema.set("runtime.threads=4"), Error);
  EXPECT_THROW(schema.set("runtime.queue_depth=0"), Error);
  EXPECT_THROW(schema.set("runtime.deterministic=maybe"), Error);
  EXPECT_THROW(schema.set("runtime.entry_deadline_ms=-1"), Error);
  EXPECT_THROW(schema.set("runtime.entry_deadline_ms=1001"), Error);
  EXPECT_THROW(schema.set("runtime.entry_deadline_share=-0.1"), Error);
  EXPECT_THROW(schema.set("runtime.entry_deadline_share=1.5"), Error);
  EXPECT_THROW(schema.set("runtime.release_latency_ms=-5"), Error);
  EXPECT_THROW(schema.set("runtime.release_latency_ms=1000.5"), Error);
  EXPECT_THROW(schema.set("runtime.opencv_threads=-1"), Error);
  EXPECT_THROW(schema.set("runtime.opencv_threads=257"), Error);
  EXPECT_THROW(schema.set("runtime.release_priority=-1"), Error);
  EXPECT_THROW(schema.set("runtime.release_priority=100"), Error);
  EXPECT_NO_THROW(schema.set("runtime.release_priority=99"));
  RuntimeParams direct;
  direct.threads = 7;
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.queue_depth = 100;
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.entry_deadline_ms = -0.5;
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.entry_deadline_share = std::nan("");
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.release_latency_ms = 2000;
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.opencv_threads = -2;
  EXPECT_THROW(validate(direct), Error);
  direct = {};
  direct.release_priority = 120;
  EXPECT_THROW(validate(direct), Error);
}

TEST(OpenCvThreads, AutoTakesOneThreadWhereTheStageThreadsFillTheCpus) {
  EXPECT_EQ(opencv_threads_for(0, 2, 2), 1);
  EXPECT_EQ(opencv_threads_for(0, 3, 2), 1);
  EXPECT_EQ(opencv_threads_for(0, 1, 1), 1);
  EXPECT_EQ(opencv_threads_for(0, 2, 3), 0);  // a CPU left over: OpenCV's own choice
  EXPECT_EQ(opencv_threads_for(0, 3, 8), 0);
  EXPECT_EQ(opencv_threads_for(3, 2, 2), 3);  // an explicit count is kept
  EXPECT_EQ(opencv_threads_for(1, 2, 16), 1);
}

TEST(OpenCvThreads, EachLeaseSetsItsCountAndTheLastOneGivesTheFirstOneBack) {
  const int original = cv::getNumThreads();
  cv::setNumThreads(3);
  {
    const OpenCvThreadsLease outer(1);
    EXPECT_EQ(cv::getNumThreads(), 1);
    {
      const OpenCvThreadsLease inner(2);
      EXPECT_EQ(cv::getNumThreads(), 2);
    }
    EXPECT_EQ(cv::getNumThreads(), 2);  // the outer lease still lives
  }
  EXPECT_EQ(cv::getNumThreads(), 3);
  {
    const OpenCvThreadsLease again(1);  // a new first lease takes the count as it is now
    cv::setNumThreads(5);
  }
  EXPECT_EQ(cv::getNumThreads(), 3);
  cv::setNumThreads(original);
}

// OpenCV rebuilds its pool on every cv::setNumThreads, and a loop running meanwhile on another
// thread crashes: a lease for the count in effect, and any lease under a pin, must not set it.
class OpenCvLoopElsewhere {
 public:
  OpenCvLoopElsewhere()
      : thread_([this] {
          while (!stop_) {
            cv::parallel_for_(cv::Range(0, 64), [&](const cv::Range& r) {
              for (int i = r.start; i < r.end; ++i) sums_[static_cast<std::size_t>(i)] += i;
            });
            ++loops_;
          }
        }) {
    while (loops_ == 0) std::this_thread::yield();
  }
  ~OpenCvLoopElsewhere() {
    stop_ = true;
    thread_.join();
  }
  long loops() const { return loops_; }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<long> loops_{0};
  std::vector<long> sums_ = std::vector<long>(64);
  std::thread thread_;
};

TEST(OpenCvThreads, ALeaseForTheCountInEffectLeavesALoopElsewhereRunning) {
  const int original = cv::getNumThreads();
  {
    const OpenCvThreadsLease outer(2);
    const OpenCvLoopElsewhere loop;
    for (int i = 0; i < 50000; ++i) const OpenCvThreadsLease again(2);  // a runtime restarting
    EXPECT_EQ(cv::getNumThreads(), 2);
    EXPECT_GT(loop.loops(), 0);
  }
  EXPECT_EQ(cv::getNumThreads(), original);
}

TEST(OpenCvThreads, APinKeepsItsCountThroughLeasesWhileALoopRunsElsewhere) {
  const int original = cv::getNumThreads();
  {
    const OpenCvThreadsPin pin(1);
    EXPECT_EQ(pin.threads(), 1);
    EXPECT_EQ(cv::getNumThreads(), 1);
    const OpenCvLoopElsewhere loop;
    for (int i = 0; i < 20000; ++i) const OpenCvThreadsLease other(1 + i % 3);
    EXPECT_EQ(cv::getNumThreads(), 1);
  }
  EXPECT_EQ(cv::getNumThreads(), original);
  {
    const OpenCvThreadsPin as_it_is(0);  // OpenCV's own count, kept
    EXPECT_EQ(as_it_is.threads(), original);
    const OpenCvThreadsLease ignored(original + 1);
    EXPECT_EQ(cv::getNumThreads(), original);
  }
}

TEST(RuntimeParams, ZeroThreadsGiveAThirdThreadWhereCpusAreFree) {
  RuntimeParams p;
  EXPECT_EQ(p.threads, 0);
  EXPECT_NO_THROW(validate(p));
  EXPECT_EQ(stage_threads(p), usable_cpus() >= 4 ? 3 : 2);
  for (int n : {1, 2, 3}) {
    p.threads = n;
    EXPECT_EQ(stage_threads(p), n);  // an explicit count is kept
  }
  // The CPUs this thread may use count, not the machine's: kept to one, the stages get 2.
  p.threads = 0;
  const testing::OneCpu one;
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(stage_threads(p), 2);
}

TEST(RuntimeParams, BadAffinityListsNameTheEntry) {
  const auto message = [](const std::string& text) {
    try {
      parse_affinity(text);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(message("0,x"), HasSubstr("'x'"));
  EXPECT_THAT(message("-1"), HasSubstr("'-1'"));
  EXPECT_THAT(message("1,1"), HasSubstr("listed twice"));
  EXPECT_THAT(message("0,"), HasSubstr("ends with a comma"));
  EXPECT_THAT(message("5000"), HasSubstr("beyond"));
  EXPECT_EQ(message(""), "accepted");
  RuntimeParams p;
  p.affinity = "0;1";
  EXPECT_THROW(validate(p), Error);
}

}  // namespace
}  // namespace dco::pipeline::runtime
