// What judging the longest stationary segment (stationarity on_event
// JUDGE_LONGEST_SEGMENT) buys on records with a level step: over many seeds of
// simulated 87-min gyro records of known truth (acquire/coverage_records.h's
// white + flicker + RRW mixtures), each analysed by the station's RunAnalyzer
// three ways:
//   clean      the record without the step (QUALIFIER_ONLY): the baseline
//   whole      a step of --step-sigmas times the record's 100 s bin means'
//              standard deviation planted at a random time in 25-40 % of the
//              record, judged on the whole record (QUALIFIER_ONLY)
//   segment    the same record under JUDGE_LONGEST_SEGMENT
// the scan's reference is the truth. For the curve minimum (bias_instability)
// and the noise model's fit_bias_instability, the coverage of the value's
// 1-sigma and 2-sigma intervals of the truth over the same taus (the curve
// minimum against the truth's minimum over the judged curve's taus; the
// model's B against that minimum / 0.664) and the mean z; and how often the
// step was found and how much of the record the segment kept.
// Prints "name value unit" lines.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "acquire/coverage_records.h"
#include "acquire/imu_simulator.h"
#include "analyze/judge/measurements.h"
#include "analyze/service/run_analyzer.h"
#include "bench/planted_steps.h"

namespace imuqual {
namespace {

constexpr double kRateHz = 100;
constexpr double kDurationS = 5220;  // 87 min
constexpr double kBiasFactor = 0.664;

struct Tally {
  int n = 0, in1 = 0, in2 = 0;
  double z_sum = 0;
  void Add(double z) {
    if (!std::isfinite(z)) return;
    ++n;
    in1 += std::abs(z) <= 1 ? 1 : 0;
    in2 += std::abs(z) <= 2 ? 1 : 0;
    z_sum += z;
  }
  void Print(const std::string& name) const {
    if (n == 0) {
      std::printf("%s_records 0 records\n", name.c_str());
      return;
    }
    std::printf("%s_cover1 %.1f %%\n", name.c_str(), 100.0 * in1 / n);
    std::printf("%s_cover2 %.1f %%\n", name.c_str(), 100.0 * in2 / n);
    std::printf("%s_mean_z %.2f sigma\n", name.c_str(), z_sum / n);
    std::printf("%s_records %d records\n", name.c_str(), n);
  }
};

pb::ReferenceNoiseModel ReferenceOf(const pb::AxisTruth& t) {
  pb::ReferenceNoiseModel r;
  r.set_axis_kind(pb::GYRO);
  r.set_source("the simulated truth");
  r.set_random_walk(t.random_walk());
  r.set_bias_instability(t.bias_instability());
  r.set_rate_random_walk(t.rate_random_walk());
  for (const pb::GaussMarkov& g : t.gauss_markov()) *r.add_gauss_markov() = g;
  return r;
}

analyze::RunDescription Describe(const pb::AxisTruth& truth, pb::Stationarity::OnEvent action) {
  analyze::RunDescription d;
  d.run_id = "R";
  d.serial = "U";
  d.nominal_rate_hz = kRateHz;
  d.axes = {{"x", pb::GYRO}};
  d.plan.set_nominal_rate_hz(kRateHz);
  pb::Axis* axis = d.plan.add_axes();
  axis->set_name("x");
  axis->set_kind(pb::GYRO);
  d.plan.mutable_stationarity()->set_on_event(action);
  *d.plan.mutable_stationarity()->add_reference_model() = ReferenceOf(truth);
  return d;
}

const pb::Measurement* Find(const analyze::RunOutcome& out, std::string_view name) {
  for (const pb::Measurement& m : out.measurements) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

// The record analysed as the station does; nullopt (said on stderr) if the
// analysis refused it.
std::optional<analyze::RunOutcome> Analyse(const analyze::RunDescription& d,
                                           const std::vector<float>& samples) {
  auto a = analyze::RunAnalyzer::Create(d);
  if (!a.ok()) {
    std::fprintf(stderr, "segment_bench: %s\n", a.status().message().c_str());
    return std::nullopt;
  }
  constexpr size_t kBatch = 1000;
  int64_t seq = 0;
  for (size_t first = 0; first < samples.size(); first += kBatch, ++seq) {
    const size_t n = std::min(kBatch, samples.size() - first);
    analyze::BatchView view;
    view.seq = seq;
    view.first_sample = static_cast<int64_t>(first);
    view.nominal_rate_hz = kRateHz;
    view.samples = {std::span<const float>(samples).subspan(first, n)};
    if (const Status st = a->AddBatch(view); !st.ok()) {
      std::fprintf(stderr, "segment_bench: %s\n", st.message().c_str());
      return std::nullopt;
    }
  }
  a->Finish(0, static_cast<int64_t>(samples.size()));
  return a->Outcome(true);
}

// The truth's curve minimum over the taus of the judged curve, deg/h.
double TruthMinimum(const pb::AxisTruth& truth, const analyze::RunOutcome& out) {
  double best = INFINITY;
  for (const auto& [axis, curve] : out.curves) {
    for (const allan::CurvePoint& p : curve.points) {
      best = std::min(best, std::sqrt(sim::TruthAvar(truth, p.tau_s)));
    }
  }
  return best * 3600;
}

double Z(const pb::Measurement* m, double truth) {
  if (m == nullptr || !m->has_uncertainty() || !(m->uncertainty() > 0) ||
      m->qualifier() == pb::UPPER_BOUND) {
    return NAN;
  }
  return (m->value() - truth) / m->uncertainty();
}

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  int seeds = 100;
  double step_sigmas = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--seeds") {
      seeds = std::atoi(argv[i + 1]);
    } else if (flag == "--step-sigmas") {
      step_sigmas = std::atof(argv[i + 1]);
    } else {
      std::fprintf(stderr, "segment_bench: unknown option %s (--seeds N, --step-sigmas K)\n",
                   flag.c_str());
      return 2;
    }
  }
  if (seeds < 1 || !(step_sigmas > 0)) {
    std::fprintf(stderr, "segment_bench: --seeds must be >= 1 and --step-sigmas > 0\n");
    return 2;
  }
  const int samples = static_cast<int>(kDurationS * kRateHz);
  for (const sim::CoverageMixture& mix : sim::PlainMixtures()) {
    Tally b[3], fit_b[3];
    int found = 0, analysed = 0;
    double kept = 0;
    std::mt19937_64 rng(4242);
    std::uniform_real_distribution<double> when(0.25, 0.40);
    for (int seed = 0; seed < seeds; ++seed) {
      pb::SimTruth truth;
      truth.set_seed(770000 + static_cast<uint64_t>(seed));
      truth.set_actual_rate_hz(kRateHz);
      *truth.add_axes() = mix.truth;
      auto sim = sim::ImuSimulator::Create(truth);
      if (!sim.ok()) {
        std::fprintf(stderr, "segment_bench: %s\n", sim.status().message().c_str());
        return 1;
      }
      std::vector<std::vector<float>> clean(1);
      sim->Generate(samples, clean);
      std::vector<float> stepped = clean[0];
      const std::vector<double> as_double(clean[0].begin(), clean[0].end());
      const double size =
          step_sigmas * bench::BinMeanSd(as_double, 1 / kRateHz, 100.0) * (seed % 2 ? 1 : -1);
      const size_t at = static_cast<size_t>(when(rng) * samples);
      for (size_t k = at; k < stepped.size(); ++k) stepped[k] += static_cast<float>(size);
      const auto qualifier = Describe(mix.truth, pb::Stationarity::QUALIFIER_ONLY);
      const auto segment = Describe(mix.truth, pb::Stationarity::JUDGE_LONGEST_SEGMENT);
      const std::optional<analyze::RunOutcome> outs[3] = {
          Analyse(qualifier, clean[0]), Analyse(qualifier, stepped), Analyse(segment, stepped)};
      if (!outs[0] || !outs[1] || !outs[2]) return 1;
      ++analysed;
      const pb::Measurement* events = Find(*outs[2], judge::kStationarityEvents);
      found += events != nullptr && events->value() >= 1 ? 1 : 0;
      if (const pb::Measurement* j = Find(*outs[2], judge::kJudgedSegment)) {
        kept += j->value() / kDurationS;
      }
      for (int k = 0; k < 3; ++k) {
        const double truth_min = TruthMinimum(mix.truth, *outs[k]);
        b[k].Add(Z(Find(*outs[k], judge::kBiasInstability), truth_min));
        fit_b[k].Add(Z(Find(*outs[k], judge::kFitBiasInstability), truth_min / kBiasFactor));
      }
    }
    const std::string p = "segment_" + mix.name + "_";
    std::printf("%sstep_found %.1f %% (%d of %d, steps of %.3g sigma)\n", p.c_str(),
                100.0 * found / analysed, found, analysed, step_sigmas);
    std::printf("%sjudged_fraction %.3f of the record (mean)\n", p.c_str(), kept / analysed);
    const char* ways[3] = {"clean", "whole", "segment"};
    for (int k = 0; k < 3; ++k) {
      b[k].Print(p + ways[k] + "_bias_instability");
      fit_b[k].Print(p + ways[k] + "_fit_bias_instability");
    }
  }
  return 0;
}
