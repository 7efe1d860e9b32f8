#include "dco/indemind/frame_metadata.hpp"
#include "dco/indemind/uvc_payload.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {

// Two well-formed frames for width 38 (2 rows of 76 bytes), in payloads of 48 and 104 bytes, and
// the same with an error bit and a truncated header.
std::vector<std::vector<std::uint8_t>> seeds() {
  using namespace dco::indemind;
  std::vector<std::vector<std::uint8_t>> out;
  for (int variant = 0; variant < 3; ++variant) {
    std::vector<std::uint8_t> s = {0};
    for (int f = 0; f < 2; ++f) {
      std::vector<std::uint8_t> frame(152, static_cast<std::uint8_t>(f + 1));
      FrameMetadata m;
      m.counter = static_cast<std::uint16_t>(f);
      write_frame_metadata(std::span(frame).subspan(76, 76), m);
      for (int part = 0; part < 2; ++part) {
        auto p = make_uvc_header(f & 1, part == 1, variant == 1 && part == 0);
        if (variant == 2 && part == 1) p[0] = 9;
        p.insert(p.end(), frame.begin() + part * 76, frame.begin() + part * 76 + 76);
        // The length byte counts 4-byte units; pad to a multiple of 4.
        while (p.size() % 4) p.push_back(0);
        s.push_back(static_cast<std::uint8_t>(p.size() / 4));
        s.insert(s.end(), p.begin(), p.end());
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace dco::fuzz
