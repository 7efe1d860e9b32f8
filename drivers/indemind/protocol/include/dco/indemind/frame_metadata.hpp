#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace dco::indemind {

// The module writes a few big-endian fields over the first pixels of the last row of each
// side-by-side frame (protocol notes §3.2).
struct FrameMetadata {
  std::uint16_t counter = 0;       // frame counter, wraps at 65536
  std::uint16_t exposure_raw = 0;  // exposure in ~9.1 µs lines
  std::uint32_t timer_raw = 0;     // 125 µs ticks; not a usable timestamp
  // Bytes 68..75 of the row hold two words that are zero on a sound frame; both non-zero means the
  // row is shifted or torn.
  bool torn = false;

  double exposure_ms() const { return exposure_raw * 9.1 / 1000.0; }
};

// Bytes of the last row that carry metadata (and are masked before matching).
inline constexpr std::size_t kMetadataBytes = 76;

// `last_row` is the whole last row of the side-by-side frame (2 × width bytes, at least 76).
FrameMetadata parse_frame_metadata(std::span<const std::uint8_t> last_row);

// Writes metadata into a last row (for the simulated device and tests).
void write_frame_metadata(std::span<std::uint8_t> last_row, const FrameMetadata& m);

// Replaces the metadata bytes with the image above them, so the metadata never reaches matching
// as if it were scene texture.
void mask_frame_metadata(std::span<std::uint8_t> last_row, std::span<const std::uint8_t> row_above);

// Extends the 16-bit frame counter to 64 bits and classifies each step. Frames are never
// reordered, and the extended value never decreases.
class CounterExtender {
 public:
  // kDuplicate and kBackward (a counter up to 64 behind) mean: drop the frame; kRestart (further
  // behind) means the device started counting again, or the counter is garbage: the metadata row
  // has no checksum, so a caller confirms a restart with the frames after it.
  enum class Step { kFirst, kNext, kGap, kDuplicate, kBackward, kRestart };
  struct Result {
    Step step = Step::kFirst;
    std::uint64_t extended = 0;
    std::uint64_t skipped = 0;  // frames missing before this one (kGap)
  };

  // classify() then accept().
  Result next(std::uint16_t counter);
  // What `counter` would be, without taking it: a caller can refuse a step it finds implausible.
  Result classify(std::uint16_t counter) const;
  // Takes a classified step: the extended value moves on for every step but a dropped one
  // (kDuplicate, kBackward).
  void accept(const Result& r);
  // After a stream restart or replug the device counter starts anywhere: the next value is taken
  // as a first one, placed above everything seen so far so the time line never goes back.
  void resync() { resync_ = started_; }
  // False until the first frame after construction or resync(): until then IMU reports cannot
  // be placed.
  bool started() const { return started_ && !resync_; }
  std::uint64_t last() const { return last_; }

  // The 64-bit value nearest to `last()` whose low 16 bits are `counter`: how an IMU report's
  // frame counter is placed on the same time line as the images.
  std::uint64_t place(std::uint16_t counter) const;

 private:
  bool started_ = false, resync_ = false;
  std::uint64_t last_ = 0;
};

}  // namespace dco::indemind
