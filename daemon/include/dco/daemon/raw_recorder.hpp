#pragma once

// DCO_RAW recording: the source's pairs, copied on the source's thread into one of two buffers
// and compressed and sent on a thread of the recorder's own, so a slow encoder never stalls the
// camera. When both buffers are busy the pair is dropped and counted, except in deterministic
// mode, where the source waits, so a replay sees every frame the pipeline saw.

#include <array>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/raw_stereo.hpp"

namespace dco::daemon {

struct RawRecorderOptions {
  int png_level = 1;
  std::size_t max_message_bytes = 4'000'000;
  bool never_drop = false;
  std::string pipeline_config;  // the algorithm's keys, carried by every message
};

class RawRecorder {
 public:
  // Sends a message: true once sent, false when it is still in its send (held by the network,
  // it may yet go out); throws when it is not sent.
  using Send = std::function<bool(const ::dco::raw_stereo_t&)>;
  // Whether a pair could go out now; while not, pairs are counted as failed without being
  // compressed (no CPU spent on what cannot be sent).
  using CanSend = std::function<bool()>;
  struct Counts {
    // held: still in their send when the sender gave up waiting; neither recorded nor lost.
    std::uint64_t recorded = 0, dropped = 0, oversized = 0, failed = 0, held = 0;
  };

  RawRecorder(std::string calibration_toml, RawRecorderOptions options, Send send,
              CanSend can_send = {});
  // Sends what it holds, then stops; close() returns the final counts.
  ~RawRecorder();
  Counts close();
  RawRecorder(const RawRecorder&) = delete;
  RawRecorder& operator=(const RawRecorder&) = delete;

  // On the source's thread.
  void offer(const drivers::StereoFrame& frame);
  Counts counts() const;
  // The last encoding or sending failure, for the log; empty when none.
  std::string last_error() const;

 private:
  struct Slot {
    Image<std::uint8_t> left, right;
    std::vector<drivers::ImuSample> imu;
    std::uint64_t seq = 0;
    std::int64_t capture_ns = 0;
  };
  void run();

  const std::string calibration_toml_;
  const RawRecorderOptions options_;
  const Send send_;
  const CanSend can_send_;
  drivers::RawStereoEncoder encoder_;
  ::dco::raw_stereo_t message_;
  std::array<Slot, 2> slots_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::size_t head_ = 0, queued_ = 0;
  bool closing_ = false;
  Counts counts_;
  std::string last_error_;
  std::thread thread_;
};

}  // namespace dco::daemon
