#pragma once

#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dco/ipc/publisher.hpp"

namespace dco::daemon {

using ipc::LogLevel;

// Parses "debug" | "info" | "warning" | "error"; throws dco::Error otherwise.
LogLevel parse_log_level(std::string_view name);

// dcod's log: to the journal (with its priority) when stderr is connected to it, else one line
// per message on stderr; every message at or above the level also goes to a forwarder (DCO_LOG).
// Thread-safe.
class Logger {
 public:
  using Forward = std::function<void(LogLevel, std::string_view)>;

  Logger();

  void set_level(LogLevel level);
  // Installs (or with {} removes) the forwarder; it must not log itself. A forwarder installed
  // after hold_for_forward() first gets the messages held since.
  void set_forward(Forward forward);
  // Keeps the messages logged from now until a forwarder is installed (the first kMaxHeld), so
  // that the forwarder gets what was logged before it could exist.
  void hold_for_forward();
  static constexpr std::size_t kMaxHeld = 100;

  void log(LogLevel level, std::string_view text);
  void debug(std::string_view text) { log(LogLevel::kDebug, text); }
  void info(std::string_view text) { log(LogLevel::kInfo, text); }
  void warning(std::string_view text) { log(LogLevel::kWarning, text); }
  void error(std::string_view text) { log(LogLevel::kError, text); }

  bool to_journal() const { return journal_; }

 private:
  void send_forward(LogLevel level, const std::string& line);  // under mutex_

  std::mutex mutex_;
  LogLevel level_ = LogLevel::kInfo;
  bool journal_ = false;
  Forward forward_;
  bool holding_ = false;
  std::vector<std::pair<LogLevel, std::string>> held_;
};

}  // namespace dco::daemon
