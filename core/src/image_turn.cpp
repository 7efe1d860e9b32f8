#include "dco/core/image_turn.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"

namespace dco {

void turn_about_centre(ImageView<const std::uint8_t> src, double radians, double down,
                       Image<std::uint8_t>& out) {
  out.resize(src.width, src.height, src.channels);
  const double c = std::cos(radians), s = std::sin(radians);
  const double xc = 0.5 * (src.width - 1), yc = 0.5 * (src.height - 1);
  // The map from out to src, which OpenCV takes as the inverse map.
  const cv::Matx23d to_src(c, -s, xc - c * xc + s * yc, s, c, yc - s * xc - c * yc + down);
  cv::Mat dst = as_mat(out.view());
  cv::warpAffine(as_mat(src), dst, to_src, dst.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
}

}  // namespace dco
