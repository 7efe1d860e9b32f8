#pragma once

// DCO_RAW messages: a raw stereo pair, losslessly compressed (PNG), with the source's
// calibration and IMU samples, and back to images for a replay.

#include <string>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/raw_stereo_t.hpp"

namespace dco::drivers {

class RawStereoEncoder {
 public:
  // zlib level 0..9: 1 is a few ms per VGA frame and most of the size gain.
  explicit RawStereoEncoder(int png_level = 1);
  // Fills `out`, reusing its buffers. Throws dco::Error for a pair whose eyes differ in size or
  // channels (1 or 3).
  void encode(const StereoFrame& frame, const std::string& calibration_toml,
              ::dco::raw_stereo_t& out);

 private:
  std::vector<int> params_;
};

// Decodes into `left` and `right`, reallocating them only when the size changes. Throws
// dco::Error naming what is wrong: another encoding, a PNG that does not decode, eyes or a size
// that differ from what the message says.
void decode_raw_stereo(const ::dco::raw_stereo_t& message, Image<std::uint8_t>& left,
                       Image<std::uint8_t>& right);
// The message's IMU samples into `out` (its capacity reused), with the recorded stamps: the
// headset's clock, like message.capture_ns (lcmlog:// moves both onto the replay's). Throws
// dco::Error when a row does not hold three values.
void decode_raw_imu(const ::dco::raw_stereo_t& message, std::vector<ImuSample>& out);

}  // namespace dco::drivers
