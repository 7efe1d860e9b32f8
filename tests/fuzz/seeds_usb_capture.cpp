#include "dco/drivers/usb_capture.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {

// Records of every kind, without the signature the target puts in front.
std::vector<std::vector<std::uint8_t>> seeds() {
  using namespace dco::drivers;
  using Kind = UsbCaptureRecord::Kind;
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> all;
  for (int k = 1; k <= static_cast<int>(Kind::kHotplug); ++k) {
    UsbCaptureRecord r;
    r.kind = static_cast<Kind>(k);
    r.t_ns = 1000 * k;
    r.devices = {{1, 2, "1-2", 5000, "SN"}};
    r.port_path = "1-2";
    r.length = 4;
    r.data = {1, 2, 3, 4};
    if (k == 2) {
      r.outcome = UsbCaptureRecord::Outcome::kNoDevice;
      r.message = "gone";
    }
    std::vector<std::uint8_t> one;
    encode_usb_capture_record(r, one);
    out.push_back(one);
    all.insert(all.end(), one.begin(), one.end());
  }
  out.push_back(all);
  return out;
}

}  // namespace dco::fuzz
