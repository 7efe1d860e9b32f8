#include "replay_check.hpp"

#include <algorithm>
#include <cstdlib>

#include <fmt/format.h>

#include "dco/ipc/publisher.hpp"

namespace dco::daemon {

void ReplayCheck::check(std::uint64_t frame_seq, ImageView<const float> depth) {
  const auto seq = static_cast<std::int64_t>(frame_seq);
  const auto it = recorded_.by_frame.find({sessions_.session_of(seq), seq});
  if (it == recorded_.by_frame.end()) return;
  const ::dco::depth_preview_t& want = it->second;
  std::string difference;
  // Previews read from a log are whole grids (ipc::consistent_preview); one larger than the
  // depth map is no shrunk copy of it.
  if (want.source_width != depth.width || want.source_height != depth.height ||
      want.width > depth.width || want.height > depth.height) {
    difference = fmt::format("frame {}: depth of {}x{}, the headset's was {}x{}", frame_seq,
                             depth.width, depth.height, want.source_width, want.source_height);
  } else {
    // The headset's preview size gives its shrink factor back.
    const int factor = std::max((depth.width + want.width - 1) / want.width,
                                (depth.height + want.height - 1) / want.height);
    ipc::make_depth_preview(depth, factor, replayed_);
    if (replayed_.width != want.width || replayed_.height != want.height ||
        replayed_.depth_mm.size() != want.depth_mm.size()) {
      difference = fmt::format("frame {}: preview of {}x{}, the headset's was {}x{}", frame_seq,
                               replayed_.width, replayed_.height, want.width, want.height);
    } else {
      long differing = 0;
      int largest_mm = 0;
      for (std::size_t i = 0; i < want.depth_mm.size(); ++i)
        if (replayed_.depth_mm[i] != want.depth_mm[i]) {
          ++differing;
          largest_mm = std::max(largest_mm, std::abs(replayed_.depth_mm[i] - want.depth_mm[i]));
        }
      if (differing > 0)
        difference = fmt::format("frame {}: {} of {} preview pixels differ, by up to {} mm",
                                 frame_seq, differing, want.depth_mm.size(), largest_mm);
    }
  }
  std::lock_guard lock(mutex_);
  ++result_.compared;
  if (difference.empty())
    ++result_.identical;
  else if (result_.first_difference.empty())
    result_.first_difference = std::move(difference);
}

ReplayCheck::Result ReplayCheck::result() const {
  std::lock_guard lock(mutex_);
  Result r = result_;
  r.recorded = static_cast<long>(recorded_.by_frame.size());
  return r;
}

std::string ReplayCheck::summary() const {
  const Result r = result();
  if (r.compared == 0)
    return fmt::format("replay check: none of the {} recorded depth previews was replayed",
                       r.recorded);
  if (r.identical == r.compared)
    return fmt::format(
        "replay check: depth identical to the headset's in all {} recorded previews "
        "replayed ({} recorded)",
        r.compared, r.recorded);
  return fmt::format(
      "replay check: depth differs from the headset's in {} of {} recorded previews replayed; "
      "first {} (a different build or configuration, or frames the headset dropped)",
      r.compared - r.identical, r.compared, r.first_difference);
}

}  // namespace dco::daemon
