#include <algorithm>

#include <opencv2/imgcodecs.hpp>

#include <fmt/format.h>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "dco/drivers/raw_stereo.hpp"

namespace dco::drivers {
namespace {

// Whether `bytes` start as an 8-bit PNG of width x height, from its header alone.
bool png_header_is(const std::vector<std::uint8_t>& bytes, int width, int height) {
  const auto png = png_header(bytes);
  return png && png->width == static_cast<std::uint32_t>(width) &&
         png->height == static_cast<std::uint32_t>(height) && png->bit_depth == 8;
}

}  // namespace

RawStereoEncoder::RawStereoEncoder(int png_level)
    : params_{cv::IMWRITE_PNG_COMPRESSION, png_level, cv::IMWRITE_PNG_STRATEGY,
              cv::IMWRITE_PNG_STRATEGY_FILTERED} {
  if (png_level < 0 || png_level > 9) throw Error("raw recording: PNG level must be 0..9");
}

void RawStereoEncoder::encode(const StereoFrame& frame, const std::string& calibration_toml,
                              ::dco::raw_stereo_t& out) {
  const ImageView<const std::uint8_t>& l = frame.left;
  const ImageView<const std::uint8_t>& r = frame.right;
  if (l.width != r.width || l.height != r.height || l.channels != r.channels ||
      (l.channels != 1 && l.channels != 3) || l.width <= 0 || l.height <= 0)
    throw Error(fmt::format("raw recording: a pair of {}x{}x{} and {}x{}x{}", l.width, l.height,
                            l.channels, r.width, r.height, r.channels));
  out.frame_seq = static_cast<std::int64_t>(frame.seq);
  out.capture_ns = frame.capture_ns;
  out.width = l.width;
  out.height = l.height;
  out.encoding = "png";
  const auto compress = [&](const ImageView<const std::uint8_t>& eye, std::vector<std::uint8_t>& to,
                            std::int32_t& size) {
    // Straight into the message, whose vector keeps its capacity from frame to frame.
    if (!cv::imencode(".png", as_mat(eye), to, params_))
      throw Error("raw recording: PNG encoding failed");
    size = static_cast<std::int32_t>(to.size());
  };
  compress(l, out.left, out.left_size);
  compress(r, out.right, out.right_size);
  out.calibration = calibration_toml;
  out.num_imu = static_cast<std::int32_t>(frame.imu.size());
  out.imu_ns.resize(frame.imu.size());
  out.accel.resize(frame.imu.size());
  out.gyro.resize(frame.imu.size());
  for (std::size_t i = 0; i < frame.imu.size(); ++i) {
    // lcm-gen makes [n][3] a vector of vectors: each row gets its three values.
    const ImuSample& sample = frame.imu[i];
    out.imu_ns[i] = sample.capture_ns;
    out.accel[i].assign(sample.accel_mps2.begin(), sample.accel_mps2.end());
    out.gyro[i].assign(sample.gyro_radps.begin(), sample.gyro_radps.end());
  }
}

void decode_raw_stereo(const ::dco::raw_stereo_t& message, Image<std::uint8_t>& left,
                       Image<std::uint8_t>& right) {
  if (message.encoding != "png")
    throw Error(fmt::format("raw frame {}: encoding '{}' (this build reads png)", message.frame_seq,
                            message.encoding));
  if (message.width < 1 || message.height < 1 || message.width > kMaxImageSide ||
      message.height > kMaxImageSide)
    throw Error(fmt::format("raw frame {}: a {}x{} frame (sides 1..{})", message.frame_seq,
                            message.width, message.height, kMaxImageSide));
  int channels = 0;
  const auto expand = [&](const std::vector<std::uint8_t>& bytes, Image<std::uint8_t>& to,
                          const char* eye) {
    if (!png_header_is(bytes, message.width, message.height))
      throw Error(fmt::format("raw frame {}: the {} image is not an 8-bit PNG of {}x{}",
                              message.frame_seq, eye, message.width, message.height));
    if (const std::string damage = png_damage(bytes); !damage.empty())
      throw Error(
          fmt::format("raw frame {}: the {} image's PNG is {}", message.frame_seq, eye, damage));
    // Straight into the image when it already has the size: imdecode keeps a matching buffer.
    cv::Mat into;
    if (!to.empty()) into = as_mat(to.view());
    const cv::Mat src(1, static_cast<int>(bytes.size()), CV_8UC1,
                      const_cast<std::uint8_t*>(bytes.data()));
    cv::Mat got = bytes.empty() ? cv::Mat() : cv::imdecode(src, cv::IMREAD_UNCHANGED, &into);
    if (got.empty() || got.depth() != CV_8U || (got.channels() != 1 && got.channels() != 3))
      throw Error(
          fmt::format("raw frame {}: the {} image is not an 8-bit PNG", message.frame_seq, eye));
    if (got.cols != message.width || got.rows != message.height)
      throw Error(fmt::format("raw frame {}: the {} image is {}x{}, the message says {}x{}",
                              message.frame_seq, eye, got.cols, got.rows, message.width,
                              message.height));
    if (channels != 0 && got.channels() != channels)
      throw Error(fmt::format("raw frame {}: the eyes differ in channels", message.frame_seq));
    channels = got.channels();
    if (got.data != to.data()) {  // decoded elsewhere (first frame, new size): take it over
      to.resize(got.cols, got.rows, got.channels());
      got.copyTo(as_mat(to.view()));
    }
  };
  expand(message.left, left, "left");
  expand(message.right, right, "right");
}

void decode_raw_imu(const ::dco::raw_stereo_t& message, std::vector<ImuSample>& out) {
  const auto n = static_cast<std::size_t>(std::max(0, message.num_imu));
  if (message.imu_ns.size() < n || message.accel.size() < n || message.gyro.size() < n)
    throw Error(
        fmt::format("raw frame {}: {} IMU samples announced, fewer carried", message.frame_seq, n));
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (message.accel[i].size() != 3 || message.gyro[i].size() != 3)
      throw Error(fmt::format("raw frame {}: IMU sample {} is not three values per sensor",
                              message.frame_seq, i));
    ImuSample& s = out[i];
    s.capture_ns = message.imu_ns[i];
    std::copy(message.accel[i].begin(), message.accel[i].end(), s.accel_mps2.begin());
    std::copy(message.gyro[i].begin(), message.gyro[i].end(), s.gyro_radps.begin());
    s.temperature_c = 0;  // not recorded
  }
}

}  // namespace dco::drivers
