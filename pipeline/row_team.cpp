#include "dco/pipeline/row_team.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"
#include "dco/core/usable_cpus.hpp"

namespace dco::pipeline {

RowTeam::RowTeam(int threads) : threads_(threads) {
  if (threads < 1 || threads > 64)
    throw Error("row team: " + std::to_string(threads) + " threads, expected 1..64");
  helpers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int part = 1; part < threads; ++part)
    helpers_.emplace_back([this, part](std::stop_token stop) {
      name_this_thread("dco-rows");
      helper_loop(stop, part);
    });
}

RowTeam::~RowTeam() {
  // jthread's destructor asks each helper to stop; the helpers wait on wake_ with their stop
  // token, so they leave at once. Joined here, before the members they read go.
  for (auto& h : helpers_) h.request_stop();
  helpers_.clear();
}

int RowTeam::threads_for(int row_threads) {
  if (row_threads > 0) return row_threads;
  const int cpus = usable_cpus();
  return cpus < 4 ? 1 : std::min(4, cpus / 2);
}

int RowTeam::block_begin(int rows, int part, int parts) {
  return static_cast<int>(static_cast<long long>(rows) * part / parts);
}

void RowTeam::run_erased(int rows, Call call, void* body) {
  if (threads_ == 1 || rows < threads_) {
    call(body, 0, 0, rows);
    return;
  }
  {
    std::lock_guard lock(mutex_);
    rows_ = rows;
    call_ = call;
    body_ = body;
    pending_ = threads_ - 1;
    error_ = nullptr;
    ++generation_;
  }
  wake_.notify_all();
  std::exception_ptr mine;
  try {
    call(body, 0, 0, block_begin(rows, 1, threads_));
  } catch (...) {
    mine = std::current_exception();
  }
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return pending_ == 0; });
  if (mine) std::rethrow_exception(mine);
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void RowTeam::helper_loop(std::stop_token stop, int part) {
  unsigned seen = 0;
  std::unique_lock lock(mutex_);
  while (wake_.wait(lock, stop, [&] { return generation_ != seen; })) {
    seen = generation_;
    const int begin = block_begin(rows_, part, threads_);
    const int end = block_begin(rows_, part + 1, threads_);
    const Call call = call_;
    void* body = body_;
    lock.unlock();
    std::exception_ptr error;
    try {
      call(body, part, begin, end);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error && !error_) error_ = error;
    if (--pending_ == 0) done_.notify_one();
  }
}

}  // namespace dco::pipeline
