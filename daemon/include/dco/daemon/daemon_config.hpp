#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/runtime/runtime_params.hpp"

namespace dco::daemon {

// Everything dcod reads from its TOML file and --set overrides. Keys are documented in the
// README's configuration reference (`dcod --print-config` prints them with their docs).
struct DaemonConfig {
  std::string source = "synthetic://hand";  // source.uri
  std::string ring_path;                    // ring.path; "" = runtime directory/depth.shm
  int ring_slots = 4;                       // ring.slots
  bool ring_image = true;                   // ring.image
  std::string lcm_url;                      // lcm.url; "" = LCM's default
  double preview_hz = 2;                    // lcm.preview_hz
  double stats_hz = 1;                      // lcm.stats_hz
  double stall_timeout_s = 3;               // service.stall_timeout_s
  int max_frames = 0;                       // service.max_frames
  std::string log_level = "info";           // log.level
  bool raw_enabled = false;                 // raw.enabled
  int raw_png_level = 1;                    // raw.png_level
  int raw_max_message_bytes = 4'000'000;    // raw.max_message_bytes
  pipeline::PipelineParams pipeline;
  pipeline::runtime::RuntimeParams runtime;
};

// Where a configuration comes from: read again, in the same order, on SIGHUP.
struct ConfigSources {
  std::optional<std::filesystem::path> file;  // --config
  std::vector<std::string> sets;              // --set key=value, in order
  std::optional<std::string> source;          // --source URI (after the file and the --sets)
  // "key=value" lines a replayed log recorded (the headset's pipeline), before the file: what
  // the engineer sets wins. Keys this build does not know are skipped.
  std::string recorded;
};

struct LoadedConfig {
  DaemonConfig config;
  std::vector<std::pair<std::string, std::string>> values;  // key -> value as TOML writes it
  std::string toml;                                         // the effective config, commented
  bool max_disparity_given = false;           // stereo.max_disparity came from the file or a --set
  std::vector<std::string> recorded_skipped;  // recorded keys unknown to this build
};

// The algorithm's keys (stereo., contour., densify.) as "key=value" lines, for DCO_RAW.
std::string pipeline_keys(const LoadedConfig& config);

// Defaults, then the file, then the overrides. Throws dco::Error with "FILE:LINE: reason" (or the
// override) for unknown keys and bad values, and with the parameter for invalid combinations.
LoadedConfig load_config(const ConfigSources& sources);

// Keys whose value differs between two configurations, in registration order.
std::vector<std::string> changed_keys(const LoadedConfig& before, const LoadedConfig& after);

// What a SIGHUP can change without a restart.
enum class Reload {
  kLive,      // applied at once (rates, log level, timeouts)
  kPipeline,  // applied by restarting the stage threads between two frames
  kRestart,   // the source, the ring geometry and the LCM bus: only a restart changes them
};
Reload reload_kind(const std::string& key);

}  // namespace dco::daemon
