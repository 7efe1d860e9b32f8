#pragma once

// An exact compositing scene: real depth of a hand with fingers in front of a slanted wall, a
// virtual cube behind the hand and a sphere half sunk into the wall, with the occlusion mask
// ray-cast on the CPU at every pixel centre, and how a rendered mask scores against it.

#include <cstdint>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/ipc/ring_writer.hpp"

namespace dco::compositor {

constexpr int kW = 640, kH = 400;
inline const Camera kCamera{kW, kH, 450.0, 450.0, 319.5, 199.5};

struct ExactScene {
  std::vector<float> depth;
  std::vector<std::uint8_t> image;
  Scene scene;
  std::vector<std::uint8_t> mask;  // 1 where a virtual object is visible
};

ExactScene make_scene();
bool in_hand(int u, int v);
RealFrame frame_of(const ExactScene& e);
// Ring metadata of kCamera, as dcod writes it with each frame.
ipc::FrameMeta ring_meta();
// Publishes the scene's top-left width x height as frame `seq`, the way dcod fills a slot.
void write_scene(ipc::RingWriter& ring, const ExactScene& e, ipc::FrameMeta& meta,
                 std::uint64_t seq, int width, int height);

// Whether pixel (u, v) of a mask has a 4-neighbour of the other value.
bool boundary(const std::vector<std::uint8_t>& m, int u, int v);

struct MaskScore {
  double iou = 0;
  double boundary_within_1px = 0;  // share of exact boundary pixels with a rendered one ≤ 1 px
  long exact_pixels = 0;
};

MaskScore score(const std::vector<std::uint8_t>& exact, const std::vector<std::uint8_t>& got);

}  // namespace dco::compositor
