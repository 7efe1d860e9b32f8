#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

namespace dco::stereo {

// Census transform over a window_w x window_h window (both odd, at most 64 - 1 comparisons):
// the neighbours in row-major order (centre skipped) fill the descriptor from its most
// significant used bit down, and a bit is set when that neighbour is darker than the centre.
// Neighbours outside the image are clamped to the border.
void census_transform(ImageView<const std::uint8_t> gray, int window_w, int window_h,
                      ImageView<std::uint64_t> out);
// The same for rows [y_begin, y_end) of `out` (the window still clamps at the image's rows).
void census_transform_rows(ImageView<const std::uint8_t> gray, int window_w, int window_h,
                           int y_begin, int y_end, ImageView<std::uint64_t> out);

}  // namespace dco::stereo
