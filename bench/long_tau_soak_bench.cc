// Soak time saved by the noise model's long taus (plan noise_model_long_taus;
// ./scripts/bench longtau). A simulated lot of navigation-grade FOGs (the
// "fog" profile at --spread, every 8th unit planted with 3 times the rate
// random walk) is judged on the rate random walk, the long-tau figure: the
// fog plan with fit_rate_random_walk's limit moved to where this lot
// straddles it (--rrw-limit deg/h/sqrt(h), marginal at 0.8 of it) and its
// other limits left out, so that a disposition is the walk's alone. Each
// unit's record (the plan's warm-up and soak) is generated once and analysed
// by the station's own analysis (RunAnalyzer) in several arms at once:
//   full, full+theo1   the whole soak, OADEV only / with the long taus
//   f, f+theo1         the first fraction f of the soak (--fractions)
// Per arm it prints the dispositions wrong against the truth (accept = PASS
// or MARGINAL, reject = FAIL, INCONCLUSIVE apart), those differing from the
// full soak's, the verdicts (PASS/MARGINAL/FAIL) wrong, and K's readings:
// how many have a value with a u (else an upper bound: the term left out),
// their rms z against the truth and their 1- and 2-sigma coverage. The
// truth of a unit is its simulated K judged by the same limit. Never
// asserts. Usage: long_tau_soak_bench [--units N] [--fractions 0.25,0.5]
#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/judge/judge.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "analyze/service/run_analyzer.h"
#include "offline/plan_soak_command.h"

namespace imuqual {
namespace {

constexpr double kDegPerHourRootHour = 1.0 / 216000;  // deg/h/sqrt(h) in deg/s/sqrt(s)

struct Arm {
  std::string name;
  double fraction = 1;
  bool theo1 = false;
};

struct ArmResult {
  pb::Outcome verdict = pb::OUTCOME_UNSET;
  double k = NAN, u = NAN;  // fit_rate_random_walk, deg/h/sqrt(h)
  bool upper_bound = false;
};

bool Accepts(pb::Outcome o) { return o == pb::PASS || o == pb::MARGINAL; }

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  CLI::App app{"soak time saved by the noise model's long taus on a simulated FOG lot"};
  int units = 200;
  double spread = 0.35;
  double rrw_limit = 0.004;
  std::string fractions_text = "0.25,0.5";
  int threads = 2;
  std::string lot = "LONGTAU-BENCH";
  bool verbose = false;
  app.add_option("--units", units, "units in the lot")->capture_default_str();
  app.add_option("--spread", spread, "lognormal unit-to-unit spread of the noise terms")
      ->capture_default_str();
  app.add_option("--rrw-limit", rrw_limit, "fit_rate_random_walk high limit, deg/h/sqrt(h)")
      ->capture_default_str();
  app.add_option("--fractions", fractions_text, "shorter soaks, fractions of the plan's")
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
      if (end == item.c_str() || *end != '\0' || !(f > 0 && f < 1)) {
        std::fprintf(stderr, "long_tau_soak_bench: --fractions: '%s' is not in (0, 1)\n",
                     item.c_str());
        return 2;
      }
      arms.push_back({"f" + item, f, false});
      arms.push_back({"f" + item + "+theo1", f, true});
    }
  }
  auto profile = sim::LotProfileByName("fog");
  auto fog_plan = judge::BuiltinPlan("fog");
  if (!profile.ok() || !fog_plan.ok()) {
    std::fprintf(stderr, "long_tau_soak_bench: no fog profile or plan\n");
    return 1;
  }
  profile->spread = spread;
  pb::TestPlan plan = *fog_plan;
  plan.clear_limits();
  pb::Limit* limit = plan.add_limits();
  limit->set_measurement(std::string(judge::kFitRateRandomWalk));
  limit->set_axis_kind(pb::GYRO);
  limit->set_high(rrw_limit);
  limit->set_marginal_high(0.8 * rrw_limit);
  limit->set_unit("deg/h/sqrt(h)");
  if (Status st = judge::ValidatePlan(plan); !st.ok()) {
    std::fprintf(stderr, "long_tau_soak_bench: %s\n", st.message().c_str());
    return 1;
  }
  const double rate = plan.nominal_rate_hz();
  const double warmup_s = plan.warmup_s();
  const double soak_s = plan.min_duration_s();
  const int64_t total = std::llround((warmup_s + soak_s) * rate);
  const uint64_t seed = sim::SeedFromName(lot);

  std::vector<pb::Outcome> truth(units, pb::OUTCOME_UNSET);
  std::vector<std::vector<ArmResult>> results(units, std::vector<ArmResult>(arms.size()));
  std::atomic<int> next{0};
  std::mutex log;
  auto work = [&]() {
    for (int i = next++; i < units; i = next++) {
      const pb::SimTruth t = sim::MakeUnitTruth(*profile, seed, i, rate);
      const double true_k = t.axes(0).rate_random_walk() / kDegPerHourRootHour;
      truth[i] = judge::Evaluate(*limit, true_k);
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
        for (size_t a = 0; a < arms.size(); ++a) {
          if (view.first_sample < ends[a]) (void)analyzers[a]->AddBatch(view);
        }
        return true;
      });
      std::string line;
      for (size_t a = 0; a < arms.size(); ++a) {
        analyzers[a]->Finish(0, std::min(ends[a], total));
        const analyze::RunOutcome out = analyzers[a]->Outcome(true);
        ArmResult& r = results[i][a];
        r.verdict = out.judgement.verdict;
        for (const pb::Measurement& m : out.measurements) {
          if (m.name() != judge::kFitRateRandomWalk) continue;
          r.k = m.value();
          r.u = m.has_uncertainty() ? m.uncertainty() : NAN;
          r.upper_bound = m.qualifier() == pb::UPPER_BOUND;
        }
        char buf[160];
        std::snprintf(buf, sizeof buf, " %s %s %.4g+-%.2g%s", arms[a].name.c_str(),
                      judge::OutcomeName(r.verdict), r.k, r.u, r.upper_bound ? "(ub)" : "");
        line += buf;
      }
      if (verbose) {
        std::lock_guard<std::mutex> lock(log);
        std::fprintf(stderr, "unit %3d %-18s K %.4g truth %-8s%s\n", i, t.profile().c_str(), true_k,
                     judge::OutcomeName(truth[i]), line.c_str());
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
  std::printf("longtau_rrw_limit %g deg/h/sqrt(h)\n", rrw_limit);
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
        wrong += Accepts(r.verdict) != Accepts(truth[i]);
      }
      differs += Accepts(r.verdict) != Accepts(full.verdict);
      category += r.verdict != truth[i];
      const double true_k = sim::MakeUnitTruth(*profile, seed, i, rate).axes(0).rate_random_walk() /
                            kDegPerHourRootHour;
      if (r.upper_bound) {
        ++bound;
      } else if (std::isfinite(r.k) && std::isfinite(r.u) && r.u > 0) {
        ++with_u;
        const double z = (r.k - true_k) / r.u;
        ss += z * z;
        cover1 += std::abs(z) < 1;
        cover2 += std::abs(z) < 2;
      }
    }
    const char* name = arms[a].name.c_str();
    std::printf("longtau_%s_soak_fraction %.3f 1\n", name, arms[a].fraction);
    std::printf("longtau_%s_disposition_error_rate %.4f 1\n", name, wrong / n);
    std::printf("longtau_%s_disposition_differs_from_full %.4f 1\n", name, differs / n);
    std::printf("longtau_%s_verdict_category_error_rate %.4f 1\n", name, category / n);
    std::printf("longtau_%s_inconclusive %d units\n", name, inconclusive);
    std::printf("longtau_%s_rrw_with_u %d units\n", name, with_u);
    std::printf("longtau_%s_rrw_upper_bound %d units\n", name, bound);
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
