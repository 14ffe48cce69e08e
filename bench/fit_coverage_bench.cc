// Coverage of the noise model's judged figures (fit_angle_random_walk,
// fit_bias_instability, fit_rate_random_walk: judge::MeasureNoiseModel, as the
// station reports them at the end of a run) through the simulator: records of
// known gyro truths analysed as the station does (streaming engine, dense
// grid, 9-bin rule), each figure's value and 1-sigma uncertainty against the
// truth's own value:
//   fit_angle_random_walk  the truth's N;
//   fit_bias_instability   the truth's ADEV minimum over the analysed taus
//                          / 0.664 (IEEE 952's B, as the model reports it);
//   fit_rate_random_walk   the truth's K.
// Per mixture and figure it prints the fraction of records whose 1-sigma and
// 2-sigma intervals cover the truth (of those with a value and u), the mean
// and rms z, and how many records had no u: withheld (model inadequate), an
// upper bound (term left out; with how often the bound covers), or none.
// With --long-taus, Theo1 at the octaves beyond each curve joins the fit as
// moments (judge::NoiseModelOptions::long_taus) and the truth's minimum is
// taken over the taus the model then reaches (0.3 of the record); the
// printed names carry "_longtau".
// --outliers prints each record whose fit_rate_random_walk is a value
// without a u, and each record whose fit_bias_instability lies beyond 2u of
// the truth (seed, value, u, truth, note: which model, which rule).
// Usage: fit_coverage_bench [--seeds N] [--threads T] [--long-taus] [--outliers]
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "acquire/coverage_records.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measure.h"
#include "analyze/judge/measurements.h"

namespace imuqual {
namespace {

constexpr double kRateHz = 100.0;
constexpr int kSamples = 1 << 19;  // 87 min at 100 Hz

using sim::TruthAvar;

// The four mixtures of coverage_records.h.
std::vector<sim::CoverageMixture> Mixtures() {
  std::vector<sim::CoverageMixture> out = sim::PlainMixtures();
  for (sim::CoverageMixture& m : sim::SteeperMixtures()) out.push_back(std::move(m));
  return out;
}

allan::Curve StationCurve(const pb::AxisTruth& axis, uint64_t seed,
                          std::vector<allan::Theo1Moment>* long_taus) {
  auto curve = sim::StationCurve(axis, seed, kSamples, kRateHz, long_taus);
  if (!curve.ok()) {
    std::fprintf(stderr, "fit_coverage_bench: %s\n", curve.status().message().c_str());
    std::exit(1);
  }
  return std::move(curve).value();
}

struct Tally {
  int records = 0, with_u = 0, in1 = 0, in2 = 0, withheld = 0, bounds = 0, bound_covers = 0;
  int no_u = 0;
  double sum_z = 0, sum_z2 = 0;
  // Bounds that carry a u: how often value +- 2u covers, and the mean z.
  int bound_with_u = 0, bound_in2 = 0;
  double bound_sum_z = 0;
  void Add(const pb::Measurement& m, double truth) {
    ++records;
    if (m.model_inadequate() && std::isnan(m.value())) {
      ++withheld;
    } else if (m.qualifier() == pb::UPPER_BOUND) {
      ++bounds;
      if (truth <= m.value()) ++bound_covers;
      if (m.has_uncertainty() && m.uncertainty() > 0) {
        const double z = (m.value() - truth) / m.uncertainty();
        ++bound_with_u;
        bound_in2 += std::fabs(z) <= 2;
        bound_sum_z += z;
      }
    } else if (m.has_uncertainty() && m.uncertainty() > 0 && std::isfinite(m.value())) {
      const double z = (m.value() - truth) / m.uncertainty();
      ++with_u;
      in1 += std::fabs(z) <= 1;
      in2 += std::fabs(z) <= 2;
      sum_z += z;
      sum_z2 += z * z;
    } else {
      ++no_u;
    }
  }
  void Print(const std::string& mixture, const char* figure) const {
    const double n = std::max(with_u, 1);
    std::printf("fit_coverage_%s_%s_1sigma %.3f fraction\n", figure, mixture.c_str(), in1 / n);
    std::printf("fit_coverage_%s_%s_2sigma %.3f fraction\n", figure, mixture.c_str(), in2 / n);
    std::printf(
        "# %s %s: %d records, %d with u (mean z %+.2f, rms z %.2f), %d withheld (model "
        "inadequate), %d upper bounds (covering %d; %d with a u: +-2u covers %d, mean z %+.2f), "
        "%d without u\n",
        mixture.c_str(), figure, records, with_u, sum_z / n, std::sqrt(sum_z2 / n), withheld,
        bounds, bound_covers, bound_with_u, bound_in2, bound_sum_z / std::max(bound_with_u, 1),
        no_u);
  }
};

const pb::Measurement* Find(const std::vector<pb::Measurement>& ms, std::string_view name) {
  for (const pb::Measurement& m : ms) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  int seeds = 200;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  bool long_taus = false, outliers = false;
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--long-taus" || flag == "--outliers") {
      (flag == "--long-taus" ? long_taus : outliers) = true;
      --i;  // no value
    } else if (i + 1 >= argc) {
      std::fprintf(stderr, "fit_coverage_bench: %s needs a value\n", argv[i]);
      return 2;
    } else if (flag == "--seeds") {
      seeds = std::atoi(argv[i + 1]);
    } else if (flag == "--threads") {
      threads = std::atoi(argv[i + 1]);
    } else {
      std::fprintf(stderr,
                   "fit_coverage_bench: unknown option %s (--seeds N, --threads T, "
                   "--long-taus, --outliers)\n",
                   argv[i]);
      return 2;
    }
  }
  if (seeds < 1 || threads < 1) {
    std::fprintf(stderr, "fit_coverage_bench: --seeds and --threads must be positive\n");
    return 2;
  }
  using allan::NoiseTerm;
  const auto gyro = allan::SensorKind::kGyro;
  for (const sim::CoverageMixture& mix : Mixtures()) {
    Tally arw, bi, rrw;
    std::mutex mu;
    std::atomic<int> next{0};
    const auto work = [&] {
      for (int s = next++; s < seeds; s = next++) {
        judge::NoiseModelOptions options;
        const allan::Curve curve =
            StationCurve(mix.truth, 0xc0fe + 7919ull * s, long_taus ? &options.long_taus : nullptr);
        const std::vector<pb::Measurement> ms =
            judge::MeasureNoiseModel("x", pb::GYRO, curve, options);
        // The truth's minimum over the taus the model analysed.
        double min_dev = INFINITY;
        const double lo = curve.points.front().tau_s;
        const double hi = options.long_taus.empty()
                              ? curve.points.back().tau_s
                              : 0.75 * static_cast<double>(options.long_taus.back().m) / kRateHz;
        for (int k = 0; k <= 2000; ++k) {
          const double tau = lo * std::pow(hi / lo, k / 2000.0);
          min_dev = std::min(min_dev, std::sqrt(TruthAvar(mix.truth, tau)));
        }
        const double n_true =
            allan::ToDatasheetUnits(NoiseTerm::kAngleRandomWalk, gyro, mix.truth.random_walk())
                .value;
        const double b_true =
            allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, gyro, min_dev / 0.664).value;
        const double k_true =
            allan::ToDatasheetUnits(NoiseTerm::kRateRandomWalk, gyro, mix.truth.rate_random_walk())
                .value;
        const pb::Measurement* a = Find(ms, judge::kFitAngleRandomWalk);
        const pb::Measurement* b = Find(ms, judge::kFitBiasInstability);
        const pb::Measurement* k = Find(ms, judge::kFitRateRandomWalk);
        std::lock_guard<std::mutex> lock(mu);
        if (a != nullptr) arw.Add(*a, n_true);
        if (b != nullptr) bi.Add(*b, b_true);
        if (outliers && b != nullptr && b->has_uncertainty() &&
            std::fabs(b->value() - b_true) > 2 * b->uncertainty()) {
          std::printf("# outlier %s seed %d: bi %.4g +- %.3g, truth %.4g; %s\n", mix.name.c_str(),
                      s, b->value(), b->uncertainty(), b_true, b->note().c_str());
        }
        if (k != nullptr) rrw.Add(*k, k_true);
        if (outliers && k != nullptr && k->qualifier() != pb::UPPER_BOUND &&
            std::isfinite(k->value()) && !(k->has_uncertainty() && k->uncertainty() > 0)) {
          const pb::Measurement* pv = Find(ms, judge::kNoiseModelPValue);
          std::printf("# rrw without u %s seed %d: %.4g; %s; %s\n", mix.name.c_str(), s, k->value(),
                      k->note().c_str(), pv != nullptr ? pv->note().c_str() : "");
        }
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
    const std::string name = mix.name + (long_taus ? "_longtau" : "");
    arw.Print(name, "arw");
    bi.Print(name, "bi");
    rrw.Print(name, "rrw");
    std::fflush(stdout);
  }
  return 0;
}
