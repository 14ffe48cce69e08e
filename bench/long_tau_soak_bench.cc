// Soak time saved by the noise model's long taus (plan noise_model_long_taus;
// ./scripts/bench longtau). A simulated lot (--profile: "tactical", the
// default, or "fog", at --spread, its rate random walk times --rrw-scale;
// every 8th unit planted with 3 times the walk and 4 times the flicker) is
// judged on the rate random walk, the long-tau figure: by the profile's
// built-in plan's fit_rate_random_walk limit (or --rrw-limit) alone on its
// gyro axes, the plan's other limits and axes left out so that a
// disposition is the walk's. The tactical plan soaks 1 h, and its typical
// unit's walk meets the flicker floor at ~530 s, beyond T/9 (400 s): the
// case the long taus are for. Each unit's record (warm-up and soak) is
// generated once and analysed by the station's own analysis (RunAnalyzer)
// in several arms at once:
//   full, full+theo1   the plan's soak, OADEV only / with the long taus
//   f, f+theo1         f times the plan's soak (--fractions, up to 4: the
//                      unit soaked longer or shorter)
// Per arm it prints the dispositions wrong against the truth (accept = PASS
// or MARGINAL, reject = FAIL, INCONCLUSIVE apart), those differing from the
// full soak's, and K's readings over every gyro axis: how many have a value
// with a u (else an upper bound: the term left out), their rms z against
// the truth and their 1- and 2-sigma coverage. The truth of a unit is its
// simulated K per axis judged by the same limit. Never asserts.
// LONGTAU_TRACE=i prints unit i's curves and noise-model values per arm.
// Usage: long_tau_soak_bench [--profile P] [--units N] [--fractions 0.5,2]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/allan/units.h"
#include "analyze/judge/judge.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "analyze/service/run_analyzer.h"
#include "offline/plan_soak_command.h"

namespace imuqual {
namespace {

struct Arm {
  std::string name;
  double fraction = 1;
  bool theo1 = false;
};

struct Reading {  // fit_rate_random_walk of one axis, deg/h/sqrt(h)
  double k = NAN, u = NAN, truth = NAN;
  bool upper_bound = false;
};

struct ArmResult {
  pb::Outcome verdict = pb::OUTCOME_UNSET;
  std::vector<Reading> readings;  // per gyro axis
};

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  CLI::App app{"soak time saved by the noise model's long taus on a simulated FOG lot"};
  std::string profile_name = "tactical";
  int units = 200;
  double spread = 0.35;
  double rrw_limit = 0;  // the plan's
  double rrw_scale = 1;
  std::string fractions_text = "0.5,2";
  int threads = 2;
  std::string lot = "LONGTAU-BENCH";
  bool verbose = false;
  app.add_option("--profile", profile_name, "lot profile and built-in plan: tactical or fog")
      ->capture_default_str();
  app.add_option("--units", units, "units in the lot")->capture_default_str();
  app.add_option("--spread", spread, "lognormal unit-to-unit spread of the noise terms")
      ->capture_default_str();
  app.add_option("--rrw-limit", rrw_limit,
                 "fit_rate_random_walk high limit, deg/h/sqrt(h) (0: the plan's)")
      ->capture_default_str();
  app.add_option("--rrw-scale", rrw_scale, "the lot's rate random walk, times the profile's")
      ->capture_default_str();
  app.add_option("--fractions", fractions_text, "other soak lengths, times the plan's")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads")->capture_default_str();
  app.add_option("--lot", lot, "lot name (seeds the truths)")->capture_default_str();
  app.add_flag("--verbose", verbose, "one line per unit on stderr");
  CLI11_PARSE(app, argc, argv);

  std::vector<Arm> arms = {{"full", 1, false}, {"full+theo1", 1, true}};
  {
    std::stringstream in(fractions_text);
    std::string item;
    while (std::getline(in, item, ',')) {
      char* end = nullptr;
      const double f = std::strtod(item.c_str(), &end);
      if (end == item.c_str() || *end != '\0' || !(f > 0 && f <= 4) || f == 1) {
        std::fprintf(stderr, "long_tau_soak_bench: --fractions: '%s' is not in (0, 4] or is 1\n",
                     item.c_str());
        return 2;
      }
      arms.push_back({"f" + item, f, false});
      arms.push_back({"f" + item + "+theo1", f, true});
    }
  }
  auto profile = sim::LotProfileByName(profile_name);
  auto builtin = judge::BuiltinPlan(profile_name);
  if (!profile.ok() || !builtin.ok()) {
    std::fprintf(stderr, "long_tau_soak_bench: no profile and plan named '%s'\n",
                 profile_name.c_str());
    return 2;
  }
  profile->spread = spread;
  // The plan's gyro axes and its fit_rate_random_walk limit only.
  pb::TestPlan plan = *builtin;
  plan.clear_limits();
  plan.clear_axes();
  plan.clear_stationarity();
  std::vector<int> gyro;  // the gyro axes' places in the profile's record
  for (int a = 0; a < builtin->axes_size(); ++a) {
    if (builtin->axes(a).kind() != pb::GYRO) continue;
    gyro.push_back(a);
    *plan.add_axes() = builtin->axes(a);
  }
  for (const pb::Limit& l : builtin->limits()) {
    if (l.measurement() == judge::kFitRateRandomWalk && l.axis_kind() == pb::GYRO) {
      *plan.add_limits() = l;
    }
  }
  if (plan.limits_size() != 1 || gyro.empty()) {
    std::fprintf(stderr, "long_tau_soak_bench: plan '%s' has no gyro fit_rate_random_walk limit\n",
                 profile_name.c_str());
    return 1;
  }
  pb::Limit* limit = plan.mutable_limits(0);
  if (rrw_limit > 0) limit->set_high(rrw_limit);
  if (Status st = judge::ValidatePlan(plan); !st.ok()) {
    std::fprintf(stderr, "long_tau_soak_bench: %s\n", st.message().c_str());
    return 1;
  }
  const double rate = plan.nominal_rate_hz();
  const double warmup_s = plan.warmup_s();
  const double soak_s = plan.min_duration_s();
  double longest = 1;
  for (const Arm& arm : arms) longest = std::max(longest, arm.fraction);
  const int64_t total = std::llround((warmup_s + longest * soak_s) * rate);
  const uint64_t seed = sim::SeedFromName(lot);

  std::vector<pb::Outcome> truth(units, pb::OUTCOME_UNSET);
  std::vector<std::vector<ArmResult>> results(units, std::vector<ArmResult>(arms.size()));
  std::atomic<int> next{0};
  std::mutex log;
  auto work = [&]() {
    for (int i = next++; i < units; i = next++) {
      pb::SimTruth t = sim::MakeUnitTruth(*profile, seed, i, rate);
      for (pb::AxisTruth& a : *t.mutable_axes()) {
        a.set_rate_random_walk(rrw_scale * a.rate_random_walk());
      }
      std::vector<double> true_k;
      pb::Outcome worst = pb::PASS;
      for (int a : gyro) {
        true_k.push_back(
            allan::DegPerSecPerRootSecToDegPerHourPerRootHour(t.axes(a).rate_random_walk()));
        const pb::Outcome o = judge::Evaluate(*limit, true_k.back());
        if (o == pb::FAIL || (o == pb::MARGINAL && worst == pb::PASS)) worst = o;
      }
      truth[i] = worst;
      auto simulator = sim::ImuSimulator::Create(t);
      if (!simulator.ok()) {
        std::fprintf(stderr, "long_tau_soak_bench: unit %d: %s\n", i,
                     simulator.status().message().c_str());
        std::exit(1);
      }
      std::vector<std::unique_ptr<analyze::RunAnalyzer>> analyzers;
      std::vector<int64_t> ends;
      for (const Arm& arm : arms) {
        analyze::RunDescription desc;
        desc.run_id = "R" + std::to_string(i);
        desc.serial = "U" + std::to_string(i);
        desc.nominal_rate_hz = rate;
        for (const pb::Axis& a : plan.axes()) desc.axes.push_back({a.name(), a.kind()});
        desc.plan = plan;
        desc.plan.set_min_duration_s(arm.fraction * soak_s);
        desc.plan.set_noise_model_long_taus(arm.theo1);
        auto a = analyze::RunAnalyzer::Create(desc);
        if (!a.ok()) {
          std::fprintf(stderr, "long_tau_soak_bench: %s\n", a.status().message().c_str());
          std::exit(1);
        }
        analyzers.push_back(std::make_unique<analyze::RunAnalyzer>(std::move(*a)));
        ends.push_back(std::llround((warmup_s + arm.fraction * soak_s) * rate));
      }
      offline::FeedSimulatedRecord(*simulator, rate, total, [&](const analyze::BatchView& view) {
        analyze::BatchView gyros = view;
        gyros.samples.clear();
        gyros.flags.clear();
        for (size_t g = 0; g < gyro.size(); ++g) {
          gyros.samples.push_back(view.samples[gyro[g]]);
          for (const analyze::BatchView::Flag& f : view.flags) {
            if (f.axis == gyro[g]) gyros.flags.push_back({f.sample, static_cast<int>(g), f.bits});
          }
        }
        for (size_t a = 0; a < arms.size(); ++a) {
          if (view.first_sample < ends[a]) (void)analyzers[a]->AddBatch(gyros);
        }
        return true;
      });
      std::string line;
      for (size_t a = 0; a < arms.size(); ++a) {
        analyzers[a]->Finish(0, std::min(ends[a], total));
        const analyze::RunOutcome out = analyzers[a]->Outcome(true);
        ArmResult& r = results[i][a];
        r.verdict = out.judgement.verdict;
        for (size_t g = 0; g < gyro.size(); ++g) {
          Reading reading;
          reading.truth = true_k[g];
          for (const pb::Measurement& m : out.measurements) {
            if (m.name() != judge::kFitRateRandomWalk || m.axis() != plan.axes(g).name()) continue;
            reading.k = m.value();
            reading.u = m.has_uncertainty() ? m.uncertainty() : NAN;
            reading.upper_bound = m.qualifier() == pb::UPPER_BOUND;
          }
          r.readings.push_back(reading);
        }
        if (getenv("LONGTAU_TRACE") && i == std::atoi(getenv("LONGTAU_TRACE"))) {
          std::lock_guard<std::mutex> lock(log);
          std::fprintf(stderr, "unit %d arm %s\n", i, arms[a].name.c_str());
          for (const auto& [axis, c] : out.curves) {
            for (const allan::CurvePoint& p : c.points) {
              std::fprintf(stderr, "  tau %.4g adev %.4g deg/h\n", p.tau_s, p.dev * 3600);
            }
          }
          for (const pb::Measurement& m : out.measurements) {
            if (m.name().rfind("fit_", 0) == 0 || m.name().rfind("noise_model", 0) == 0) {
              std::fprintf(stderr, "  %s %g +- %g: %s\n", m.name().c_str(), m.value(),
                           m.uncertainty(), m.note().c_str());
            }
          }
        }
        line += " " + arms[a].name + " " + judge::OutcomeName(r.verdict);
        for (const Reading& k : r.readings) {
          char buf[64];
          std::snprintf(buf, sizeof buf, " %.3g%s%.2g", k.k, k.upper_bound ? "(ub)" : "+-", k.u);
          line += buf;
        }
      }
      if (verbose) {
        std::lock_guard<std::mutex> lock(log);
        std::string ks;
        for (double k : true_k) ks += " " + std::to_string(k);
        std::fprintf(stderr, "unit %3d %-18s K%s truth %-8s%s\n", i, t.profile().c_str(),
                     ks.c_str(), judge::OutcomeName(truth[i]), line.c_str());
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(threads, 1); ++t) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();

  int truth_reject = 0;
  for (pb::Outcome o : truth) truth_reject += o == pb::FAIL;
  std::printf("longtau_units %d units\n", units);
  std::printf("longtau_truth_reject_units %d units\n", truth_reject);
  std::printf("longtau_rrw_limit %g deg/h/sqrt(h)\n", limit->high());
  std::printf("longtau_rrw_scale %g 1\n", rrw_scale);
  std::printf("longtau_full_soak %.0f s\n", soak_s);
  const double n = units;
  for (size_t a = 0; a < arms.size(); ++a) {
    int wrong = 0, differs = 0, category = 0, inconclusive = 0, with_u = 0, bound = 0;
    int cover1 = 0, cover2 = 0;
    double ss = 0;
    for (int i = 0; i < units; ++i) {
      const ArmResult& r = results[i][a];
      const ArmResult& full = results[i][0];
      if (r.verdict == pb::INCONCLUSIVE) {
        ++inconclusive;
      } else {
        wrong += judge::Accepted(r.verdict) != judge::Accepted(truth[i]);
      }
      differs += judge::Accepted(r.verdict) != judge::Accepted(full.verdict);
      category += r.verdict != truth[i];
      for (const Reading& k : r.readings) {
        if (k.upper_bound) {
          ++bound;
        } else if (std::isfinite(k.k) && std::isfinite(k.u) && k.u > 0) {
          ++with_u;
          const double z = (k.k - k.truth) / k.u;
          ss += z * z;
          cover1 += std::abs(z) < 1;
          cover2 += std::abs(z) < 2;
        }
      }
    }
    const char* name = arms[a].name.c_str();
    std::printf("longtau_%s_soak_fraction %.3f 1\n", name, arms[a].fraction);
    std::printf("longtau_%s_disposition_error_rate %.4f 1\n", name, wrong / n);
    std::printf("longtau_%s_disposition_differs_from_full %.4f 1\n", name, differs / n);
    std::printf("longtau_%s_verdict_category_error_rate %.4f 1\n", name, category / n);
    std::printf("longtau_%s_inconclusive %d units\n", name, inconclusive);
    std::printf("longtau_%s_rrw_with_u %d axes\n", name, with_u);
    std::printf("longtau_%s_rrw_upper_bound %d axes\n", name, bound);
    if (with_u > 0) {
      std::printf("longtau_%s_rrw_rms_z %.3f 1\n", name, std::sqrt(ss / with_u));
      std::printf("longtau_%s_rrw_cover_1sigma %.3f 1\n", name,
                  static_cast<double>(cover1) / with_u);
      std::printf("longtau_%s_rrw_cover_2sigma %.3f 1\n", name,
                  static_cast<double>(cover2) / with_u);
    }
  }
  return 0;
}
