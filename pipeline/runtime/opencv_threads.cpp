#include "dco/pipeline/runtime/opencv_threads.hpp"

#include <mutex>

#include <opencv2/core/utility.hpp>

namespace dco::pipeline::runtime {
namespace {

struct Leases {
  std::mutex mutex;
  int count = 0;
  int before = 0;  // OpenCV's count before the first lease
};

Leases& leases() {
  static Leases l;
  return l;
}

}  // namespace

OpenCvThreadsLease::OpenCvThreadsLease(int threads) {
  Leases& l = leases();
  const std::lock_guard lock(l.mutex);
  if (l.count++ == 0) l.before = cv::getNumThreads();
  cv::setNumThreads(threads);
}

OpenCvThreadsLease::~OpenCvThreadsLease() {
  Leases& l = leases();
  const std::lock_guard lock(l.mutex);
  if (--l.count == 0) cv::setNumThreads(l.before);
}

int opencv_threads_for(int opencv_threads, int stage_threads, int usable_cpus) {
  if (opencv_threads > 0) return opencv_threads;
  return stage_threads >= usable_cpus ? 1 : 0;
}

}  // namespace dco::pipeline::runtime
