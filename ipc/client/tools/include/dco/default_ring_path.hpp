#pragma once

// Where the client-side tools (dco-watch, the compositor) look for the depth ring when they are
// given no path: where dcod puts it (RingWriter::default_directory), as a client can tell.

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace dco::client_tools {

inline constexpr const char* kServiceRingPath = "/run/dcod/depth.shm";

// The service's ring, else the one dcod run by hand by this user writes ($XDG_RUNTIME_DIR/dcod,
// else dcod-<uid> in the temp directory), whichever exists; the service's when none does, so
// that the error names it.
inline std::string default_ring_path() {
  std::error_code ec;
  if (std::filesystem::exists(kServiceRingPath, ec)) return kServiceRingPath;
  if (const char* xdg = std::getenv("XDG_RUNTIME_DIR"); xdg != nullptr && *xdg == '/') {
    const std::filesystem::path p = std::filesystem::path(xdg) / "dcod" / "depth.shm";
    if (std::filesystem::exists(p, ec)) return p.string();
  }
  const std::filesystem::path tmp =
      std::filesystem::temp_directory_path(ec) / ("dcod-" + std::to_string(getuid())) / "depth.shm";
  if (!ec && std::filesystem::exists(tmp, ec)) return tmp.string();
  return kServiceRingPath;
}

}  // namespace dco::client_tools
