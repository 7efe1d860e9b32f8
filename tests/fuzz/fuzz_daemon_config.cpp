// Entry point: arbitrary bytes as dcod's TOML configuration file, and as the "key=value" pipeline
// lines a recording carries. Bad input must be refused with a dco::Error; a configuration that is
// accepted must read back to the same values from the TOML it reports (dcod --print-config) and,
// for its pipeline keys, from the lines it records (DCO_RAW).

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "dco/core/error.hpp"
#include "dco/daemon/daemon_config.hpp"
#include "fuzz_target.hpp"
#include "scratch_dir.hpp"

namespace {

using dco::daemon::ConfigSources;
using dco::daemon::LoadedConfig;

std::optional<LoadedConfig> load(const ConfigSources& sources) {
  try {
    return dco::daemon::load_config(sources);
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return std::nullopt;
  }
}

void check_reads_back(const LoadedConfig& config, const dco::fuzz::ScratchDir& dir) {
  ConfigSources from_toml;
  from_toml.file = dir.write("again.toml", config.toml);
  const std::optional<LoadedConfig> reread = load(from_toml);
  if (!reread || reread->values != config.values) std::abort();

  ConfigSources from_lines;
  from_lines.recorded = dco::daemon::pipeline_keys(config);
  const std::optional<LoadedConfig> recorded = load(from_lines);
  if (!recorded || dco::daemon::pipeline_keys(*recorded) != from_lines.recorded) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dco::fuzz::ScratchDir dir("daemon_config");
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  ConfigSources from_file;
  from_file.file = dir.write("dcod.toml", text);
  if (const auto config = load(from_file)) check_reads_back(*config, dir);

  ConfigSources from_lines;
  from_lines.recorded = std::string(text);
  if (const auto config = load(from_lines)) check_reads_back(*config, dir);
  return 0;
}
