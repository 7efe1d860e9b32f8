#pragma once

namespace dco::pipeline::runtime {

// OpenCV runs its own parallel loops (DIS optical flow, the synthetic scene's rows, colour
// conversions) on a pool of its threads. When the stage threads already keep every usable CPU
// busy, that pool only takes turns with them: a stage waits for a part of its loop that waits for
// a CPU. While a lease lives, OpenCV uses `threads` threads (cv::setNumThreads). The setting is
// process-wide: each lease sets its count, and when the last lease ends OpenCV gets back the count
// it had before the first.
//
// OpenCV rebuilds its pool on every cv::setNumThreads, and a loop running meanwhile on another
// thread crashes (its TBB arena is torn down under it). So a count is set only when it changes,
// and a process whose other threads use OpenCV while runtimes stop and start (dcod: the source
// renders or decodes frames through a reload) fixes the count with a pin before they run.
class OpenCvThreadsLease {
 public:
  explicit OpenCvThreadsLease(int threads);
  ~OpenCvThreadsLease();
  OpenCvThreadsLease(const OpenCvThreadsLease&) = delete;
  OpenCvThreadsLease& operator=(const OpenCvThreadsLease&) = delete;
};

// While a pin lives, OpenCV uses `threads` threads (0: the count it has now) and leases change
// nothing; when the last pin and lease end, OpenCV gets back its count from before them. Make or
// end one only while no other thread runs an OpenCV loop.
class OpenCvThreadsPin {
 public:
  explicit OpenCvThreadsPin(int threads);
  ~OpenCvThreadsPin();
  OpenCvThreadsPin(const OpenCvThreadsPin&) = delete;
  OpenCvThreadsPin& operator=(const OpenCvThreadsPin&) = delete;

  int threads() const { return threads_; }  // the count pinned

 private:
  int threads_ = 0;
};

// runtime.opencv_threads as it will run: an explicit count as it is; 0 (auto) gives 1 when the
// runtime's stage threads are at least as many as the usable CPUs, else 0 (OpenCV's own choice,
// no lease).
int opencv_threads_for(int opencv_threads, int stage_threads, int usable_cpus);

}  // namespace dco::pipeline::runtime
