#pragma once

// Pairs the frames of two free-running cameras by capture time, keeping only the newest pair.
// Two cameras at one frame rate always have a frame within half a period of each other, so that
// is the tolerance; a frame that can no longer find a partner is handed back at once, so neither
// camera runs out of buffers while its partner is late or stalls. Independent of libcamera (the
// handle is whatever names a frame's buffer) and not thread-safe: the caller locks.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <vector>

namespace dco::drivers {

template <typename Handle>
class FramePairer {
 public:
  struct Frame {
    Handle handle{};
    std::int64_t ns = 0;  // capture time
  };
  using Pair = std::array<Frame, 2>;  // left, right
  struct Counters {
    std::uint64_t pairs = 0;
    std::uint64_t unpaired = 0;   // frames dropped without a partner
    std::uint64_t overtaken = 0;  // ready pairs replaced by a newer one before they were taken
    std::uint64_t untimed = 0;    // frames without a timestamp (0 or less), released at once
  };

  // `max_pending`: frames per camera held while waiting for a partner.
  explicit FramePairer(std::size_t max_pending = 2) : max_pending_(max_pending) {
    for (auto& p : pending_) p.reserve(max_pending_ + 1);
  }

  // A known frame period (the rate asked for, or the one the camera reports).
  void set_period(std::int64_t ns) {
    period_ns_ = ns;
    period_fixed_ = ns > 0;
  }
  // Otherwise the period is measured from the left camera: time between frames per sensor frame,
  // so frames the sensor dropped do not stretch it.
  void measure(std::uint32_t sequence, std::int64_t ns) {
    if (!period_fixed_ && last_ns_ != 0 && sequence > last_sequence_ && ns > last_ns_) {
      const std::int64_t measured = (ns - last_ns_) / (sequence - last_sequence_);
      period_ns_ = period_ns_ > 0 ? period_ns_ + (measured - period_ns_) / 8 : measured;
    }
    last_ns_ = ns;
    last_sequence_ = sequence;
  }
  std::int64_t period() const { return period_ns_; }

  // Adds a frame of camera `eye` (0 = left, 1 = right), oldest first per camera. Every frame given
  // up on, including an overtaken ready pair, goes to release(handle). True when a new pair is
  // ready.
  template <typename Release>
  bool add(int eye, const Frame& frame, Release&& release) {
    // Without a time a frame has no partner to be told from the others: pairing it by arrival
    // could match frames a period apart for good, unseen.
    if (frame.ns <= 0) {
      ++counters_.untimed;
      release(frame.handle);
      return false;
    }
    pending_[eye].push_back(frame);
    bool paired = false;
    const std::int64_t tolerance = period_ns_ / 2;
    auto& left = pending_[0];
    auto& right = pending_[1];
    while (tolerance > 0 && !left.empty() && !right.empty()) {
      const Frame a = left.front(), b = right.front();
      const std::int64_t gap = std::abs(a.ns - b.ns);
      if (a.ns < b.ns - tolerance) {
        drop(0, release);  // the right camera's later frames are later still
      } else if (b.ns < a.ns - tolerance) {
        drop(1, release);
      } else if (left.size() > 1 && std::abs(left[1].ns - b.ns) < gap) {
        drop(0, release);  // b's partner is the next left frame
      } else if (right.size() > 1 && std::abs(right[1].ns - a.ns) < gap) {
        drop(1, release);
      } else {
        left.erase(left.begin());
        right.erase(right.begin());
        unpaired_run_ = 0;
        ++counters_.pairs;
        offer({a, b}, 2, release);
        paired = true;
      }
    }
    for (int e = 0; e < 2; ++e)
      while (pending_[e].size() > max_pending_) drop(e, release);
    return paired;
  }

  // One camera with both eyes in each frame: every frame is a pair, the newest wins.
  template <typename Release>
  void add_single(const Frame& frame, Release&& release) {
    ++counters_.pairs;
    offer({frame, Frame{}}, 1, release);
  }

  bool has_pair() const { return ready_.has_value(); }
  std::optional<Pair> take() {
    std::optional<Pair> out = ready_;
    ready_.reset();
    ready_frames_ = 0;
    return out;
  }

  // Forgets every held frame without releasing it (the cameras have stopped).
  void clear() {
    for (auto& p : pending_) p.clear();
    ready_.reset();
    ready_frames_ = 0;
    unpaired_run_ = 0;
  }

  // Frames dropped without a partner since the last pair: a long run means the cameras do not
  // run at one rate.
  int unpaired_run() const { return unpaired_run_; }
  const Counters& counters() const { return counters_; }

 private:
  template <typename Release>
  void drop(int eye, Release& release) {
    release(pending_[eye].front().handle);
    pending_[eye].erase(pending_[eye].begin());
    ++counters_.unpaired;
    ++unpaired_run_;
  }

  template <typename Release>
  void offer(const Pair& pair, int frames, Release& release) {
    if (ready_) {
      ++counters_.overtaken;
      for (int i = 0; i < ready_frames_; ++i) release((*ready_)[i].handle);
    }
    ready_ = pair;
    ready_frames_ = frames;
  }

  std::size_t max_pending_;
  std::array<std::vector<Frame>, 2> pending_;
  std::optional<Pair> ready_;
  int ready_frames_ = 0;  // 1 for a single camera's frame
  std::int64_t period_ns_ = 0;
  bool period_fixed_ = false;
  std::int64_t last_ns_ = 0;
  std::uint32_t last_sequence_ = 0;
  int unpaired_run_ = 0;
  Counters counters_;
};

}  // namespace dco::drivers
