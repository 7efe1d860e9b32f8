#pragma once

// Zero-copy bridges between dco image views and cv::Mat. Kept out of image.hpp so that code which
// only needs views (the SIMD kernels, the client library) never pulls in OpenCV.

#include <opencv2/core.hpp>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"

namespace dco {

template <typename T>
constexpr int cv_depth_of() {
  if constexpr (std::is_same_v<std::remove_const_t<T>, std::uint8_t>)
    return CV_8U;
  else if constexpr (std::is_same_v<std::remove_const_t<T>, std::uint16_t>)
    return CV_16U;
  else if constexpr (std::is_same_v<std::remove_const_t<T>, std::int16_t>)
    return CV_16S;
  else if constexpr (std::is_same_v<std::remove_const_t<T>, std::int32_t>)
    return CV_32S;
  else if constexpr (std::is_same_v<std::remove_const_t<T>, float>)
    return CV_32F;
  else if constexpr (std::is_same_v<std::remove_const_t<T>, double>)
    return CV_64F;
  else
    static_assert(sizeof(T) == 0, "no OpenCV depth for this pixel type");
}

// The Mat aliases the view's memory; for a const view the caller must not write through it.
template <typename T>
cv::Mat as_mat(ImageView<T> v) {
  using U = std::remove_const_t<T>;
  return cv::Mat(v.height, v.width, CV_MAKETYPE(cv_depth_of<T>(), v.channels),
                 const_cast<U*>(v.data), static_cast<std::size_t>(v.stride) * sizeof(T));
}

template <typename T>
ImageView<T> as_view(cv::Mat& m) {
  if (m.depth() != cv_depth_of<T>()) throw Error("internal: cv::Mat has an unexpected pixel type");
  if (m.step[0] % sizeof(T) != 0) throw Error("internal: cv::Mat row step is not a whole pixel");
  return ImageView<T>(m.ptr<T>(), m.cols, m.rows, m.channels(),
                      static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T)));
}

template <typename T>
ImageView<const T> as_view(const cv::Mat& m) {
  if (m.depth() != cv_depth_of<T>()) throw Error("internal: cv::Mat has an unexpected pixel type");
  if (m.step[0] % sizeof(T) != 0) throw Error("internal: cv::Mat row step is not a whole pixel");
  return ImageView<const T>(m.ptr<T>(), m.cols, m.rows, m.channels(),
                            static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T)));
}

}  // namespace dco
