#pragma once

// The pixels a test writer puts into frame `seq`, and checksums over what a reader got: a frame
// mixed from two writes cannot match the checksum of either. Depends on nothing but the standard
// library so the reader helper process links libdco-client alone.

#include <cstddef>
#include <cstdint>

namespace dco::ipc::testing {

inline std::uint32_t mix(std::uint64_t seq, std::uint32_t x, std::uint32_t y) {
  std::uint64_t h = seq * 0x9e3779b97f4a7c15ull ^ (std::uint64_t{y} << 32 | x);
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  return static_cast<std::uint32_t>(h);
}

inline float pattern_depth(std::uint64_t seq, std::uint32_t x, std::uint32_t y) {
  return 0.25f + static_cast<float>(mix(seq, x, y) & 0xffff) / 4096.0f;
}

inline std::uint8_t pattern_image(std::uint64_t seq, std::uint32_t x, std::uint32_t y) {
  return static_cast<std::uint8_t>(mix(seq + 7, x, y) >> 8);
}

class Checksum {
 public:
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 0x100000001b3ull;
  }
  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ull;
};

// Checksum of `height` rows of depth then image; image may be null.
inline std::uint64_t frame_checksum(const unsigned char* depth, std::size_t depth_stride,
                                    const unsigned char* image, std::size_t image_stride,
                                    std::uint32_t width, std::uint32_t height,
                                    std::uint32_t channels) {
  Checksum c;
  for (std::uint32_t y = 0; y < height; ++y) c.add(depth + y * depth_stride, width * sizeof(float));
  if (image != nullptr)
    for (std::uint32_t y = 0; y < height; ++y) c.add(image + y * image_stride, width * channels);
  return c.value();
}

inline std::uint64_t expected_checksum(std::uint64_t seq, std::uint32_t width, std::uint32_t height,
                                       bool with_image) {
  Checksum c;
  for (std::uint32_t y = 0; y < height; ++y)
    for (std::uint32_t x = 0; x < width; ++x) {
      const float v = pattern_depth(seq, x, y);
      c.add(&v, sizeof(v));
    }
  if (with_image)
    for (std::uint32_t y = 0; y < height; ++y)
      for (std::uint32_t x = 0; x < width; ++x) {
        const std::uint8_t v = pattern_image(seq, x, y);
        c.add(&v, 1);
      }
  return c.value();
}

}  // namespace dco::ipc::testing
