#include "lcm_sender.hpp"

#include <algorithm>
#include <deque>
#include <mutex>

#include <lcm/lcm-cpp.hpp>

#include "dco/core/priority_inheritance_condition.hpp"
#include "dco/core/priority_inheritance_mutex.hpp"
#include "dco/core/thread_name.hpp"

namespace dco::ipc::detail {

struct LcmSender::State {
  struct Message {
    const std::string* channel = nullptr;
    std::vector<std::uint8_t> bytes;
    std::uint64_t order = 0;
  };
  enum class Large : std::int8_t { kIdle, kQueued, kSending };

  // Posted to by dcod's release thread, which may run at SCHED_FIFO: the sending thread, holding
  // it to take the next message, is lent that priority rather than preempted with it held.
  PriorityInheritanceMutex mutex;
  PriorityInheritanceCondition changed;
  std::unique_ptr<lcm::LCM> lcm;
  std::vector<Message> queue;  // a ring: head, count
  std::size_t head = 0, count = 0;
  std::uint64_t next_order = 0;
  bool sending_small = false;
  std::vector<std::uint8_t> sending;  // the small message in flight (swapped out of the queue)
  std::vector<std::uint8_t> large_bytes;
  const std::string* large_channel = nullptr;
  std::size_t large_size = 0;
  std::uint64_t large_order = 0, large_done = 0;
  Large large = Large::kIdle;
  bool large_sent = false;
  // A large message's wait ran out while the network held a send, and no send has finished
  // since: the next large message is refused at once.
  bool blocked = false;
  std::uint64_t failures = 0;
  const char* last_failed_channel = "";
  bool stopping = false, exited = false;
  bool flush_timed_out = false;  // the owner already waited for a network that held a send
  // The channels' names, the state's own: a thread left blocked at the exit outlives the
  // callers' strings.
  std::deque<std::string> names;

  bool idle() const { return count == 0 && !sending_small && large == Large::kIdle; }
  void failed(const std::string& channel) {
    ++failures;
    last_failed_channel = channel.c_str();
  }
  const std::string& name(const std::string& channel) {
    for (const std::string& n : names)
      if (n == channel) return n;
    return names.emplace_back(channel);
  }
};

LcmSender::LcmSender(std::size_t queue_length, std::size_t message_bytes)
    : state_(std::make_shared<State>()) {
  state_->queue.resize(std::max<std::size_t>(queue_length, 1));
  for (State::Message& m : state_->queue) m.bytes.reserve(message_bytes);
  state_->sending.reserve(message_bytes);
  thread_ = std::thread([state = state_] {
    name_this_thread("dco-lcm-send");
    run(state);
  });
}

LcmSender::~LcmSender() {
  std::unique_lock lock(state_->mutex);
  state_->stopping = true;
  state_->changed.notify_all();
  // Not again after a flush that ran out: the network holds a send.
  const auto wait = state_->flush_timed_out ? std::chrono::milliseconds(0) : kStopWait;
  if (state_->changed.wait_for(lock, wait, [&] { return state_->exited; })) {
    lock.unlock();
    thread_.join();
  } else {
    // The thread keeps the state (and the LCM instance it is blocked in) alive by itself.
    lock.unlock();
    thread_.detach();
  }
}

void LcmSender::run(const std::shared_ptr<State>& state) {
  State& s = *state;
  std::unique_lock lock(s.mutex);
  for (;;) {
    s.changed.wait(lock,
                   [&] { return s.stopping || s.count > 0 || s.large == State::Large::kQueued; });
    const bool large_waits = s.large == State::Large::kQueued;
    if (s.count == 0 && !large_waits) break;  // stopping, and everything went out
    lcm::LCM* const lcm = s.lcm.get();
    if (large_waits && (s.count == 0 || s.large_order < s.queue[s.head].order)) {
      s.large = State::Large::kSending;
      const std::string& channel = *s.large_channel;
      const std::size_t size = s.large_size;
      lock.unlock();
      // The buffer is the sender's while kSending: acquire_large hands it out only when idle.
      const bool sent = lcm != nullptr && lcm->publish(channel, s.large_bytes.data(),
                                                       static_cast<unsigned>(size)) == 0;
      lock.lock();
      if (!sent) s.failed(channel);
      s.large = State::Large::kIdle;
      s.large_sent = sent;
      s.blocked = false;
      ++s.large_done;
    } else {
      State::Message& m = s.queue[s.head];
      s.sending.swap(m.bytes);
      const std::string& channel = *m.channel;
      s.head = (s.head + 1) % s.queue.size();
      --s.count;
      s.sending_small = true;
      lock.unlock();
      const bool sent =
          lcm != nullptr &&
          lcm->publish(channel, s.sending.data(), static_cast<unsigned>(s.sending.size())) == 0;
      lock.lock();
      if (!sent) s.failed(channel);
      s.sending_small = false;
      s.blocked = false;
    }
    s.changed.notify_all();
  }
  s.exited = true;
  s.changed.notify_all();
}

void LcmSender::set_lcm(std::unique_ptr<lcm::LCM> lcm) {
  std::lock_guard lock(state_->mutex);
  if (!state_->lcm) state_->lcm = std::move(lcm);
}

lcm::LCM* LcmSender::lcm() const {
  std::lock_guard lock(state_->mutex);
  return state_->lcm.get();
}

void LcmSender::post(const std::string& channel, const std::uint8_t* data, std::size_t size) {
  State& s = *state_;
  std::lock_guard lock(s.mutex);
  const std::string& name = s.name(channel);
  if (!s.lcm) {
    s.failed(name);  // nothing to send it with: not queued behind messages that will fail too
    return;
  }
  if (s.count == s.queue.size()) {
    s.failed(*s.queue[s.head].channel);
    s.head = (s.head + 1) % s.queue.size();
    --s.count;
  }
  State::Message& m = s.queue[(s.head + s.count) % s.queue.size()];
  m.channel = &name;
  m.bytes.assign(data, data + size);
  m.order = s.next_order++;
  ++s.count;
  s.changed.notify_all();
}

void LcmSender::count_failure(const std::string& channel) {
  std::lock_guard lock(state_->mutex);
  state_->failed(state_->name(channel));
}

bool LcmSender::blocked() const {
  std::lock_guard lock(state_->mutex);
  return state_->blocked;
}

std::vector<std::uint8_t>* LcmSender::acquire_large(std::chrono::milliseconds wait) {
  State& s = *state_;
  std::unique_lock lock(s.mutex);
  // A network that already held a send past one wait is not waited for again: the caller hears
  // at once, and a stop is not held up pair after pair.
  if (s.blocked || !s.changed.wait_for(lock, wait, [&] { return s.large == State::Large::kIdle; }))
    return nullptr;
  return &s.large_bytes;
}

LcmSender::LargeOutcome LcmSender::send_large(const std::string& channel, std::size_t size,
                                              std::chrono::milliseconds wait) {
  State& s = *state_;
  std::unique_lock lock(s.mutex);
  const std::string& name = s.name(channel);
  if (!s.lcm) {
    s.failed(name);
    return LargeOutcome::kFailed;
  }
  s.large_channel = &name;
  s.large_size = std::min(size, s.large_bytes.size());
  s.large_order = s.next_order++;
  s.large = State::Large::kQueued;
  const std::uint64_t done_before = s.large_done;
  s.changed.notify_all();
  if (!s.changed.wait_for(lock, wait, [&] { return s.large_done != done_before; })) {
    // Held either way: in its own send, or behind another one the network holds.
    s.blocked = true;
    if (s.large != State::Large::kQueued) return LargeOutcome::kStillSending;
    s.large = State::Large::kIdle;  // not sent: the buffer is free again
    s.failed(name);
    return LargeOutcome::kTimedOut;
  }
  return s.large_sent ? LargeOutcome::kSent : LargeOutcome::kFailed;
}

bool LcmSender::flush(std::chrono::milliseconds wait) {
  std::unique_lock lock(state_->mutex);
  const bool flushed = state_->changed.wait_for(lock, wait, [&] { return state_->idle(); });
  state_->flush_timed_out = !flushed;
  return flushed;
}

std::uint64_t LcmSender::failures() const {
  std::lock_guard lock(state_->mutex);
  return state_->failures;
}

const char* LcmSender::last_failed_channel() const {
  std::lock_guard lock(state_->mutex);
  return state_->last_failed_channel;
}

}  // namespace dco::ipc::detail
