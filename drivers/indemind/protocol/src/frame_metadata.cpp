#include "dco/indemind/frame_metadata.hpp"

#include <algorithm>

#include "dco/indemind/byte_order.hpp"

namespace dco::indemind {

FrameMetadata parse_frame_metadata(std::span<const std::uint8_t> row) {
  FrameMetadata m;
  if (row.size() < kMetadataBytes) {
    m.torn = true;
    return m;
  }
  m.counter = read_be16(row, 0);
  m.exposure_raw = read_be16(row, 2);
  m.timer_raw = read_be32(row, 4);
  m.torn = read_be32(row, 68) != 0 && read_be32(row, 72) != 0;
  return m;
}

void write_frame_metadata(std::span<std::uint8_t> row, const FrameMetadata& m) {
  std::fill(row.begin(), row.begin() + kMetadataBytes, std::uint8_t{0});
  write_be16(row, 0, m.counter);
  write_be16(row, 2, m.exposure_raw);
  write_be32(row, 4, m.timer_raw);
  if (m.torn) {
    write_be32(row, 68, 0xdeadbeef);
    write_be32(row, 72, 0x01020304);
  }
}

void mask_frame_metadata(std::span<std::uint8_t> row, std::span<const std::uint8_t> above) {
  const std::size_t n = std::min({kMetadataBytes, row.size(), above.size()});
  std::copy(above.begin(), above.begin() + n, row.begin());
}

namespace {

std::uint64_t above(std::uint64_t last, std::uint16_t counter) {
  return ((last >> 16) + 1) << 16 | counter;
}

}  // namespace

CounterExtender::Result CounterExtender::classify(std::uint16_t counter) const {
  Result r;
  if (!started_ || resync_) {
    r.step = Step::kFirst;
    r.extended = started_ ? above(last_, counter) : counter;
    return r;
  }
  r.extended = last_;
  const auto delta = static_cast<std::uint16_t>(counter - static_cast<std::uint16_t>(last_));
  if (delta == 0) {
    r.step = Step::kDuplicate;
  } else if (delta < 0x8000) {
    r.extended = last_ + delta;
    r.step = delta == 1 ? Step::kNext : Step::kGap;
    r.skipped = delta - 1u;
  } else if (0x10000 - delta <= 64) {
    r.step = Step::kBackward;
  } else {
    r.extended = above(last_, counter);
    r.step = Step::kRestart;
  }
  return r;
}

void CounterExtender::accept(const Result& r) {
  if (r.step == Step::kDuplicate || r.step == Step::kBackward) return;
  last_ = r.extended;
  started_ = true;
  resync_ = false;
}

CounterExtender::Result CounterExtender::next(std::uint16_t counter) {
  const Result r = classify(counter);
  accept(r);
  return r;
}

std::uint64_t CounterExtender::place(std::uint16_t counter) const {
  const std::int16_t delta = static_cast<std::int16_t>(
      static_cast<std::uint16_t>(counter - static_cast<std::uint16_t>(last_)));
  const std::int64_t placed = static_cast<std::int64_t>(last_) + delta;
  return placed < 0 ? counter : static_cast<std::uint64_t>(placed);
}

}  // namespace dco::indemind
