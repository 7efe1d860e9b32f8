#pragma once

#include <condition_variable>
#include <exception>
#include <mutex>
#include <stop_token>
#include <thread>
#include <type_traits>
#include <vector>

namespace dco::pipeline {

// A loop over image rows shared by the calling thread and helper threads started once: each
// run() hands every thread one contiguous block of rows and returns when all are done. Where
// CPUs are spare (a GPU machine, a headset's third and fourth core) a stage's row-wise steps
// take a fraction of their time; a step whose rows are independent gives the same bytes however
// it is split. A run costs no thread start and no allocation.
class RowTeam {
 public:
  // `threads` >= 1 threads in all, the caller's included (1: every run is a plain loop).
  explicit RowTeam(int threads);
  ~RowTeam();
  RowTeam(const RowTeam&) = delete;
  RowTeam& operator=(const RowTeam&) = delete;

  int threads() const { return threads_; }

  // Calls body(part, begin, end) for the blocks [begin, end) of [0, rows), part 0 on the caller
  // and part i < threads() on helper i; a block may be empty. Rethrows the first part's error
  // after every part has returned. Not reentrant: one run at a time.
  template <typename Body>
  void run(int rows, Body&& body) {
    using B = std::remove_reference_t<Body>;
    run_erased(
        rows,
        [](void* b, int part, int begin, int end) { (*static_cast<B*>(b))(part, begin, end); },
        const_cast<void*>(static_cast<const void*>(&body)));
  }

  // The block of part `part` of `parts` over `rows` rows: [rows * part / parts, rows * (part + 1)
  // / parts).
  static int block_begin(int rows, int part, int parts);

  // A stage's `row_threads` parameter on this machine: itself when positive; 0 (auto) is 1 where
  // fewer than 4 CPUs are usable (the two stage threads have them), else half of them, at most 4.
  static int threads_for(int row_threads);

 private:
  using Call = void (*)(void*, int, int, int);
  void run_erased(int rows, Call call, void* body);
  void helper_loop(std::stop_token stop, int part);

  int threads_;
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::condition_variable done_;
  // The run in progress: its generation (helpers wait for a new one), rows, body, the helpers
  // still working and the first error.
  unsigned generation_ = 0;
  int rows_ = 0;
  Call call_ = nullptr;
  void* body_ = nullptr;
  int pending_ = 0;
  std::exception_ptr error_;
  std::vector<std::jthread> helpers_;  // last: started after the members above exist
};

}  // namespace dco::pipeline
