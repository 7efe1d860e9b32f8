// Seeds of the LCM decode target: one valid message of each type.

#include "fuzz_target.hpp"
#include "ipc/lcm_samples.hpp"

namespace dco::fuzz {
namespace {

template <class T>
std::vector<std::uint8_t> encoded(const T& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  using namespace dco::ipc::testing;
  return {encoded(sample_depth_frame()), encoded(sample_preview()), encoded(sample_stats()),
          encoded(sample_status()),      encoded(sample_log()),     encoded(sample_raw())};
}

}  // namespace dco::fuzz
