// dcod: the depth service. Owns the camera (or a stand-in), runs the depth pipeline in real time
// and publishes every depth map to the shared-memory ring and LCM.

#include <signal.h>

#include <cstdio>
#include <string>
#include <string_view>

#include "dco/core/error.hpp"
#include "dco/core/memory_policy.hpp"
#include "dco/core/printable.hpp"
#include "dco/daemon/daemon.hpp"
#include "dco/daemon/daemon_config.hpp"
#include "dco/daemon/logger.hpp"

namespace {

constexpr std::string_view kUsage =
    R"(usage: dcod [--config FILE] [--set KEY=VALUE]... [--source URI] [--print-config]

Runs the depth pipeline on a camera, a recording or the synthetic demo scene and publishes dense
depth to the shared-memory ring (ring.path) and LCM (DCO_DEPTH, DCO_STATS, DCO_STATUS, DCO_LOG,
DCO_DEPTH_PREVIEW). Under systemd it reports readiness, status and health (Type=notify with a
watchdog); SIGTERM stops it, SIGHUP reloads the configuration file.

  --config FILE     TOML configuration (every key: --print-config, or the README)
  --set KEY=VALUE   override one key after the file, e.g. --set lcm.preview_hz=5
  --source URI      same as --set source.uri=URI: synthetic://hand?width=640&height=360&fps=30,
                    replay://DIR?fps=30&loop=1
  --print-config    print the effective configuration as TOML and exit
  -h, --help        print this help

Exit status: 0 clean stop, 1 failure at run time (logged), 2 bad command line or configuration.
)";

int usage_error(const std::string& message) {
  std::fprintf(stderr, "dcod: %s\n(dcod --help for usage)\n", message.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  dco::retain_freed_memory();  // before any thread starts: see memory_policy.hpp
  // First of all: a reload or stop sent while the configuration is still being read then waits
  // for the daemon instead of killing it.
  dco::daemon::block_service_signals();
  signal(SIGPIPE, SIG_IGN);
  // A write past a file size limit (LimitFSIZE=, ulimit -f) is then an error the writer reports,
  // not the end of the daemon.
  signal(SIGXFSZ, SIG_IGN);
  dco::daemon::ConfigSources sources;
  bool print_config = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "-h" || arg == "--help") {
      std::fputs(kUsage.data(), stdout);
      return 0;
    } else if (arg == "--print-config") {
      print_config = true;
    } else if (arg == "--config" && has_value) {
      sources.file = argv[++i];
    } else if (arg == "--set" && has_value) {
      sources.sets.emplace_back(argv[++i]);
    } else if (arg == "--source" && has_value) {
      sources.source = argv[++i];
    } else if (arg == "--config" || arg == "--set" || arg == "--source") {
      return usage_error(std::string(arg) + " needs a value");
    } else {
      return usage_error("unknown argument '" + dco::printable(arg) + "'");
    }
  }

  dco::daemon::LoadedConfig config;
  dco::daemon::Logger log;
  try {
    config = dco::daemon::load_config(sources);
    log.set_level(dco::daemon::parse_log_level(config.config.log_level));
  } catch (const dco::Error& e) {
    // Through the log: under systemd the journal then has it at error priority.
    log.error(e.what());
    return 2;
  }
  if (print_config) {
    std::fputs("# dcod: effective configuration\n\n", stdout);
    std::fputs(config.toml.c_str(), stdout);
    return 0;
  }

  try {
    dco::daemon::Daemon daemon(sources, std::move(config), log);
    return daemon.run();
  } catch (const std::exception& e) {
    log.error(e.what());
    return 1;
  }
}
