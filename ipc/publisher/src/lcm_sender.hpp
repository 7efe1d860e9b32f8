#pragma once

// LCM traffic off the frame path. LCM sends synchronously on a blocking socket: a tcpq peer that
// stopped reading, or a slow link under a multi-megabyte DCO_RAW message, holds the sending
// thread for as long as it lasts. Callers therefore hand encoded messages to a bounded queue and
// one thread of the sender's own sends them, so such a send delays LCM only, never the ring's
// readers or the watchdog, and a stop by a second or so at most.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace lcm {
class LCM;
}

namespace dco::ipc::detail {

class LcmSender {
 public:
  // queue_length: small messages waiting at most; message_bytes: the room each one has from the
  // start, so the queue allocates nothing once messages fit it.
  LcmSender(std::size_t queue_length, std::size_t message_bytes);
  // Sends what waits for up to kStopWait (not at all when the last flush() ran out), then stops.
  // A send that does not return by then (the network holds it) is abandoned with its thread and
  // LCM instance: the process is ending.
  ~LcmSender();
  LcmSender(const LcmSender&) = delete;
  LcmSender& operator=(const LcmSender&) = delete;

  static constexpr std::chrono::milliseconds kStopWait{1000};

  // Installs LCM once it is set up; until then every message counts as a failure.
  void set_lcm(std::unique_ptr<lcm::LCM> lcm);
  lcm::LCM* lcm() const;  // nullptr while none is installed

  // Queues a copy of `size` bytes for `channel`. Never waits
  // for the network: when the queue is full the oldest waiting message gives way and counts as
  // a failure.
  void post(const std::string& channel, const std::uint8_t* data, std::size_t size);
  // Counts a message the caller could not even encode.
  void count_failure(const std::string& channel);

  // One large message at a time, sent in its turn among the others, with its outcome: the
  // buffer to fill, once the previous large message is no longer being sent (nullptr when it
  // still is after `wait`, or at once while blocked()), then send_large, which waits up to
  // `wait` for the send. kTimedOut: it never started (the network holds an earlier send) and is
  // dropped, a failure; kStillSending: LCM holds it in its own send, which may yet finish (a
  // send that then fails counts as a failure).
  std::vector<std::uint8_t>* acquire_large(std::chrono::milliseconds wait);
  enum class LargeOutcome : std::int8_t { kSent, kFailed, kTimedOut, kStillSending };
  LargeOutcome send_large(const std::string& channel, std::size_t size,
                          std::chrono::milliseconds wait);

  // Whether a large message's wait ran out (the network holds a send) and no send has finished
  // since: large messages are then refused at once.
  bool blocked() const;

  // Waits until every queued message has been handed to LCM; false when `wait` ran out first.
  bool flush(std::chrono::milliseconds wait);

  std::uint64_t failures() const;
  const char* last_failed_channel() const;

 private:
  struct State;
  static void run(const std::shared_ptr<State>& state);

  std::shared_ptr<State> state_;  // shared with the thread, which may outlive an abandoned stop
  std::thread thread_;
};

}  // namespace dco::ipc::detail
