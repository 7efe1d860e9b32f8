#include "dco/core/file_replace.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>

#include "dco/core/error.hpp"

namespace dco {
namespace {

namespace fs = std::filesystem;

// The file a path names, through its symbolic links: a link to an output is written through,
// not replaced by a file of its own (nor, run as root, a system link such as /dev/stdout).
fs::path through_links(const fs::path& path) {
  fs::path p = path;
  for (int hops = 0; hops < 40; ++hops) {
    std::error_code ec;
    if (!fs::is_symlink(p, ec)) return p;
    const fs::path target = fs::read_symlink(p, ec);
    if (ec) throw Error("cannot write '" + path.string() + "': " + ec.message());
    p = target.is_absolute() ? target : p.parent_path() / target;
  }
  throw Error("cannot write '" + path.string() + "': too many levels of symbolic links");
}

// A temporary name no other writer of this process or another uses: hidden, with the process
// id and a count, ending as `like` does (OpenCV picks the format by the extension).
fs::path temporary_name(const fs::path& dir, const fs::path& like) {
  static std::atomic<unsigned> count{0};
  return dir / ("." + like.filename().string() + "." + std::to_string(::getpid()) + "." +
                std::to_string(count++) + ".tmp" + like.extension().string());
}

void write_temporary(const fs::path& tmp, const std::function<void(const fs::path& tmp)>& write) {
  try {
    write(tmp);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

// A FIFO or a device (`--json /dev/stdout`): nothing to rename over, so the bytes written
// elsewhere go to it in place.
void write_into(const fs::path& path, const fs::path& target,
                const std::function<void(const fs::path& tmp)>& write) {
  const fs::path tmp = temporary_name(fs::temp_directory_path(), target);
  write_temporary(tmp, write);
  std::error_code ignored;
  std::ifstream in(tmp, std::ios::binary);
  std::ofstream out(target, std::ios::binary);
  const int err = errno;
  if (!in || !out) {
    fs::remove(tmp, ignored);
    throw Error("cannot write '" + path.string() + "': " + std::strerror(err));
  }
  out << in.rdbuf();
  out.flush();
  const bool ok = static_cast<bool>(out);
  const int write_err = errno;
  fs::remove(tmp, ignored);
  if (!ok) throw Error("cannot write '" + path.string() + "': " + std::strerror(write_err));
}

}  // namespace

void replace_file(const fs::path& path, const std::function<void(const fs::path& tmp)>& write) {
  const fs::path target = through_links(path);
  std::error_code ec;
  if (const fs::file_status s = fs::status(target, ec);
      fs::exists(s) && !fs::is_regular_file(s) && !fs::is_directory(s)) {
    write_into(path, target, write);
    return;
  }
  // Beside the file, so the rename stays within its file system.
  const fs::path tmp = temporary_name(target.parent_path(), target);
  write_temporary(tmp, write);
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("cannot write '" + path.string() + "': " + ec.message());
  }
}

}  // namespace dco
