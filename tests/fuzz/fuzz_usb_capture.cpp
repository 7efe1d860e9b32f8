// libFuzzer entry point: arbitrary bytes as a USB capture file (behind the signature, so the
// mutations reach the records). Reading never throws past the signature, never reads beyond the
// input, and what it read re-encodes to exactly the bytes it came from.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "dco/drivers/usb_capture.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dco::drivers;
  std::vector<std::uint8_t> file(std::begin(kUsbCaptureMagic), std::end(kUsbCaptureMagic));
  file.insert(file.end(), data, data + size);
  const UsbCapture c = parse_usb_capture(file);
  if (c.bytes_read > file.size()) std::abort();
  if (c.bytes_read < file.size() && c.problem.empty()) std::abort();
  std::vector<std::uint8_t> again(std::begin(kUsbCaptureMagic), std::end(kUsbCaptureMagic));
  for (const UsbCaptureRecord& r : c.records) encode_usb_capture_record(r, again);
  if (again.size() != c.bytes_read || std::memcmp(again.data(), file.data(), again.size()) != 0)
    std::abort();
  return 0;
}
