// Exact batch Allan estimators: wall time of whole curves on one thread.
// Figures: exact_oadev_octave_1e7_s (the target: <= 0.1 s), and the same for
// 1e6 samples, MDEV, TOTDEV, Theo1 (octave m = 2..2^19, long_tau.h), a record
// with gaps, and the rate -> phase step.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/estimators.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"
#include "bench/bench_summary.h"

namespace imuqual::allan {
namespace {

// Seeded white rate noise, built once per length and kept for every run.
const std::vector<double>& WhiteRate(int64_t samples) {
  static std::map<int64_t, std::vector<double>> cache;
  auto it = cache.find(samples);
  if (it != cache.end()) return it->second;
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal;
  std::vector<double> rate(static_cast<size_t>(samples));
  for (double& y : rate) y = 9.80665 + 0.02 * normal(rng);
  return cache.emplace(samples, std::move(rate)).first->second;
}

// The phase record of WhiteRate(samples); with_gaps marks one sample in
// 10000 invalid.
const PhaseRecord& Phase(int64_t samples, bool with_gaps) {
  static std::map<std::pair<int64_t, bool>, PhaseRecord> cache;
  const auto key = std::make_pair(samples, with_gaps);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  std::vector<uint8_t> flags;
  if (with_gaps) {
    flags.assign(static_cast<size_t>(samples), 0);
    for (int64_t k = 5000; k < samples; k += 10000) flags[k] = 1;
  }
  return cache.emplace(key, PhaseFromRate(WhiteRate(samples), 0.01, flags)).first->second;
}

void RunOctaveCurve(benchmark::State& state, Deviation dev, bool with_gaps) {
  const PhaseRecord& phase = Phase(state.range(0), with_gaps);
  const std::vector<int64_t> m_list =
      AveragingFactors(TauGridSpec{}, phase.tau0_s, phase.size(), dev, StopRule::kNone);
  for (auto _ : state) {
    Curve curve = ComputeDeviation(phase, dev, m_list);
    benchmark::DoNotOptimize(curve.points.data());
  }
  state.counters["taus"] = static_cast<double>(m_list.size());
}

void BM_ExactOadevOctave(benchmark::State& state) {
  RunOctaveCurve(state, Deviation::kOadev, false);
}
void BM_ExactOadevOctaveGaps(benchmark::State& state) {
  RunOctaveCurve(state, Deviation::kOadev, true);
}
void BM_ExactMdevOctave(benchmark::State& state) { RunOctaveCurve(state, Deviation::kMdev, false); }
void BM_ExactOhdevOctave(benchmark::State& state) {
  RunOctaveCurve(state, Deviation::kOhdev, false);
}
void BM_ExactTotdevOctave(benchmark::State& state) {
  RunOctaveCurve(state, Deviation::kTotdev, false);
}
void BM_ExactTheo1Octave(benchmark::State& state) {
  RunOctaveCurve(state, Deviation::kTheo1, false);
}

void BM_PhaseFromRate(benchmark::State& state) {
  const std::vector<double>& rate = WhiteRate(state.range(0));
  for (auto _ : state) {
    PhaseRecord phase = PhaseFromRate(rate, 0.01);
    benchmark::DoNotOptimize(phase.x.data());
  }
}

constexpr int kRepetitions = 7;

BENCHMARK(BM_ExactOadevOctave)
    ->Arg(1000000)
    ->Arg(10000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);
BENCHMARK(BM_ExactOadevOctaveGaps)
    ->Arg(10000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);
BENCHMARK(BM_ExactMdevOctave)
    ->Arg(1000000)
    ->Arg(10000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);
BENCHMARK(BM_ExactOhdevOctave)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);
BENCHMARK(BM_ExactTotdevOctave)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);
BENCHMARK(BM_ExactTheo1Octave)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);
BENCHMARK(BM_PhaseFromRate)
    ->Arg(10000000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(kRepetitions);

}  // namespace
}  // namespace imuqual::allan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  imuqual::bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  const auto figure = [&](const std::string& name, const std::string& run) {
    imuqual::bench::PrintFigure(name, reporter.BestRealSeconds(run), "s");
  };
  const std::string suffix =
      "/iterations:1/repeats:" + std::to_string(imuqual::allan::kRepetitions);
  figure("exact_oadev_octave_1e7_s", "BM_ExactOadevOctave/10000000" + suffix);
  figure("exact_oadev_octave_1e6_s", "BM_ExactOadevOctave/1000000" + suffix);
  figure("exact_oadev_octave_1e7_gaps_s", "BM_ExactOadevOctaveGaps/10000000" + suffix);
  figure("exact_mdev_octave_1e7_s", "BM_ExactMdevOctave/10000000" + suffix);
  figure("exact_mdev_octave_1e6_s", "BM_ExactMdevOctave/1000000" + suffix);
  figure("exact_ohdev_octave_1e6_s", "BM_ExactOhdevOctave/1000000" + suffix);
  figure("exact_totdev_octave_1e6_s", "BM_ExactTotdevOctave/1000000" + suffix);
  figure("exact_theo1_octave_1e6_s", "BM_ExactTheo1Octave/1000000/iterations:1/repeats:3");
  figure("phase_from_rate_1e7_s", "BM_PhaseFromRate/10000000" + suffix);
  return 0;
}
