// libFuzzer entry point: arbitrary bytes given to the checked decoder of every dco LCM type. A
// message that decodes must encode back to the same bytes (the decoder accepted exactly one
// encoding); nothing may crash, hang or allocate more than the input justifies.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "dco/ipc/lcm_messages.hpp"
#include "fuzz_target.hpp"

namespace {

template <class T>
void try_type(const std::uint8_t* data, std::size_t size) {
  T m;
  std::string error;
  if (!dco::ipc::decode_message(data, size, m, error)) {
    if (error.empty()) std::abort();
    return;
  }
  const int n = m.getEncodedSize();
  std::vector<std::uint8_t> again(static_cast<std::size_t>(n));
  if (m.encode(again.data(), 0, n) != n || again.size() != size ||
      std::memcmp(again.data(), data, size) != 0)
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try_type<dco::depth_frame_t>(data, size);
  try_type<dco::depth_preview_t>(data, size);
  try_type<dco::pipeline_stats_t>(data, size);
  try_type<dco::device_status_t>(data, size);
  try_type<dco::log_event_t>(data, size);
  try_type<dco::raw_stereo_t>(data, size);
  return 0;
}
