#pragma once

// Console output as usual, plus the real time of each benchmark, so a program can print the
// ratios of dco against its peers of the same run at the end.

#include <cstdio>
#include <initializer_list>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "dco/core/memory_policy.hpp"

namespace dco::bench {

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    // With --benchmark_repetitions the median stands for the benchmark.
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      const std::string name = run.benchmark_name().substr(0, run.benchmark_name().find('/'));
      if (median || (run.run_type == Run::RT_Iteration && !has_median_.count(name)))
        ms_[name] = run.GetAdjustedRealTime();
      if (median) has_median_.insert(name);
    }
  }

  double ms(const std::string& name) const {
    const auto it = ms_.find(name);
    return it == ms_.end() ? 0.0 : it->second;
  }

  // Prints ours / peer when both ran (< 1: dco is faster).
  void print_ratio(const char* ours, const char* peer) const {
    const double a = ms(ours), b = ms(peer);
    if (a > 0 && b > 0) std::printf("ratio %-28s / %-28s = %.2f\n", ours, peer, a / b);
  }

 private:
  std::map<std::string, double> ms_;
  std::set<std::string> has_median_;
};

// The main of a dco benchmark program: runs the selected benchmarks and then prints ours / peer
// for each pair whose both sides ran.
struct RatioPair {
  const char* ours;
  const char* peer;
};
inline int run_with_ratios(int argc, char** argv, std::initializer_list<RatioPair> pairs) {
  // Both sides allocate from a heap that keeps freed memory, as in the tools and the daemon: a
  // peer that allocates its buffers on every call would otherwise also pay their page faults.
  retain_freed_memory();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  std::printf("\ntime ratios (< 1: dco is faster)\n");
  for (const RatioPair& pair : pairs) reporter.print_ratio(pair.ours, pair.peer);
  return 0;
}

}  // namespace dco::bench
