#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

namespace dco {

// out(x, y) = src(xc + cos a (x - xc) - sin a (y - yc), yc + sin a (x - xc) + cos a (y - yc) +
// down) for a = `radians` about the centre (xc, yc): each pixel takes what lies turned by a about
// the centre and `down` rows lower (cv::warpAffine, linear, borders repeated). A synthetic camera
// turned on its mount, and a real one's turn taken back, are both this. `out` is resized to `src`.
void turn_about_centre(ImageView<const std::uint8_t> src, double radians, double down,
                       Image<std::uint8_t>& out);

}  // namespace dco
