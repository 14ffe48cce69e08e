// Turns Google Benchmark runs into the project's benchmark lines:
// "name value unit", one per figure, on stdout (scripts/bench collects them).
// Usage in a benchmark main():
//   benchmark::Initialize(&argc, argv);
//   imuqual::bench::SummaryReporter reporter;
//   benchmark::RunSpecifiedBenchmarks(&reporter);
//   reporter.BestRealSeconds("BM_Foo/10000000")  -> best (minimum) wall time per iteration
//   imuqual::bench::PrintFigure("foo_s", value, "s");
#ifndef IMUQUAL_BENCH_BENCH_SUMMARY_H_
#define IMUQUAL_BENCH_BENCH_SUMMARY_H_

#include <benchmark/benchmark.h>

#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace imuqual::bench {

// Prints human-readable progress to stderr (the console reporter) and keeps,
// per benchmark name, the best per-iteration wall time and the last counters.
class SummaryReporter : public benchmark::BenchmarkReporter {
 public:
  SummaryReporter() { console_.SetOutputStream(&std::cerr); console_.SetErrorStream(&std::cerr); }

  bool ReportContext(const Context& context) override { return console_.ReportContext(context); }

  void ReportRuns(const std::vector<Run>& runs) override {
    console_.ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.run_type != Run::RT_Iteration || run.iterations == 0) continue;
      const std::string name = run.run_name.str();
      const double per_iter_s = run.real_accumulated_time / static_cast<double>(run.iterations);
      auto it = best_s_.find(name);
      if (it == best_s_.end() || per_iter_s < it->second) best_s_[name] = per_iter_s;
      for (const auto& [key, counter] : run.counters) counters_[name][key] = counter.value;
    }
  }

  void Finalize() override { console_.Finalize(); }

  // Best wall time per iteration in seconds, NaN if the benchmark did not run.
  double BestRealSeconds(const std::string& name) const {
    auto it = best_s_.find(name);
    return it == best_s_.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
  }
  // Last reported value of a user counter, NaN if absent.
  double Counter(const std::string& name, const std::string& key) const {
    auto it = counters_.find(name);
    if (it == counters_.end()) return std::numeric_limits<double>::quiet_NaN();
    auto jt = it->second.find(key);
    return jt == it->second.end() ? std::numeric_limits<double>::quiet_NaN() : jt->second;
  }

 private:
  benchmark::ConsoleReporter console_;
  std::map<std::string, double> best_s_;
  std::map<std::string, std::map<std::string, double>> counters_;
};

// One benchmark figure line: "name value unit".
inline void PrintFigure(const std::string& name, double value, const std::string& unit) {
  std::printf("%s %.6g %s\n", name.c_str(), value, unit.c_str());
  std::fflush(stdout);
}

}  // namespace imuqual::bench

#endif  // IMUQUAL_BENCH_BENCH_SUMMARY_H_
