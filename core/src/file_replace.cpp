#include "dco/core/file_replace.hpp"

#include <unistd.h>

#include <string>

#include "dco/core/error.hpp"

namespace dco {

void replace_file(const std::filesystem::path& path,
                  const std::function<void(const std::filesystem::path& tmp)>& write) {
  // Hidden, and named by the process, so two writers of one path do not share a temporary file.
  const std::filesystem::path tmp =
      path.parent_path() / ("." + path.filename().string() + "." + std::to_string(::getpid()) +
                            ".tmp" + path.extension().string());
  std::error_code ignored;
  try {
    write(tmp);
  } catch (...) {
    std::filesystem::remove(tmp, ignored);
    throw;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ignored);
    throw Error("cannot write '" + path.string() + "': " + ec.message());
  }
}

}  // namespace dco
