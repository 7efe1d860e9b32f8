#pragma once

namespace dco::pipeline::runtime {

// OpenCV runs its own parallel loops (DIS optical flow) on a pool of its threads. When
// the stage threads already keep every usable CPU busy, that pool only takes turns with them: a
// stage waits for a part of its loop that waits for a CPU. While a lease lives, OpenCV uses
// `threads` threads (cv::setNumThreads). The setting is process-wide: each lease sets its count,
// and when the last lease ends OpenCV gets back the count it had before the first.
class OpenCvThreadsLease {
 public:
  explicit OpenCvThreadsLease(int threads);
  ~OpenCvThreadsLease();
  OpenCvThreadsLease(const OpenCvThreadsLease&) = delete;
  OpenCvThreadsLease& operator=(const OpenCvThreadsLease&) = delete;
};

// runtime.opencv_threads as it will run: an explicit count as it is; 0 (auto) gives 1 when the
// runtime's stage threads are at least as many as the usable CPUs, else 0 (OpenCV's own choice,
// no lease).
int opencv_threads_for(int opencv_threads, int stage_threads, int usable_cpus);

}  // namespace dco::pipeline::runtime
