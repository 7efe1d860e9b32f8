#include "dco/daemon/logger.hpp"

#include <sys/stat.h>
#include <syslog.h>
#include <systemd/sd-journal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "dco/core/error.hpp"
#include "dco/core/printable.hpp"

namespace dco::daemon {
namespace {

// systemd sets $JOURNAL_STREAM to "DEVICE:INODE" of the stream it connected stdout/stderr to.
bool stderr_is_journal() {
  const char* env = std::getenv("JOURNAL_STREAM");
  if (env == nullptr) return false;
  struct stat st {};
  if (fstat(STDERR_FILENO, &st) != 0) return false;
  unsigned long long dev = 0, ino = 0;
  if (std::sscanf(env, "%llu:%llu", &dev, &ino) != 2) return false;
  return dev == static_cast<unsigned long long>(st.st_dev) &&
         ino == static_cast<unsigned long long>(st.st_ino);
}

int priority(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return LOG_DEBUG;
    case LogLevel::kInfo:
      return LOG_INFO;
    case LogLevel::kWarning:
      return LOG_WARNING;
    case LogLevel::kError:
      return LOG_ERR;
  }
  return LOG_INFO;
}

const char* name(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return "debug";
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kError:
      return "error";
  }
  return "info";
}

}  // namespace

LogLevel parse_log_level(std::string_view text) {
  for (const LogLevel l : {LogLevel::kDebug, LogLevel::kInfo, LogLevel::kWarning, LogLevel::kError})
    if (text == name(l)) return l;
  throw Error("log.level: '" + std::string(text) + "' is not debug, info, warning or error");
}

Logger::Logger() : journal_(stderr_is_journal()) {}

void Logger::set_level(LogLevel level) {
  std::lock_guard lock(mutex_);
  level_ = level;
}

void Logger::set_forward(Forward forward) {
  std::lock_guard lock(mutex_);
  forward_ = std::move(forward);
  if (forward_)
    for (const auto& [level, line] : held_) send_forward(level, line);
  held_.clear();
  holding_ = false;
}

void Logger::hold_for_forward() {
  std::lock_guard lock(mutex_);
  holding_ = true;
}

void Logger::send_forward(LogLevel level, const std::string& line) {
  try {
    forward_(level, line);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dcod: error: DCO_LOG: %s\n", e.what());
  }
}

void Logger::log(LogLevel level, std::string_view text) {
  std::lock_guard lock(mutex_);
  if (level < level_) return;
  // One line each, whatever a message quotes (a URI, an argument, a device's string).
  const std::string line = printable(text);
  if (journal_)
    sd_journal_send("MESSAGE=%s", line.c_str(), "PRIORITY=%i", priority(level),
                    "SYSLOG_IDENTIFIER=dcod", nullptr);
  else
    std::fprintf(stderr, "dcod: %s: %s\n", name(level), line.c_str());
  if (forward_)
    send_forward(level, line);
  else if (holding_ && held_.size() < kMaxHeld)
    held_.emplace_back(level, line);
}

}  // namespace dco::daemon
