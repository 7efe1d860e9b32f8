#include "lcm_setup.hpp"

#include <atomic>
#include <condition_variable>
#include <mutex>

#include <lcm/lcm-cpp.hpp>

#include "dco/core/thread_name.hpp"

namespace dco::ipc::detail {
namespace {

std::atomic<int> g_running{0};

}  // namespace

struct LcmSetup::State {
  std::mutex mutex;
  std::condition_variable ended_cv;
  bool ended = false;
  std::unique_ptr<lcm::LCM> lcm;  // the good instance, until handed out
};

LcmSetup::LcmSetup(const std::string& url)
    : state_(std::make_shared<State>()), started_(std::chrono::steady_clock::now()) {
  ++g_running;
  try {
    thread_ = std::thread([state = state_, url] {
      name_this_thread("dco-lcm-setup");
      auto lcm = std::make_unique<lcm::LCM>(url);
      std::lock_guard lock(state->mutex);
      if (lcm->good()) state->lcm = std::move(lcm);
      state->ended = true;
      state->ended_cv.notify_all();
      --g_running;
    });
  } catch (...) {
    --g_running;
    throw;
  }
}

std::chrono::steady_clock::duration LcmSetup::age() const {
  return std::chrono::steady_clock::now() - started_;
}

int LcmSetup::running() {
  return g_running.load();
}

LcmSetup::~LcmSetup() {
  bool ended = false;
  {
    std::lock_guard lock(state_->mutex);
    ended = state_->ended;
  }
  if (ended)
    thread_.join();
  else
    thread_.detach();
}

std::optional<std::unique_ptr<lcm::LCM>> LcmSetup::result(std::chrono::milliseconds wait) {
  std::unique_lock lock(state_->mutex);
  if (!state_->ended_cv.wait_for(lock, wait, [&] { return state_->ended; })) return std::nullopt;
  return std::move(state_->lcm);
}

}  // namespace dco::ipc::detail
