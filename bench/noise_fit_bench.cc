// The composite noise-model fit (analyze/allan/gmwm.h) on one axis of a
// simulated MEMS gyro like the public ADIS16405 recording (100 Hz, 1e6
// samples, white noise band-limited at 15 Hz, flicker, a Gauss-Markov bump, a
// small rate random walk, a 0.05 deg/s LSB): octave OADEV with chi-square
// intervals, then
//   fit_axis_ms         the whole fit: both passes, model selection,
//                       covariance, uncertainties and figures (target <= 50);
//   fit_uncertainty_ms  the uncertainty part alone: the full covariance of the
//                       octave AVARs from the model's spectrum (target <= 500).
#include <benchmark/benchmark.h>

#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"
#include "bench/bench_summary.h"

namespace imuqual::allan {
namespace {

constexpr int kSamples = 1000000;

const Curve& MemsCurve() {
  static const Curve curve = [] {
    const auto profile = sim::LotProfileByName("mems-real");
    pb::SimTruth truth = sim::MakeUnitTruth(*profile, sim::SeedFromName("bench"), 0, 100.0);
    truth.mutable_axes()->DeleteSubrange(1, truth.axes_size() - 1);  // gx only
    auto simulator = sim::ImuSimulator::Create(truth);
    std::vector<std::vector<float>> samples(1);
    simulator->Generate(kSamples, samples);
    const std::vector<double> rate(samples[0].begin(), samples[0].end());
    const PhaseRecord phase = PhaseFromRate(rate, 0.01);
    const std::vector<int64_t> m = AveragingFactors(TauGridSpec{}, phase.tau0_s, phase.size(),
                                                    Deviation::kOadev, StopRule::kBins9);
    Curve c = ComputeDeviation(phase, Deviation::kOadev, m);
    AttachConfidence(phase, CiMethod::kChi2, kOneSigmaConfidence, &c);
    return c;
  }();
  return curve;
}

void BM_FitAxis(benchmark::State& state) {
  const Curve& curve = MemsCurve();
  int parameters = 0;
  for (auto _ : state) {
    auto fit = FitCompositeModel(curve);
    if (!fit.ok()) state.SkipWithError(fit.status().message().c_str());
    parameters = fit.ok() ? fit->parameters : 0;
    benchmark::DoNotOptimize(fit);
  }
  state.counters["parameters"] = parameters;
}

void BM_FitUncertainty(benchmark::State& state) {
  const Curve& curve = MemsCurve();
  auto fit = FitCompositeModel(curve);
  if (!fit.ok()) {
    state.SkipWithError(fit.status().message().c_str());
    return;
  }
  std::vector<int64_t> m;
  for (const GmwmPoint& p : fit->points) m.push_back(p.m);
  for (auto _ : state) {
    std::vector<double> corr = AvarCorrelationMatrix(fit->model, curve.tau0_s, m);
    benchmark::DoNotOptimize(corr.data());
  }
}

BENCHMARK(BM_FitAxis)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FitUncertainty)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace imuqual::allan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  imuqual::bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  imuqual::bench::PrintFigure("fit_axis_ms", reporter.BestRealSeconds("BM_FitAxis") * 1e3, "ms");
  imuqual::bench::PrintFigure("fit_uncertainty_ms",
                              reporter.BestRealSeconds("BM_FitUncertainty") * 1e3, "ms");
  return 0;
}
