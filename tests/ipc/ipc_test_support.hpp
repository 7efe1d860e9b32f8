#pragma once

#include <filesystem>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "frame_pattern.hpp"
#include "support/temp_dir.hpp"

namespace dco::ipc::testing {

using TempDir = dco::testing::TempDir;

// Fills a slot with frame `seq` of the test pattern.
inline void fill_pattern(const RingWriter::Slot& slot, std::uint64_t seq) {
  for (int y = 0; y < slot.depth.height; ++y)
    for (int x = 0; x < slot.depth.width; ++x)
      slot.depth.at(x, y) =
          pattern_depth(seq, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
  if (!slot.image.empty())
    for (int y = 0; y < slot.image.height; ++y)
      for (int x = 0; x < slot.image.width; ++x)
        slot.image.at(x, y) =
            pattern_image(seq, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
}

// Writes frame `seq` of the test pattern straight into the next slot.
inline std::uint64_t publish_pattern(RingWriter& writer, std::uint64_t seq) {
  fill_pattern(writer.begin_write(), seq);
  FrameMeta meta;
  meta.frame_seq = seq;
  meta.capture_ns = static_cast<std::int64_t>(seq) * 1000;
  meta.fx = 500.0 + static_cast<double>(seq);
  meta.fy = 501.0;
  meta.cx = 320.5;
  meta.cy = 240.25;
  meta.baseline_m = 0.12;
  return writer.publish(meta);
}

}  // namespace dco::ipc::testing
