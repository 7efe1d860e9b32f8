#pragma once

// The output the command line asks for, plus the real time of each benchmark, so a program can
// print the ratios of dco against its peers of the same run at the end.

#include <cstdio>
#include <initializer_list>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "dco/core/memory_policy.hpp"

namespace dco::bench {

// Passes every report to the display reporter the command line chose (--benchmark_format,
// --benchmark_color, --benchmark_counters_tabular) and keeps each benchmark's real time.
class RatioReporter : public benchmark::BenchmarkReporter {
 public:
  // After benchmark::Initialize, which reads the flags; the display reporter belongs to the
  // library.
  RatioReporter() : display_(benchmark::CreateDefaultDisplayReporter()) {}

  bool ReportContext(const Context& context) override { return display_->ReportContext(context); }
  void Finalize() override { display_->Finalize(); }

  void ReportRuns(const std::vector<Run>& runs) override {
    display_->ReportRuns(runs);
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

  // Whether the display is the console table (else JSON or CSV, which the ratios must not join).
  bool console() const { return dynamic_cast<benchmark::ConsoleReporter*>(display_) != nullptr; }

  double ms(const std::string& name) const {
    const auto it = ms_.find(name);
    return it == ms_.end() ? 0.0 : it->second;
  }

  // Prints ours / peer to `out` when both ran (< 1: dco is faster).
  void print_ratio(std::FILE* out, const char* ours, const char* peer) const {
    const double a = ms(ours), b = ms(peer);
    if (a > 0 && b > 0) std::fprintf(out, "ratio %-28s / %-28s = %.2f\n", ours, peer, a / b);
  }

 private:
  benchmark::BenchmarkReporter* display_;
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
  // Beside a JSON or CSV report on standard output, the ratios go to standard error.
  std::FILE* out = reporter.console() ? stdout : stderr;
  std::fflush(stdout);
  std::fprintf(out, "\ntime ratios (< 1: dco is faster)\n");
  for (const RatioPair& pair : pairs) reporter.print_ratio(out, pair.ours, pair.peer);
  return 0;
}

}  // namespace dco::bench
