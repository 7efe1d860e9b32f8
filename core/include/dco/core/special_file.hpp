#pragma once

#include <filesystem>
#include <system_error>

namespace dco {

// Whether `path` names something other than a regular file: a directory (which reads as empty), a
// device, or a pipe (whose open blocks until its other end comes). A missing path is not one.
inline bool is_special_file(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec);
}

}  // namespace dco
