// Heap use of the contour extractor once its buffers are sized. This binary counts every C-level
// allocation (malloc, calloc, realloc, aligned_alloc, posix_memalign, memalign), which catches
// operator new, dco::Image and cv::Mat alike; it is a binary of its own because
// dco_pipeline_tests already replaces operator new for its own counting.

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/image.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"

namespace {

std::atomic<bool> g_counting{false};
std::atomic<long> g_calls{0};

}  // namespace

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kCounting = false;  // the sanitizer runtime owns the allocator
#else
constexpr bool kCounting = true;
namespace {

void count() {
  if (g_counting.load(std::memory_order_relaxed)) g_calls.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) noexcept {
  count();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) noexcept {
  count();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) noexcept {
  count();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t alignment, std::size_t n) noexcept {
  count();
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) noexcept {
  count();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) noexcept {
  count();
  void* p = __libc_memalign(alignment, n);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}
#endif

namespace dco::contour {
namespace {

// Allocations made while `f` runs.
template <typename F>
long allocations_during(F&& f) {
  g_calls = 0;
  g_counting = true;
  f();
  g_counting = false;
  return g_calls.load();
}

struct Scene {
  cv::Mat input, past, centre, future;
  std::array<cv::Mat, 5> shifted;  // internal frames of a pan: frame k is k px further
  Image<float> disparity;
  explicit Scene(int w, int h) {
    cv::Mat big(h, w + 8, CV_8U);
    cv::RNG(5).fill(big, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(big, big, {0, 0}, 1.5);
    input = big(cv::Rect(4, 0, w, h)).clone();
    cv::Mat half;
    cv::resize(big, half, {(w + 8) / 2, h / 2}, 0, 0, cv::INTER_AREA);
    past = half(cv::Rect(1, 0, w / 2, h / 2)).clone();
    centre = half(cv::Rect(2, 0, w / 2, h / 2)).clone();
    future = half(cv::Rect(3, 0, w / 2, h / 2)).clone();
    for (int k = 0; k < 5; ++k) shifted[k] = half(cv::Rect(k, 0, w / 2, h / 2)).clone();
    disparity.resize(w / 2, h / 2);
    for (int y = 0; y < h / 2; ++y)
      for (int x = 0; x < w / 2; ++x) disparity.at(x, y) = x < w / 4 ? 4.0f : 12.0f;
  }
  ContourInputs inputs() const {
    ContourInputs in;
    in.image = as_view<std::uint8_t>(input);
    in.centre = as_view<std::uint8_t>(centre);
    in.neighbour_a = as_view<std::uint8_t>(past);
    in.neighbour_b = as_view<std::uint8_t>(future);
    in.disparity = disparity.view();
    return in;
  }
  // The window centred on shifted frame k + 1: each follows the last, so the flow is reused.
  ContourInputs window(int k) const {
    ContourInputs in = inputs();
    in.neighbour_a = as_view<std::uint8_t>(shifted[k]);
    in.centre = as_view<std::uint8_t>(shifted[k + 1]);
    in.neighbour_b = as_view<std::uint8_t>(shifted[k + 2]);
    return in;
  }
  // The causal window (lookahead 0) ending at frame k + 2.
  ContourInputs causal_window(int k) const {
    ContourInputs in = inputs();
    in.centre = as_view<std::uint8_t>(shifted[k + 2]);
    in.neighbour_a = as_view<std::uint8_t>(shifted[k + 1]);
    in.neighbour_b = as_view<std::uint8_t>(shifted[k]);
    return in;
  }
};

class ContourAllocations : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    if (!kCounting) GTEST_SKIP() << "allocations are not counted under a sanitizer";
    threads_ = cv::getNumThreads();
    cv::setNumThreads(GetParam());
  }
  void TearDown() override {
    if (kCounting) cv::setNumThreads(threads_);
  }
  int threads_ = 0;
};

TEST_P(ContourAllocations, CountingSeesEveryAllocator) {
  EXPECT_GT(allocations_during([] { std::vector<int> v(100); }), 0);
  EXPECT_GT(allocations_during([] { Image<float> img(64, 64); }), 0);
  EXPECT_GT(allocations_during([] { cv::Mat m(64, 64, CV_32F); }), 0);
}

// Everything the extractor does itself (stereo cue, box filter, blur, gradient, gated Canny) is
// allocation-free from the second frame on.
TEST_P(ContourAllocations, NoneWithoutFlowAfterTheFirstFrame) {
  const Scene scene(320, 240);
  ContourParams params;
  params.use_flow = false;
  const auto extractor = make_cpu_contour_extractor(params);
  ContourOutputs out;
  EXPECT_GT(allocations_during([&] { extractor->compute(scene.inputs(), out); }), 0);
  EXPECT_EQ(allocations_during([&] { extractor->compute(scene.inputs(), out); }), 0);
}

// With flow, the only allocations left are those cv::DISOpticalFlow::calc makes internally on
// every call (it has no way to keep them): the extractor allocates exactly what two bare DIS calls
// on the same frames allocate.
// On one thread: TBB's worker threads allocate on their own schedule, so with several threads
// the two counts differ from run to run.
class ContourAllocationsOneThread : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!kCounting) GTEST_SKIP() << "allocations are not counted under a sanitizer";
    threads_ = cv::getNumThreads();
    cv::setNumThreads(1);
  }
  void TearDown() override {
    if (kCounting) cv::setNumThreads(threads_);
  }
  int threads_ = 0;
};

TEST_F(ContourAllocationsOneThread, WithFlowOnlyInsideDis) {
  const Scene scene(320, 240);
  const auto extractor = make_cpu_contour_extractor({});
  ContourOutputs out;
  extractor->compute(scene.inputs(), out);
  extractor->compute(scene.inputs(), out);
  const long ours = allocations_during([&] { extractor->compute(scene.inputs(), out); });

  const cv::Ptr<cv::DISOpticalFlow> dis =
      cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
  cv::Mat flow_a(scene.centre.size(), CV_32FC2), flow_b(scene.centre.size(), CV_32FC2);
  auto both = [&] {
    dis->calc(scene.centre, scene.past, flow_a);
    dis->calc(scene.centre, scene.future, flow_b);
  };
  both();
  both();
  const long dis_only = allocations_during(both);
  std::printf("%ld allocations per compute() with flow, %ld in two bare DIS calls\n", ours,
              dis_only);
  EXPECT_EQ(ours, dis_only);
}

// A window that follows the last runs DIS once and turns the kept field round in place.
// `ours`, the allocations of a compute() that ran DIS once, are those of one bare DIS call.
void expect_one_dis_calls_allocations(const Scene& scene, long ours, int lookahead) {
  const cv::Ptr<cv::DISOpticalFlow> dis =
      cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
  cv::Mat flow(scene.centre.size(), CV_32FC2);
  auto one = [&] { dis->calc(scene.shifted[3], scene.shifted[4], flow); };
  one();
  one();
  const long dis_only = allocations_during(one);
  std::printf(
      "lookahead %d: %ld allocations per compute() with a reused field, %ld in one bare DIS "
      "call\n",
      lookahead, ours, dis_only);
  EXPECT_EQ(ours, dis_only) << "lookahead " << lookahead;
}

// With either window (the field turned round with lookahead 1, carried on with lookahead 0).
TEST_F(ContourAllocationsOneThread, WithAReusedFieldOnlyInsideOneDisCall) {
  const Scene scene(320, 240);
  for (const int lookahead : {1, 0}) {
    ContourParams params;
    params.lookahead = lookahead;
    const auto extractor = make_cpu_contour_extractor(params);
    const auto window = [&](int k) {
      return lookahead == 1 ? scene.window(k) : scene.causal_window(k);
    };
    ContourOutputs out;
    extractor->compute(window(0), out);
    extractor->compute(window(1), out);
    const long ours = allocations_during([&] { extractor->compute(window(2), out); });
    ASSERT_EQ(extractor->last_timings().dis_fields, 1);
    expect_one_dis_calls_allocations(scene, ours, lookahead);
  }
}

INSTANTIATE_TEST_SUITE_P(Threads, ContourAllocations, ::testing::Values(1, 4));

}  // namespace
}  // namespace dco::contour
