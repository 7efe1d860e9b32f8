// libFuzzer entry point: arbitrary bytes as IMU interrupt transfers. Only exactly 32-byte reports
// parse; a parsed report re-encodes to the same bytes where the format has fields, scales to
// finite values in every range, and the counter extender places its frame counter within half a
// wrap of the last frame (or as itself near the start of the time line).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "dco/indemind/frame_metadata.hpp"
#include "dco/indemind/imu_report.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dco::indemind;
  const auto report = parse_imu_report({data, size});
  if (size != kImuReportBytes) {
    if (report) std::abort();
    return 0;
  }
  if (!report) std::abort();
  const auto back = encode_imu_report(*report);
  if (parse_imu_report(back)->ticks != report->ticks) std::abort();
  for (int i = 0; i < 4; ++i) {
    const ImuSample s = to_sample(*report, ImuRanges{i, 3 - i});
    for (float v : s.accel_g)
      if (!std::isfinite(v) || std::abs(v) > 16.01f) std::abort();
    for (float v : s.gyro_dps)
      if (!std::isfinite(v) || std::abs(v) > 2000.1f) std::abort();
  }
  CounterExtender e;
  e.next(static_cast<std::uint16_t>(data[0] << 8 | data[1]));
  const std::uint64_t placed = e.place(report->frame_counter);
  const auto distance = static_cast<std::int64_t>(placed) - static_cast<std::int64_t>(e.last());
  if ((placed & 0xffff) != report->frame_counter) std::abort();
  // Near the start of the time line a counter "before zero" stays as it is.
  const bool before_zero = placed == report->frame_counter && e.last() < 32768;
  if (!before_zero && (distance > 32768 || distance < -32768)) std::abort();
  return 0;
}
