#include "dco/daemon/service_notifier.hpp"

#include <systemd/sd-daemon.h>

#include <string>

namespace dco::daemon {

ServiceNotifier::ServiceNotifier() {
  std::uint64_t usec = 0;
  // Keeps the variables: the manager's watchdog settings belong to this process (WATCHDOG_PID).
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0)
    watchdog_ = std::chrono::microseconds(static_cast<std::int64_t>(usec));
}

void ServiceNotifier::send(std::string_view message) const {
  sd_notify(0, std::string(message).c_str());
}

void ServiceNotifier::ready(std::string_view status) const {
  send("READY=1\nSTATUS=" + std::string(status));
}

void ServiceNotifier::status(std::string_view status) const {
  send("STATUS=" + std::string(status));
}

void ServiceNotifier::reloading() const {
  send("RELOADING=1");
}

void ServiceNotifier::stopping() const {
  send("STOPPING=1");
}

void ServiceNotifier::watchdog() const {
  send("WATCHDOG=1");
}

}  // namespace dco::daemon
