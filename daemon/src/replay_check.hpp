#pragma once

#include <cstdint>
#include <mutex>
#include <string>

#include "dco/core/image.hpp"
#include "dco/core/priority_inheritance_mutex.hpp"
#include "dco/drivers/recorded_previews.hpp"

namespace dco::daemon {

// A replay of a field log checked against the depth the headset published: every replayed frame
// with a recorded DCO_DEPTH_PREVIEW is shrunk the same way and compared pixel for pixel. In
// deterministic mode a replay through the same build and configuration matches exactly. A log
// of several dcod runs numbers their frames again; each replayed frame is compared with the
// preview of its own run.
class ReplayCheck {
 public:
  // `first_session`: the dcod run of the log the replay starts with (drivers::ReplayedLog).
  ReplayCheck(drivers::RecordedPreviews recorded, std::int64_t first_session)
      : recorded_(std::move(recorded)), sessions_(first_session) {}

  // The pipeline's thread, for every frame in the order replayed: the depth published for camera
  // frame `frame_seq`.
  void check(std::uint64_t frame_seq, ImageView<const float> depth);

  struct Result {
    long recorded = 0, compared = 0, identical = 0;
    std::string first_difference;  // empty while all compared frames match
  };
  Result result() const;
  // One line for the daemon's log.
  std::string summary() const;

 private:
  const drivers::RecordedPreviews recorded_;
  mutable PriorityInheritanceMutex mutex_;  // check() runs on the release thread
  Result result_;
  ::dco::depth_preview_t replayed_;
  drivers::FrameSessions sessions_;
};

}  // namespace dco::daemon
