// Simulated gyro records of known truth for the coverage measurements of the
// analysis's uncertainties (acquire/bias_instability_coverage_test.cc,
// bench/fit_coverage_bench.cc): four noise mixtures, the truth's AVAR written
// out here (IEEE 952 terms and first-order Gauss-Markov processes) so the
// measurements do not take it from the library they check, and a record
// analysed as the station does (streaming engine, dense grid, 9-bin rule).
#ifndef IMUQUAL_ACQUIRE_COVERAGE_RECORDS_H_
#define IMUQUAL_ACQUIRE_COVERAGE_RECORDS_H_

#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "acquire/imu_simulator.h"
#include "analyze/allan/long_tau.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/streaming.h"
#include "common/status.h"

namespace imuqual::sim {

struct CoverageMixture {
  std::string name;
  pb::AxisTruth truth;
};

// The truth's AVAR at tau (base units: deg/s for a gyro).
inline double TruthAvar(const pb::AxisTruth& t, double tau) {
  double avar = t.random_walk() * t.random_walk() / tau +
                2 * std::numbers::ln2 / std::numbers::pi * t.bias_instability() *
                    t.bias_instability() +
                t.rate_random_walk() * t.rate_random_walk() * tau / 3;
  for (const pb::GaussMarkov& g : t.gauss_markov()) {
    const double q = g.sigma() * g.sigma();
    const double T = g.correlation_time_s();
    const double x = tau / T;
    avar += q * T / tau * (2 - T / tau * (3 - 4 * std::exp(-x) + std::exp(-2 * x)));
  }
  return avar;
}

// White + flicker + rate random walk, and the same with a Gauss-Markov bump.
inline std::vector<CoverageMixture> PlainMixtures() {
  pb::AxisTruth base;
  base.set_axis("x");
  base.set_random_walk(0.004);
  base.set_bias_instability(5e-4);
  base.set_rate_random_walk(2e-5);
  pb::AxisTruth gm = base;
  gm.set_bias_instability(3e-4);
  gm.set_rate_random_walk(3e-5);
  pb::GaussMarkov* g = gm.add_gauss_markov();
  g->set_sigma(4e-4);
  g->set_correlation_time_s(20);
  return {{"white+flicker+rrw", base}, {"white+flicker+gm+rrw", gm}};
}

// Two whose minimum is steeper and further inside the record: white noise
// through a first-order 20 Hz filter with weak flicker and a strong random
// walk (tau* 46 s), and the first plain one with a stronger random walk
// (87 s).
inline std::vector<CoverageMixture> SteeperMixtures() {
  const pb::AxisTruth base = PlainMixtures().front().truth;
  pb::AxisTruth sharp = base;
  sharp.set_white_bandwidth_hz(20);
  sharp.set_bias_instability(1e-4);
  sharp.set_rate_random_walk(1.5e-4);
  pb::AxisTruth steeper = base;
  steeper.set_rate_random_walk(8e-5);
  return {{"filtered20Hz+flicker+rrw", sharp}, {"white+flicker+stronger_rrw", steeper}};
}

// One record of `axis` (seed), `samples` long at `rate_hz`, analysed as the
// station does: streaming engine, dense grid, 9-bin rule, no intervals;
// with `long_taus`, also Theo1 at the octaves beyond the curve
// (allan::Theo1MomentsBeyond) into it.
inline Result<allan::Curve> StationCurve(const pb::AxisTruth& axis, uint64_t seed, int samples,
                                         double rate_hz,
                                         std::vector<allan::Theo1Moment>* long_taus = nullptr) {
  pb::SimTruth truth;
  truth.set_seed(seed);
  truth.set_actual_rate_hz(rate_hz);
  *truth.add_axes() = axis;
  auto sim = ImuSimulator::Create(truth);
  if (!sim.ok()) return sim.status();
  std::vector<std::vector<float>> out(1);
  out[0].reserve(samples);
  sim->Generate(samples, out);
  allan::StreamingOptions so;
  so.tau0_s = 1 / rate_hz;
  allan::StreamingAllan engine(so);
  engine.Append(std::span<const float>(out[0]));
  allan::Curve curve =
      engine.Oadev(allan::StreamGrid::kDense, allan::StopRule::kBins9, allan::CiMethod::kNone);
  if (long_taus != nullptr && !curve.points.empty()) {
    const allan::PhaseRecord phase =
        allan::PhaseFromRate(std::span<const float>(out[0]), so.tau0_s);
    *long_taus = allan::Theo1MomentsBeyond(phase, curve.points.back().tau_s);
  }
  return curve;
}

}  // namespace imuqual::sim

#endif  // IMUQUAL_ACQUIRE_COVERAGE_RECORDS_H_
