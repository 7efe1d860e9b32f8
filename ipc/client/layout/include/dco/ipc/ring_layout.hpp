#pragma once

// Byte layout of the shared-memory depth ring, shared by the writer (dco_ipc) and the client
// library (dco_client). It includes nothing but the standard library so the client stands alone.
//
// File: [RingHeader][slot 0][slot 1]...[slot N-1]. Every slot is [SlotHeader][depth][image], each
// part starting on a 64-byte boundary and every pixel row padded to a multiple of 64 bytes. The
// header's fixed part is written once before the file is renamed into place; only the fields
// after it change, and only the writer changes them. An LCM descriptor names a frame by
// (session_id, slot index, publish_index): everything a reader trusts lives in the slot.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <type_traits>

namespace dco::ipc::layout {

inline constexpr std::uint64_t kMagic = 0x31474e49524f4344ull;  // "DCORING1" little-endian
inline constexpr std::uint32_t kVersion = 2;
inline constexpr std::uint32_t kDepthFormatFloat32Metres = 1;
inline constexpr std::uint32_t kImageFormatNone = 0;
inline constexpr std::uint32_t kImageFormatU8 = 1;  // interleaved 8-bit, 1 or 3 channels
inline constexpr std::uint32_t kMinSlots = 3;
inline constexpr std::uint32_t kMaxSlots = 64;
inline constexpr std::uint32_t kMaxDimension = 16384;
inline constexpr std::uint64_t kAlignment = 64;

inline constexpr std::uint32_t kStateLive = 1;
inline constexpr std::uint32_t kStateClosed = 2;  // the writer stopped cleanly

static_assert(std::atomic<std::uint64_t>::is_always_lock_free);
static_assert(std::atomic<std::uint32_t>::is_always_lock_free);
static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t));

struct alignas(64) RingHeader {
  std::uint64_t magic;
  std::uint32_t version;
  std::uint32_t header_size;  // sizeof(RingHeader)
  std::uint32_t width;
  std::uint32_t height;
  std::uint32_t depth_format;
  std::uint32_t image_format;
  std::uint32_t image_channels;  // 0 when image_format is kImageFormatNone
  std::uint32_t slot_count;
  std::uint64_t depth_stride;  // bytes between depth rows
  std::uint64_t image_stride;  // bytes between image rows, 0 without image
  std::uint64_t slot_header_size;
  std::uint64_t depth_offset;  // from the slot start
  std::uint64_t image_offset;  // from the slot start, 0 without image
  std::uint64_t slot_stride;
  std::uint64_t slots_offset;  // from the file start
  std::uint64_t file_size;
  std::uint64_t session_id;  // random, new every time a writer creates the ring
  std::int64_t writer_pid;
  std::int64_t created_ns;  // CLOCK_MONOTONIC

  // Changed while the ring is live, by the writer only.
  alignas(64) std::atomic<std::uint64_t> publish_count;  // frames published so far
  std::atomic<std::uint32_t> newest_slot;                // valid once publish_count > 0
  std::atomic<std::uint32_t> state;
  // Futex word readers sleep on: the writer changes it after every publish and on close, then
  // wakes the sleepers, so a reader never has to poll for the next frame.
  std::atomic<std::uint32_t> wake;
  // Futex word for readers that poll through a write: the writer adds 1 and wakes them when it
  // starts filling a slot (and on close). Between writes it equals publish_count's low 32 bits.
  // It sits in what was padding, so readers that do not know it are unaffected, and with a
  // writer that does not set it such readers just never see a write begin.
  std::atomic<std::uint32_t> writes_begun;
};

struct alignas(64) SlotHeader {
  // Odd while the writer fills the slot; every write adds 2.
  std::atomic<std::uint64_t> seqlock;
  std::uint64_t publish_index;  // 1 for the first frame this session, then +1 per frame
  std::uint64_t frame_seq;      // the camera's frame number
  std::int64_t capture_ns;      // CLOCK_MONOTONIC
  std::int64_t publish_ns;      // CLOCK_MONOTONIC
  double fx;                    // rectified left camera, pixels
  double fy;
  double cx;
  double cy;
  double baseline_m;
};

// Standard layout, so both sides (and tests) agree on every offsetof.
static_assert(std::is_standard_layout_v<RingHeader> && std::is_standard_layout_v<SlotHeader>);

inline constexpr std::uint64_t align_up(std::uint64_t v) {
  return (v + kAlignment - 1) / kAlignment * kAlignment;
}

struct Geometry {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t image_channels = 0;  // 0 = no image, 1 = grey, 3 = colour
  std::uint32_t slot_count = 0;
};

struct Sizes {
  std::uint64_t depth_stride;
  std::uint64_t image_stride;
  std::uint64_t depth_offset;
  std::uint64_t image_offset;
  std::uint64_t slot_stride;
  std::uint64_t slots_offset;
  std::uint64_t file_size;
};

// The one place sizes are derived, so a reader recomputes them instead of trusting the file.
// Empty when the geometry is out of range (every product then fits in 64 bits).
inline std::optional<Sizes> compute_sizes(const Geometry& g) {
  if (g.width == 0 || g.height == 0 || g.width > kMaxDimension || g.height > kMaxDimension)
    return std::nullopt;
  if (g.image_channels != 0 && g.image_channels != 1 && g.image_channels != 3) return std::nullopt;
  if (g.slot_count < kMinSlots || g.slot_count > kMaxSlots) return std::nullopt;
  Sizes s{};
  s.depth_stride = align_up(std::uint64_t{g.width} * sizeof(float));
  s.image_stride = g.image_channels ? align_up(std::uint64_t{g.width} * g.image_channels) : 0;
  s.depth_offset = align_up(sizeof(SlotHeader));
  const std::uint64_t depth_end = s.depth_offset + s.depth_stride * g.height;
  s.image_offset = g.image_channels ? depth_end : 0;
  s.slot_stride = g.image_channels ? s.image_offset + s.image_stride * g.height : depth_end;
  s.slots_offset = align_up(sizeof(RingHeader));
  s.file_size = s.slots_offset + s.slot_stride * g.slot_count;
  return s;
}

// Seqlock fences. GCC rejects std::atomic_thread_fence under ThreadSanitizer, which does not
// model fences; there a compiler barrier stands in (enough on x86's ordered memory, the only
// target the TSan build runs on), and the counter accesses stay acquire/release.
inline void fence_acquire() {
#if defined(__SANITIZE_THREAD__)
  std::atomic_signal_fence(std::memory_order_seq_cst);
#else
  std::atomic_thread_fence(std::memory_order_acquire);
#endif
}

inline void fence_release() {
#if defined(__SANITIZE_THREAD__)
  std::atomic_signal_fence(std::memory_order_seq_cst);
#else
  std::atomic_thread_fence(std::memory_order_release);
#endif
}

}  // namespace dco::ipc::layout
