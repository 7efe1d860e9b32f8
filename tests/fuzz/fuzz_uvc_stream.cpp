// libFuzzer entry point: arbitrary bytes as a run of UVC bulk payloads from the camera. The first
// byte picks a small frame size; the rest is cut into payloads at lengths taken from the input.
// The assembler must never write outside its buffers, must account for every payload and frame
// start, and every frame it hands out must have exactly the frame size; its metadata row is parsed
// and masked as the driver does.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "dco/indemind/frame_assembler.hpp"
#include "dco/indemind/frame_metadata.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dco::indemind;
  if (size < 2) return 0;
  // Frames of 2·width × 2 rows: width 38..293, so a metadata row is 76..586 bytes.
  const std::size_t width = 38 + data[0];
  const std::size_t frame_bytes = 2 * width * 2;
  FrameAssembler assembler(frame_bytes);
  std::vector<std::uint8_t> out(frame_bytes);
  std::size_t at = 1, payloads = 0;
  while (at < size) {
    const std::size_t len = std::min<std::size_t>(data[at] * 4u, size - at - 1);
    ++at;
    const bool done = assembler.feed({data + at, len});
    ++payloads;
    at += len;
    if (done) {
      if (!assembler.take_frame(out) || out.size() != frame_bytes) std::abort();
      std::span<std::uint8_t> last(out.data() + 2 * width, 2 * width);
      const FrameMetadata m = parse_frame_metadata(last);
      if (!m.torn) mask_frame_metadata(last, {out.data(), 2 * width});
    }
  }
  const AssemblerCounters& c = assembler.counters();
  if (c.payloads != payloads) std::abort();
  if (c.bad_payloads > c.payloads) std::abort();
  const std::uint64_t ended =
      c.frames + c.short_frames + c.oversized_frames + c.error_frames + c.corrupt_frames;
  if (ended > c.payloads) std::abort();
  return 0;
}
