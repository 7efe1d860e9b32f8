#include "dco/pipeline/contour/flow_field_worker.hpp"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace dco::contour {
namespace {

cv::Mat textured(int w, int h, int shift) {
  cv::Mat t(h, w + 16, CV_8U);
  cv::RNG rng(7);
  rng.fill(t, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(t, t, {0, 0}, 2.0);
  return t(cv::Rect(8 + shift, 0, w, h)).clone();
}

cv::Ptr<cv::DISOpticalFlow> fast_dis() {
  return cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// The worker's field is the one its own DIS computes on the calling thread, frame after frame.
TEST(FlowFieldWorker, GivesTheFieldOfACallOnTheCallingThread) {
  const cv::Mat a = textured(160, 96, 0), b = textured(160, 96, 3), c = textured(160, 96, -2);
  const auto reference = fast_dis();
  FlowFieldWorker worker(fast_dis());
  for (const cv::Mat* to : {&b, &c, &b}) {
    cv::Mat expected = cv::Mat::zeros(a.size(), CV_32FC2), actual = expected.clone();
    reference->calc(a, *to, expected);
    worker.start(a, *to, actual);
    worker.wait();
    EXPECT_TRUE(same(actual, expected));
  }
}

// What the worker's DIS throws reaches wait(), once, and the worker takes the next field.
TEST(FlowFieldWorker, AnErrorReachesWaitAndTheWorkerGoesOn) {
  const cv::Mat a = textured(160, 96, 0), b = textured(160, 96, 3);
  const cv::Mat smaller = textured(80, 48, 0);  // DIS refuses frames of different sizes
  FlowFieldWorker worker(fast_dis());
  cv::Mat flow = cv::Mat::zeros(a.size(), CV_32FC2);
  worker.start(a, smaller, flow);
  EXPECT_THROW(worker.wait(), cv::Exception);
  EXPECT_NO_THROW(worker.wait());  // nothing pending, nothing left to report

  cv::Mat expected = cv::Mat::zeros(a.size(), CV_32FC2);
  fast_dis()->calc(a, b, expected);
  flow = cv::Mat::zeros(a.size(), CV_32FC2);
  worker.start(a, b, flow);
  EXPECT_NO_THROW(worker.wait());
  EXPECT_TRUE(same(flow, expected));
}

// Destroyed while idle or right after a field: the thread is joined, nothing hangs.
TEST(FlowFieldWorker, StopsWhenDestroyed) {
  { FlowFieldWorker idle(fast_dis()); }
  const cv::Mat a = textured(160, 96, 0), b = textured(160, 96, 3);
  cv::Mat flow = cv::Mat::zeros(a.size(), CV_32FC2);
  FlowFieldWorker worker(fast_dis());
  worker.start(a, b, flow);
  worker.wait();
  SUCCEED();
}

}  // namespace
}  // namespace dco::contour
