#pragma once

#include <cstdint>
#include <filesystem>

#include "dco/core/image.hpp"

namespace dco::ipc {

struct RingOptions {
  int width = 0;
  int height = 0;
  int image_channels = 1;  // rectified left image per slot: 0 = none, 1 = grey, 3 = colour
  int slot_count = 4;      // at least 3
};

// What a reader trusts about a frame; written into the slot, never taken from elsewhere.
struct FrameMeta {
  std::uint64_t frame_seq = 0;
  std::int64_t capture_ns = 0;  // CLOCK_MONOTONIC
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double baseline_m = 0;
};

// The publishing side of the shared-memory depth ring (layout: dco/ipc/ring_layout.hpp). One
// writer per ring (a second one on a live writer's path is refused); it never waits for a reader.
// Creating a ring replaces any file at the path atomically, so readers of a previous session see
// a new inode and a new session id.
class RingWriter {
 public:
  // Throws dco::Error when the file cannot be created, the geometry is out of range or another
  // live writer publishes at `path`.
  RingWriter(const std::filesystem::path& path, const RingOptions& options);
  RingWriter(const RingWriter&) = delete;
  RingWriter& operator=(const RingWriter&) = delete;
  // Marks the ring closed and removes the file if it is still this ring's.
  ~RingWriter();

  // A slot being written: fill the views, then publish().
  struct Slot {
    ImageView<float> depth;
    ImageView<std::uint8_t> image;  // empty without image
    std::uint32_t index = 0;
  };

  // Opens the next slot (never the newest one); readers of that slot see it as overwritten. A
  // slot left open by a write that was never published is opened again instead.
  Slot begin_write();
  // Stamps the metadata and publish time and makes the slot the newest. Returns its publish index.
  // Throws dco::Error without an open slot.
  std::uint64_t publish(const FrameMeta& meta);

  // begin_write + copy + publish. `image` must match the ring: empty exactly when it holds none.
  // Throws dco::Error on a size mismatch, before touching any slot.
  std::uint64_t write(ImageView<const float> depth, ImageView<const std::uint8_t> image,
                      const FrameMeta& meta);

  const std::filesystem::path& path() const { return path_; }
  const RingOptions& options() const { return options_; }
  // The slot begin_write() opened last: the newest one once published.
  std::uint32_t current_slot() const { return writing_; }
  std::uint64_t session_id() const { return session_id_; }
  std::uint64_t published() const { return published_; }

  // $RUNTIME_DIRECTORY, else /run/dcod when it is writable, else the user's own
  // $XDG_RUNTIME_DIR/dcod or <temp>/dcod-<uid> (made 0700; refused when it is not the user's or
  // others can write to it).
  static std::filesystem::path default_directory();

 private:
  unsigned char* slot_base(std::uint32_t index) const;

  std::filesystem::path path_;
  RingOptions options_;
  int fd_ = -1;
  unsigned char* base_ = nullptr;
  std::size_t size_ = 0;
  std::uint64_t session_id_ = 0;
  std::uint64_t published_ = 0;
  std::uint32_t writing_ = 0;
  bool open_slot_ = false;
};

}  // namespace dco::ipc
