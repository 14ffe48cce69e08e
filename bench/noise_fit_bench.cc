// The composite noise-model fit (analyze/allan/gmwm.h) on one axis of a
// simulated MEMS gyro like the public ADIS16405 recording (100 Hz, 1e6
// samples, white noise band-limited at 15 Hz, flicker, a Gauss-Markov bump, a
// small rate random walk, a 0.05 deg/s LSB): octave OADEV with chi-square
// intervals, then
//   fit_axis_ms         the fit without uncertainties: both passes, the
//                       covariance, model selection, figures (target <= 50);
//   fit_uncertainty_ms  what the uncertainties add: the bootstrap of the
//                       selected model (target <= 500).
#include <benchmark/benchmark.h>

#include <string>
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
  GmwmOptions options;
  options.bootstrap_replicates = static_cast<int>(state.range(0));
  int parameters = 0;
  for (auto _ : state) {
    auto fit = FitCompositeModel(curve, options);
    if (!fit.ok()) state.SkipWithError(fit.status().message().c_str());
    parameters = fit.ok() ? fit->parameters : 0;
    benchmark::DoNotOptimize(fit);
  }
  state.counters["parameters"] = parameters;
}

BENCHMARK(BM_FitAxis)->Arg(0)->Arg(GmwmOptions{}.bootstrap_replicates)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace imuqual::allan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  imuqual::bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const double without = reporter.BestRealSeconds("BM_FitAxis/0");
  const double with = reporter.BestRealSeconds(
      "BM_FitAxis/" + std::to_string(imuqual::allan::GmwmOptions{}.bootstrap_replicates));
  imuqual::bench::PrintFigure("fit_axis_ms", without * 1e3, "ms");
  imuqual::bench::PrintFigure("fit_uncertainty_ms", (with - without) * 1e3, "ms");
  return 0;
}
