#pragma once

// A file written beside its name and renamed over it, for the client-side tools (dco-watch, the
// compositor), which stay off dco_core: a reader never sees half a file, a failed write (a full
// disk) leaves the last good one, and the temporary file is created under a name of its own
// (O_EXCL), so a link planted at a guessable name is never written through.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>

namespace dco::client_tools {

class ReplacingFile {
 public:
  // Opens the temporary file; on failure file() is null and error() says why.
  explicit ReplacingFile(std::string path) : path_(std::move(path)), temp_(path_ + ".XXXXXX") {
    const int fd = mkstemp(temp_.data());
    if (fd < 0) {
      error_ = temp_ + ": " + std::strerror(errno);
      temp_.clear();
      return;
    }
    fchmod(fd, 0644);  // mkstemp's 0600 would keep the output from everyone else
    file_ = fdopen(fd, "wb");
    if (file_ == nullptr) {
      error_ = temp_ + ": " + std::strerror(errno);
      close(fd);
    }
  }
  ReplacingFile(const ReplacingFile&) = delete;
  ReplacingFile& operator=(const ReplacingFile&) = delete;
  // A file never committed is removed.
  ~ReplacingFile() {
    if (file_ != nullptr) std::fclose(file_);
    if (!temp_.empty()) std::remove(temp_.c_str());
  }

  std::FILE* file() const { return file_; }
  const std::string& error() const { return error_; }

  // Closes the temporary file and renames it over the path; false (error() says why) when a
  // write failed (`written` false, called straight after it, while errno still says why), the
  // close or the rename fails; the temporary file is then removed.
  bool commit(bool written = true) {
    if (file_ == nullptr) return false;
    int err = written ? 0 : (errno != 0 ? errno : EIO);
    if (std::fclose(file_) != 0 && err == 0) err = errno;
    file_ = nullptr;
    if (err == 0 && std::rename(temp_.c_str(), path_.c_str()) != 0) err = errno;
    if (err != 0) {
      error_ = path_ + ": " + std::strerror(err);
      return false;
    }
    temp_.clear();
    return true;
  }

 private:
  std::string path_, temp_, error_;
  std::FILE* file_ = nullptr;
};

}  // namespace dco::client_tools
