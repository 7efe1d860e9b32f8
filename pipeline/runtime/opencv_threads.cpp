#include "dco/pipeline/runtime/opencv_threads.hpp"

#include <mutex>

#include <opencv2/core/utility.hpp>

namespace dco::pipeline::runtime {
namespace {

struct Holders {
  std::mutex mutex;
  int count = 0;  // leases and pins
  int pins = 0;
  int before = 0;   // OpenCV's count before the first holder
  int current = 0;  // OpenCV's count while there are holders

  void take() {
    if (count++ == 0) before = current = cv::getNumThreads();
  }
  void give_back() {
    if (--count == 0) set(before);
  }
  void set(int threads) {
    if (threads == current) return;  // a rebuilt pool would crash a loop running elsewhere
    cv::setNumThreads(threads);
    current = threads;
  }
};

Holders& holders() {
  static Holders h;
  return h;
}

}  // namespace

OpenCvThreadsLease::OpenCvThreadsLease(int threads) {
  Holders& h = holders();
  const std::lock_guard lock(h.mutex);
  h.take();
  if (h.pins == 0) h.set(threads);
}

OpenCvThreadsLease::~OpenCvThreadsLease() {
  Holders& h = holders();
  const std::lock_guard lock(h.mutex);
  h.give_back();
}

OpenCvThreadsPin::OpenCvThreadsPin(int threads) {
  Holders& h = holders();
  const std::lock_guard lock(h.mutex);
  h.take();
  if (threads > 0) h.set(threads);
  ++h.pins;
  threads_ = h.current;
}

OpenCvThreadsPin::~OpenCvThreadsPin() {
  Holders& h = holders();
  const std::lock_guard lock(h.mutex);
  --h.pins;
  h.give_back();
}

int opencv_threads_for(int opencv_threads, int stage_threads, int usable_cpus) {
  if (opencv_threads > 0) return opencv_threads;
  return stage_threads >= usable_cpus ? 1 : 0;
}

}  // namespace dco::pipeline::runtime
