#include "dco/daemon/service_notifier.hpp"

#include <systemd/sd-daemon.h>

#include <string>

#include "dco/core/printable.hpp"

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

// A status quotes the source (a file path, a device name): its control characters are shown as
// '?', so a line break in them cannot add an assignment such as WATCHDOG=1 to the message.
void ServiceNotifier::ready(std::string_view status) const {
  send("READY=1\nSTATUS=" + printable(status));
}

void ServiceNotifier::status(std::string_view status) const {
  send("STATUS=" + printable(status));
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
