#pragma once

// LCM's set-up off the caller's thread. lcm_create for tcpq connects and then waits for the
// server's answer on a blocking socket without a timeout: a server that accepts and never
// answers holds it for ever, a host that drops the connection's packets for minutes. One attempt
// runs on a thread of its own and the caller waits for it only as long as it chooses.

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>

namespace lcm {
class LCM;
}

namespace dco::ipc::detail {

class LcmSetup {
 public:
  // Starts constructing lcm::LCM(url).
  explicit LcmSetup(const std::string& url);
  // Joins an attempt that has ended; one that has not is left to end by itself with its thread
  // (it owns what it shares): the publisher is going away.
  ~LcmSetup();
  LcmSetup(const LcmSetup&) = delete;
  LcmSetup& operator=(const LcmSetup&) = delete;

  // Waits up to `wait` for the attempt to end. nullopt while it still runs; once it has ended,
  // the LCM instance when it is good, else nullptr (LCM has said why on stderr). The instance is
  // handed out once.
  std::optional<std::unique_ptr<lcm::LCM>> result(std::chrono::milliseconds wait);
  // How long this attempt has run.
  std::chrono::steady_clock::duration age() const;
  // Attempts in this process that have not ended, left behind ones included.
  static int running();

 private:
  struct State;
  std::shared_ptr<State> state_;
  std::chrono::steady_clock::time_point started_;
  std::thread thread_;
};

}  // namespace dco::ipc::detail
