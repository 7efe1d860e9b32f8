// Seeds of the ring header target: small consistent rings, with and without image, before and
// after frames were published, as RingWriter lays them out.

#include <cstring>
#include <new>

#include "dco/ipc/ring_layout.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

namespace layout = dco::ipc::layout;

std::vector<std::uint8_t> ring(std::uint32_t w, std::uint32_t h, std::uint32_t channels,
                               std::uint32_t slots, std::uint64_t published) {
  const layout::Geometry g{w, h, channels, slots};
  const layout::Sizes s = *layout::compute_sizes(g);
  // 64-byte aligned storage for the headers' atomics; the file is its bytes.
  std::vector<std::uint64_t> words((s.file_size + 63) / 8 + 8);
  auto* base = reinterpret_cast<unsigned char*>(
      (reinterpret_cast<std::uintptr_t>(words.data()) + 63) / 64 * 64);
  auto* hdr = new (base) layout::RingHeader{};
  hdr->magic = layout::kMagic;
  hdr->version = layout::kVersion;
  hdr->header_size = sizeof(layout::RingHeader);
  hdr->width = w;
  hdr->height = h;
  hdr->depth_format = layout::kDepthFormatFloat32Metres;
  hdr->image_format = channels ? layout::kImageFormatU8 : layout::kImageFormatNone;
  hdr->image_channels = channels;
  hdr->slot_count = slots;
  hdr->depth_stride = s.depth_stride;
  hdr->image_stride = s.image_stride;
  hdr->slot_header_size = sizeof(layout::SlotHeader);
  hdr->depth_offset = s.depth_offset;
  hdr->image_offset = s.image_offset;
  hdr->slot_stride = s.slot_stride;
  hdr->slots_offset = s.slots_offset;
  hdr->file_size = s.file_size;
  hdr->session_id = 0x1234;
  hdr->state.store(layout::kStateLive);
  hdr->publish_count.store(published);
  hdr->newest_slot.store(published == 0 ? slots - 1
                                        : static_cast<std::uint32_t>((published - 1) % slots));
  for (std::uint32_t i = 0; i < slots; ++i) {
    auto* slot = new (base + s.slots_offset + s.slot_stride * i) layout::SlotHeader{};
    // Slot i holds the newest index that went into it.
    std::uint64_t index = 0;
    for (std::uint64_t k = 1; k <= published; ++k)
      if ((k - 1) % slots == i) index = k;
    slot->seqlock.store(index == 0 ? 0 : 2 * ((index - 1) / slots + 1));
    slot->publish_index = index;
    slot->frame_seq = index * 10;
  }
  return {base, base + s.file_size};
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {ring(4, 2, 1, 3, 0), ring(4, 2, 1, 3, 5), ring(3, 1, 0, 4, 2), ring(2, 2, 3, 3, 7)};
}

}  // namespace dco::fuzz
