#include "dco/daemon/raw_recorder.hpp"

#include <algorithm>
#include <cstring>
#include <exception>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"

namespace dco::daemon {
namespace {

void copy_into(const ImageView<const std::uint8_t>& from, Image<std::uint8_t>& to) {
  to.resize(from.width, from.height, from.channels);
  const auto bytes = static_cast<std::size_t>(from.width) * static_cast<std::size_t>(from.channels);
  for (int y = 0; y < from.height; ++y) std::memcpy(to.row(y), from.row(y), bytes);
}

}  // namespace

RawRecorder::RawRecorder(std::string calibration_toml, RawRecorderOptions options, Send send,
                         CanSend can_send)
    : calibration_toml_(std::move(calibration_toml)),
      options_(options),
      send_(std::move(send)),
      can_send_(std::move(can_send)),
      encoder_(options.png_level),
      thread_([this] {
        name_this_thread("dco-recorder");
        run();
      }) {
  std::lock_guard lock(mutex_);  // the thread reads the message under it
  message_.pipeline_config = options_.pipeline_config;
}

RawRecorder::~RawRecorder() {
  close();
}

RawRecorder::Counts RawRecorder::close() {
  {
    std::lock_guard lock(mutex_);
    closing_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
  return counts();
}

void RawRecorder::offer(const drivers::StereoFrame& frame) {
  std::size_t index = 0;
  {
    std::unique_lock lock(mutex_);
    if (queued_ == slots_.size()) {
      if (!options_.never_drop) {
        ++counts_.dropped;
        return;
      }
      changed_.wait(lock, [&] { return queued_ < slots_.size() || closing_; });
      if (closing_) return;
    }
    index = (head_ + queued_) % slots_.size();
  }
  // The slot past the queue is the source's alone until it is queued.
  Slot& slot = slots_[index];
  copy_into(frame.left, slot.left);
  copy_into(frame.right, slot.right);
  slot.imu.assign(frame.imu.begin(), frame.imu.end());
  slot.seq = frame.seq;
  slot.capture_ns = frame.capture_ns;
  {
    std::lock_guard lock(mutex_);
    ++queued_;
  }
  changed_.notify_all();
}

void RawRecorder::run() {
  for (;;) {
    std::size_t index = 0;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return queued_ > 0 || closing_; });
      if (queued_ == 0) return;  // closing, and everything was sent
      index = head_;
    }
    const Slot& slot = slots_[index];
    drivers::StereoFrame frame;
    frame.seq = slot.seq;
    frame.capture_ns = slot.capture_ns;
    frame.left = slot.left.cview();
    frame.right = slot.right.cview();
    frame.imu = slot.imu;
    enum { kSent, kHeld, kOversized, kFailed } outcome = kSent;
    std::string error;
    try {
      if (can_send_ && !can_send_())
        throw Error(fmt::format(
            "raw frame {} not compressed: LCM is not set up, or its network holds a send",
            slot.seq));
      encoder_.encode(frame, calibration_toml_, message_);
      if (static_cast<std::size_t>(message_.getEncodedSize()) > options_.max_message_bytes) {
        outcome = kOversized;
        error = fmt::format(
            "raw frame {} compresses to {} bytes, more than raw.max_message_bytes "
            "({}): not recorded",
            slot.seq, message_.getEncodedSize(), options_.max_message_bytes);
      } else if (!send_(message_)) {
        outcome = kHeld;
        error = fmt::format(
            "raw frame {} still in its send after LCM's wait: the network holds it (it goes out "
            "if the network takes it)",
            slot.seq);
      }
    } catch (const std::exception& e) {
      outcome = kFailed;
      error = e.what();
    }
    {
      std::lock_guard lock(mutex_);
      head_ = (head_ + 1) % slots_.size();
      --queued_;
      if (outcome == kSent) ++counts_.recorded;
      if (outcome == kOversized) ++counts_.oversized;
      if (outcome == kFailed) ++counts_.failed;
      if (outcome == kHeld) ++counts_.held;
      if (!error.empty()) last_error_ = std::move(error);
    }
    changed_.notify_all();
  }
}

RawRecorder::Counts RawRecorder::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

std::string RawRecorder::last_error() const {
  std::lock_guard lock(mutex_);
  return last_error_;
}

}  // namespace dco::daemon
