#include "dco/daemon/daemon_config.hpp"

#include <fmt/format.h>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/ipc/publisher.hpp"

namespace dco::daemon {
namespace {

void register_params(ConfigSchema& s, DaemonConfig& c) {
  s.add("source.uri", &c.source, {},
        "frames from: synthetic://NAME?..., replay://DIR?..., lcmlog://FILE?fps=, indemind://...,"
        " libcamera://... (see *The daemon, dcod*)");
  s.add("ring.path", &c.ring_path, {},
        "depth ring file; empty = $RUNTIME_DIRECTORY (or /run/dcod, else $XDG_RUNTIME_DIR/dcod or"
        " the temp dir's dcod-<uid>)/depth.shm");
  s.add("ring.slots", &c.ring_slots, 3, 64, "frames the ring holds (readers get the newest)");
  s.add("ring.image", &c.ring_image, "each slot also carries the rectified left image");
  s.add("lcm.url", &c.lcm_url, {}, "LCM provider; empty = $LCM_DEFAULT_URL, else udpm multicast");
  s.add("lcm.preview_hz", &c.preview_hz, 0.0, 30.0, "DCO_DEPTH_PREVIEW rate (0 = off)");
  s.add("lcm.stats_hz", &c.stats_hz, 0.1, 10.0, "DCO_STATS and DCO_STATUS rate");
  s.add("service.stall_timeout_s", &c.stall_timeout_s, 0.1, 600.0,
        "no frame published for this long = unhealthy: watchdog pings stop");
  s.add("service.max_frames", &c.max_frames, 0, 2000000000,
        "exit cleanly after publishing this many frames (0 = run until stopped)");
  s.add("log.level", &c.log_level, {"debug", "info", "warning", "error"},
        "least severe message written (journal or stderr, and DCO_LOG); dcod writes nothing at "
        "debug level yet, so debug shows what info does");
  s.add("raw.enabled", &c.raw_enabled,
        "record the source's raw pairs on DCO_RAW (PNG, with calibration and IMU) for "
        "lcm-logger and lcmlog:// replay; SIGHUP turns it on and off");
  s.add("raw.png_level", &c.raw_png_level, 0, 9, "DCO_RAW zlib level (1: fast, most of the gain)");
  s.add("raw.max_message_bytes", &c.raw_max_message_bytes, 65536, 268435456,
        "larger DCO_RAW messages are not sent (udpm receivers need recv_buf_size above it)");
  pipeline::register_params(s, c.pipeline);
  pipeline::runtime::register_params(s, c.runtime);
}

bool is_pipeline_key(const std::string& key) {
  return key.starts_with("stereo.") || key.starts_with("contour.") || key.starts_with("densify.");
}

}  // namespace

std::string pipeline_keys(const LoadedConfig& config) {
  std::string out;
  for (const auto& [key, value] : config.values) {
    if (!is_pipeline_key(key)) continue;
    // --set takes strings bare: "stereo.mode=fast".
    const bool quoted = value.size() >= 2 && value.front() == '"' && value.back() == '"';
    out += key + "=" + (quoted ? value.substr(1, value.size() - 2) : value) + "\n";
  }
  return out;
}

LoadedConfig load_config(const ConfigSources& sources) {
  LoadedConfig out;
  ConfigSchema schema;
  register_params(schema, out.config);
  std::size_t begin = 0;
  while (begin < sources.recorded.size()) {
    std::size_t end = sources.recorded.find('\n', begin);
    if (end == std::string::npos) end = sources.recorded.size();
    const std::string line = sources.recorded.substr(begin, end - begin);
    begin = end + 1;
    if (line.empty()) continue;
    const std::string key = line.substr(0, line.find('='));
    if (!schema.has(key) || !is_pipeline_key(key)) {
      out.recorded_skipped.push_back(key);
      continue;
    }
    try {
      schema.set(line);
    } catch (const Error& e) {
      throw Error(fmt::format("the log's recorded pipeline: {}", e.what()));
    }
  }
  if (sources.file) schema.load_file(*sources.file);
  for (const std::string& s : sources.sets) schema.set(s);
  if (sources.source) {
    if (sources.source->empty()) throw Error("--source: empty URI");
    out.config.source = *sources.source;
  }
  if (out.config.source.empty()) throw Error("source.uri: empty (e.g. synthetic://hand)");
  // The checks below look at values together: name everything they may have come from.
  std::string where = sources.file ? sources.file->string() : std::string();
  if (!sources.sets.empty()) where += std::string(where.empty() ? "" : " with ") + "--set";
  if (where.empty()) where = "configuration";
  try {
    pipeline::validate(out.config.pipeline);
    pipeline::runtime::validate(out.config.runtime);
    drivers::check_source_uri(out.config.source);
    ipc::check_lcm_url(out.config.lcm_url);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", where, e.what()));
  }
  out.values = schema.values();
  out.toml = schema.to_toml();
  out.max_disparity_given = schema.was_set("stereo.max_disparity");
  return out;
}

std::vector<std::string> changed_keys(const LoadedConfig& before, const LoadedConfig& after) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < after.values.size() && i < before.values.size(); ++i)
    if (before.values[i] != after.values[i]) out.push_back(after.values[i].first);
  return out;
}

Reload reload_kind(const std::string& key) {
  const auto starts = [&](const char* prefix) { return key.rfind(prefix, 0) == 0; };
  // OpenCV's thread count is the process's (see Daemon::opencv_pin_).
  if (starts("source.") || starts("ring.") || key == "lcm.url" || key == "runtime.opencv_threads")
    return Reload::kRestart;
  if (starts("stereo.") || starts("contour.") || starts("densify.") || starts("runtime."))
    return Reload::kPipeline;
  return Reload::kLive;
}

}  // namespace dco::daemon
