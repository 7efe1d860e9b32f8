#pragma once

#include <condition_variable>
#include <exception>
#include <mutex>
#include <stop_token>
#include <thread>
#include <utility>

#include <opencv2/video/tracking.hpp>

#include "dco/core/thread_name.hpp"

namespace dco::contour {

// One DIS flow field computed on a thread of its own while the caller computes the other: the
// thread is started once and waits between frames, so a frame costs no thread start and no
// allocation. The DIS instance is the worker's alone (DIS keeps per-call state).
class FlowFieldWorker {
 public:
  explicit FlowFieldWorker(cv::Ptr<cv::DISOpticalFlow> dis)
      : dis_(std::move(dis)), thread_([this](std::stop_token stop) {
          name_this_thread("dco-flow");
          loop(stop);
        }) {}
  FlowFieldWorker(const FlowFieldWorker&) = delete;
  FlowFieldWorker& operator=(const FlowFieldWorker&) = delete;

  // Starts flow = DIS(from -> to). The three must stay alive and untouched until wait() returns.
  void start(const cv::Mat& from, const cv::Mat& to, cv::Mat& flow) {
    {
      std::lock_guard lock(mutex_);
      from_ = &from;
      to_ = &to;
      flow_ = &flow;
      pending_ = true;
    }
    wake_.notify_one();
  }

  // Waits for the field started last; rethrows what computing it threw.
  void wait() {
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return !pending_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  void loop(std::stop_token stop) {
    std::unique_lock lock(mutex_);
    while (wake_.wait(lock, stop, [this] { return pending_; })) {
      lock.unlock();
      std::exception_ptr error;
      try {
        dis_->calc(*from_, *to_, *flow_);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      error_ = error;
      pending_ = false;
      done_.notify_all();
    }
  }

  cv::Ptr<cv::DISOpticalFlow> dis_;
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::condition_variable done_;
  const cv::Mat* from_ = nullptr;
  const cv::Mat* to_ = nullptr;
  cv::Mat* flow_ = nullptr;
  bool pending_ = false;
  std::exception_ptr error_;
  std::jthread thread_;  // last: started after the members above exist, joined before they go
};

}  // namespace dco::contour
