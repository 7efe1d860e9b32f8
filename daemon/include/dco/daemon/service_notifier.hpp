#pragma once

#include <chrono>
#include <optional>
#include <string_view>

namespace dco::daemon {

// The sd_notify protocol (READY, STATUS, RELOADING, STOPPING, WATCHDOG) through libsystemd. When
// the service manager did not ask for notifications (no $NOTIFY_SOCKET) every call is a no-op,
// so the daemon runs the same by hand.
class ServiceNotifier {
 public:
  ServiceNotifier();  // reads $NOTIFY_SOCKET and $WATCHDOG_USEC/$WATCHDOG_PID once

  void ready(std::string_view status) const;
  void status(std::string_view status) const;
  void reloading() const;
  void stopping() const;
  void watchdog() const;

  // The watchdog period the manager expects pings within, if it set one for this process.
  std::optional<std::chrono::microseconds> watchdog_period() const { return watchdog_; }

 private:
  void send(std::string_view message) const;
  std::optional<std::chrono::microseconds> watchdog_;
};

}  // namespace dco::daemon
