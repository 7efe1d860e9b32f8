#pragma once

// The depth previews (DCO_DEPTH_PREVIEW) a field log holds, by camera frame number: what the
// headset's depth looked like, for checking a replay of the same log against it.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string_view>

#include "dco/depth_preview_t.hpp"

namespace dco::drivers {

struct RecordedPreviews {
  std::map<std::int64_t, ::dco::depth_preview_t> by_frame;
  long undecodable = 0;    // preview messages that did not decode or hold no whole grid
  bool truncated = false;  // more previews than the limit; the first ones are kept
};

// Reads the log up to its end or its damage (which the replay itself reports). Throws dco::Error
// when the file cannot be opened.
RecordedPreviews read_recorded_previews(const std::filesystem::path& log, std::size_t max_count);

// The log an lcmlog:// URI replays; nullopt for other sources.
std::optional<std::filesystem::path> lcmlog_path(std::string_view source_uri);

}  // namespace dco::drivers
