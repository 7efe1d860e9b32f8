#include "dco/drivers/recorded_previews.hpp"

#include "dco/drivers/lcm_log.hpp"
#include "dco/drivers/source_uri.hpp"
#include "dco/ipc/lcm_messages.hpp"

namespace dco::drivers {

RecordedPreviews read_recorded_previews(const std::filesystem::path& log, std::size_t max_count) {
  RecordedPreviews out;
  LcmLogReader reader(log);
  LcmLogEvent event;
  ::dco::depth_preview_t preview;
  std::string problem;
  while (reader.next(event)) {
    if (event.channel != ipc::channel::kDepthPreview) continue;
    if (!ipc::decode_message(event.data.data(), event.data.size(), preview, problem) ||
        !ipc::consistent_preview(preview)) {
      ++out.undecodable;
      continue;
    }
    if (out.by_frame.size() >= max_count) {
      out.truncated = true;
      break;
    }
    const std::int64_t frame = preview.frame_seq;
    out.by_frame[frame] = std::move(preview);
  }
  return out;
}

std::optional<std::filesystem::path> lcmlog_path(std::string_view source_uri) {
  if (!source_uri.starts_with("lcmlog://")) return std::nullopt;
  return SourceUri(source_uri).path();
}

}  // namespace dco::drivers
