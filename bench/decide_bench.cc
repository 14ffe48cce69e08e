// Early decisions against full-length soaks on a simulated lot with known
// truth (./scripts/bench decide). Each unit's record is generated once and
// analysed twice by the station's own analysis (RunAnalyzer): with the
// plan's early_decision (fed until the unit is decided, as a station would
// stop its source) and without (the whole soak). Prints
//   soak_time_ratio_median     slot time (warm-up + analysed) decided / full
//   decision_disagreement_rate early verdict != full-length verdict
//     (PASS, MARGINAL, FAIL), and _accept_reject (PASS or MARGINAL vs FAIL)
//   decision_error_rate_vs_truth_{early,full}  accept/reject side wrong
//     against the truth's verdict (PASS or MARGINAL = accept)
//   verdict_category_error_rate_vs_truth_{early,full}  PASS/MARGINAL/FAIL
// and the units decided, pending to the end, and their soak times. The truth
// of a unit is its simulated noise model (acquire/lot_profile.h): its Allan
// deviation minimum over the taus the full-length curve shows, the tau of
// that minimum and N, judged against the plan's limits. Never asserts.
// DECIDE_TRACE=1 prints every 10th look of every unit (what is pending).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/allan/composite_model.h"
#include "analyze/allan/tau_grid.h"
#include "analyze/judge/judge.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "analyze/judge/stationarity_measure.h"
#include "analyze/service/run_analyzer.h"
#include "offline/plan_soak_command.h"

namespace imuqual {
namespace {

struct UnitResult {
  int index = 0;
  std::string role;
  pb::Outcome truth = pb::OUTCOME_UNSET;
  pb::Outcome full = pb::OUTCOME_UNSET;
  pb::Outcome early = pb::OUTCOME_UNSET;
  bool decided = false;
  double decided_at_s = 0;
  double truth_bi = 0;  // worst axis, deg/h
  std::string pending;  // what the last look left pending
  std::string differs;  // --verbose: measurements judged differently early
  // --calibration: (fraction, measurements) at a few times, and at the end.
  std::vector<std::pair<double, std::vector<pb::Measurement>>> snapshots;
  std::vector<pb::Measurement> final_measurements;
};

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? NAN : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// How well a reading and its uncertainty at fraction f predict the
// full-length reading: z = (full - now) / (u sqrt(1 - f)) should be about
// N(0, 1) for an efficient estimator; the flag rule FLAGS_AGREE_FULL_LENGTH
// relies on |z| < 2.33 in 99 % of units.
void PrintCalibration(const std::vector<UnitResult>& results) {
  const std::string_view names[] = {judge::kBiasInstability, judge::kTauAtMinimum,
                                    judge::kAngleRandomWalk};
  for (std::string_view name : names) {
    std::map<int, std::vector<double>> zs;  // by fraction in percent
    for (const UnitResult& r : results) {
      for (const auto& [f, ms] : r.snapshots) {
        for (const pb::Measurement& m : ms) {
          if (m.name() != name || !m.has_uncertainty() || !(m.uncertainty() > 0)) continue;
          for (const pb::Measurement& g : r.final_measurements) {
            if (g.name() != name || g.axis() != m.axis() || !std::isfinite(g.value())) continue;
            zs[static_cast<int>(std::lround(f * 100))].push_back(
                (g.value() - m.value()) / (m.uncertainty() * std::sqrt(1 - f)));
          }
        }
      }
    }
    for (auto& [pct, z] : zs) {
      double ss = 0;
      int beyond = 0;
      for (double x : z) {
        ss += x * x;
        beyond += std::abs(x) > 2.33;
      }
      std::sort(z.begin(), z.end());
      std::printf(
          "calibration_%s_f%02d rms_z %.3f beyond_2.33 %.4f p50_abs_z %.3f n %zu\n",
          std::string(name).c_str(), pct, std::sqrt(ss / z.size()),
          static_cast<double>(beyond) / z.size(),
          [&] {
            std::vector<double> a;
            for (double x : z) a.push_back(std::abs(x));
            return Median(a);
          }(),
          z.size());
    }
  }
}

// The truth's verdict: the plan's limits on the truth's bias instability
// (curve minimum up to m_max), tau at minimum and angle random walk.
pb::Outcome TruthVerdict(const pb::TestPlan& plan, const pb::SimTruth& truth, double tau0,
                         int64_t m_max, double* worst_bi) {
  pb::Outcome worst = pb::PASS;
  *worst_bi = 0;
  auto fold = [&](pb::Outcome o) {
    if (o == pb::FAIL || (o == pb::MARGINAL && worst == pb::PASS)) worst = o;
  };
  for (const pb::AxisTruth& a : truth.axes()) {
    const allan::CompositeModel model = judge::CompositeModelOf(a);
    double best = INFINITY, best_m = 1;
    const int steps = 2000;
    for (int i = 0; i <= steps; ++i) {
      const double m = std::exp2(std::log2(static_cast<double>(m_max)) * i / steps);
      const double dev = model.Deviation(m, tau0);
      if (dev < best) {
        best = dev;
        best_m = m;
      }
    }
    const judge::AxisDesc axis{a.axis(), pb::GYRO};
    const double values[] = {best * 3600.0, best_m * tau0, a.random_walk() * 60.0};
    const std::string_view names[] = {judge::kBiasInstability, judge::kTauAtMinimum,
                                      judge::kAngleRandomWalk};
    *worst_bi = std::max(*worst_bi, values[0]);
    for (int k = 0; k < 3; ++k) {
      const pb::Limit* limit = judge::FindLimit(plan, std::string(names[k]), &axis);
      if (limit) fold(judge::Evaluate(*limit, values[k]));
    }
  }
  return worst;
}

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  CLI::App app{"early decisions vs full-length soaks on a simulated lot"};
  int units = 200;
  double spread = 0.35;
  double risk = 0.01;
  double min_duration_s = 600;
  double look_period_s = 60;
  int threads = 2;
  std::string lot = "DECIDE-BENCH";
  bool verbose = false;
  std::string flags = "at_decision";
  app.add_option("--units", units, "units in the lot")->capture_default_str();
  app.add_option("--spread", spread, "lognormal unit-to-unit spread of the noise terms")
      ->capture_default_str();
  app.add_option("--risk", risk, "early_decision.risk")->capture_default_str();
  app.add_option("--min-duration", min_duration_s, "early_decision.min_duration_s")
      ->capture_default_str();
  app.add_option("--look-period", look_period_s, "early_decision.look_period_s")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads")->capture_default_str();
  app.add_option("--lot", lot, "lot name (seeds the truths)")->capture_default_str();
  app.add_flag("--verbose", verbose, "one line per unit on stderr");
  bool calibration = false;
  app.add_flag("--calibration", calibration,
               "how well each reading and its uncertainty predict the full-length reading");
  app.add_option("--marginal-flags", flags,
                 "early_decision.marginal_flags: at_decision, agree_full_length or decided")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  auto profile = sim::LotProfileByName("vg700");
  auto full_plan = judge::BuiltinPlan("vg700ca");
  if (!profile.ok() || !full_plan.ok()) {
    std::fprintf(stderr, "decide_bench: no vg700 profile or plan\n");
    return 1;
  }
  profile->spread = spread;
  pb::TestPlan early_plan = *full_plan;
  early_plan.mutable_early_decision()->set_risk(risk);
  early_plan.mutable_early_decision()->set_min_duration_s(min_duration_s);
  early_plan.mutable_early_decision()->set_look_period_s(look_period_s);
  std::string mode_name = "FLAGS_" + flags;
  for (char& c : mode_name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  pb::EarlyDecision::MarginalFlags mode;
  if (!pb::EarlyDecision::MarginalFlags_Parse(mode_name, &mode)) {
    std::fprintf(stderr, "decide_bench: --marginal-flags: unknown mode '%s'\n", flags.c_str());
    return 2;
  }
  early_plan.mutable_early_decision()->set_marginal_flags(mode);
  if (Status st = judge::ValidatePlan(early_plan); !st.ok()) {
    std::fprintf(stderr, "decide_bench: %s\n", st.message().c_str());
    return 1;
  }
  const double rate = full_plan->nominal_rate_hz();
  const double tau0 = 1.0 / rate;
  const double warmup_s = full_plan->warmup_s();
  const double soak_s = full_plan->min_duration_s();
  const int64_t total = std::llround((warmup_s + soak_s) * rate);
  const int64_t m_max = allan::StopRuleMaxAveragingFactor(
      allan::StopRule::kBins9, allan::Deviation::kOadev, std::llround(soak_s * rate) + 1);
  const uint64_t seed = sim::SeedFromName(lot);

  std::vector<UnitResult> results(units);
  std::atomic<int> next{0};
  std::mutex log;
  auto work = [&]() {
    for (int i = next++; i < units; i = next++) {
      UnitResult& r = results[i];
      r.index = i;
      const pb::SimTruth truth = sim::MakeUnitTruth(*profile, seed, i, rate);
      r.role = truth.profile();
      r.truth = TruthVerdict(*full_plan, truth, tau0, m_max, &r.truth_bi);
      auto simulator = sim::ImuSimulator::Create(truth);
      analyze::RunDescription desc;
      desc.run_id = "R" + std::to_string(i);
      desc.serial = "U" + std::to_string(i);
      desc.nominal_rate_hz = rate;
      for (const pb::Axis& a : full_plan->axes()) desc.axes.push_back({a.name(), a.kind()});
      desc.plan = *full_plan;
      auto full = analyze::RunAnalyzer::Create(desc);
      desc.plan = early_plan;
      auto early = analyze::RunAnalyzer::Create(desc);
      if (!simulator.ok() || !full.ok() || !early.ok()) {
        std::fprintf(stderr, "decide_bench: unit %d could not be set up\n", i);
        continue;
      }
      int64_t early_end = -1;
      const double snap_s[] = {600, 900, 1200, 1800, 2400};
      size_t next_snap = 0;
      offline::FeedSimulatedRecord(*simulator, rate, total, [&](const analyze::BatchView& view) {
        (void)full->AddBatch(view);
        const double analysed_s =
            static_cast<double>(full->analysed_end_counter()) * tau0 - warmup_s;
        if (calibration && next_snap < std::size(snap_s) && analysed_s >= snap_s[next_snap]) {
          r.snapshots.emplace_back(analysed_s / soak_s, full->Outcome(false).measurements);
          ++next_snap;
        }
        if (early_end < 0) {
          (void)early->AddBatch(view);
          // The station stops the source once the unit is decided.
          if (early->decided()) {
            early_end = view.first_sample + static_cast<int64_t>(view.samples[0].size());
          }
        }
        return true;
      });
      full->Finish(0, total);
      early->Finish(0, early_end < 0 ? total : early_end);
      const analyze::RunOutcome f = full->Outcome(true);
      const analyze::RunOutcome e = early->Outcome(true);
      r.full = f.judgement.verdict;
      r.early = e.judgement.verdict;
      if (calibration) r.final_measurements = f.measurements;
      if (verbose && r.full != r.early) {
        // Which judged measurements read differently, early and full length.
        for (const pb::Measurement& g : f.measurements) {
          for (const pb::Measurement& m : e.measurements) {
            if (m.axis() != g.axis() || m.name() != g.name() || m.outcome() == g.outcome())
              continue;
            r.differs += "\n    " + m.axis() + " " + m.name() + " early " +
                         judge::OutcomeName(m.outcome()) + " " + std::to_string(m.value()) +
                         " +- " + std::to_string(m.uncertainty()) + ", full " +
                         judge::OutcomeName(g.outcome()) + " " + std::to_string(g.value()) +
                         " +- " + std::to_string(g.uncertainty());
          }
        }
      }
      r.decided = e.early && e.early->unit != judge::Decision::kPending;
      r.decided_at_s = r.decided ? e.early->decided_at_s : soak_s;
      if (getenv("DECIDE_TRACE") && e.early) {
        std::lock_guard<std::mutex> lock(log);
        for (const judge::Look& look : e.early->looks) {
          if (look.index % 10 != 0) continue;
          std::fprintf(stderr, "  unit %d look %d: %s\n", i, look.index, look.note.c_str());
          for (const judge::LookEntry& entry : look.entries) {
            if (entry.decision == judge::Decision::kPending || entry.name == "tau_at_minimum")
              std::fprintf(stderr, "     %s %s %g +- %g\n", entry.axis.c_str(), entry.name.c_str(),
                           entry.value, entry.uncertainty);
          }
        }
      }
      if (e.early && !e.early->looks.empty()) {
        for (const judge::LookEntry& entry : e.early->looks.back().entries) {
          if (entry.decision == judge::Decision::kPending) r.pending += "\n    " + entry.why;
        }
        if (!e.early->looks.back().note.empty()) r.pending += "\n    " + e.early->looks.back().note;
      }
      if (verbose) {
        std::lock_guard<std::mutex> lock(log);
        std::fprintf(
            stderr, "unit %3d %-13s truth %-8s full %-8s early %-8s %s bi %.2f\n", i,
            r.role.c_str(), judge::OutcomeName(r.truth), judge::OutcomeName(r.full),
            judge::OutcomeName(r.early),
            r.decided ? ("decided at " + std::to_string(std::lround(r.decided_at_s)) + " s").c_str()
                      : "pending to the end",
            r.truth_bi);
        if (!r.decided) std::fprintf(stderr, "  pending:%s\n", r.pending.c_str());
        if (!r.differs.empty())
          std::fprintf(stderr, "  judged differently:%s\n", r.differs.c_str());
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(threads, 1); ++t) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();

  std::vector<double> ratios, decided_times;
  int disagree = 0, disagree_side = 0, early_wrong = 0, full_wrong = 0, early_cat = 0, full_cat = 0,
      decided = 0;
  int truth_fail = 0, early_fail_decided = 0;
  for (const UnitResult& r : results) {
    ratios.push_back((warmup_s + r.decided_at_s) / (warmup_s + soak_s));
    if (r.decided) {
      ++decided;
      decided_times.push_back(r.decided_at_s);
      if (r.early == pb::FAIL) ++early_fail_decided;
    }
    disagree += r.early != r.full;
    disagree_side += judge::Accepted(r.early) != judge::Accepted(r.full);
    early_wrong += judge::Accepted(r.early) != judge::Accepted(r.truth);
    full_wrong += judge::Accepted(r.full) != judge::Accepted(r.truth);
    early_cat += r.early != r.truth;
    full_cat += r.full != r.truth;
    truth_fail += r.truth == pb::FAIL;
  }
  const double n = units;
  std::printf("decide_units %d units\n", units);
  std::printf("decide_truth_fail_units %d units\n", truth_fail);
  std::printf("decide_risk %g 1\n", risk);
  std::printf("decide_marginal_flags_%s 1 mode\n", flags.c_str());
  std::printf("soak_time_ratio_median %.4f 1\n", Median(ratios));
  std::printf(
      "soak_time_saved_fraction %.4f 1\n", 1.0 - [&] {
        double s = 0;
        for (double x : ratios) s += x;
        return s / n;
      }());
  std::printf("decided_early_fraction %.4f 1\n", decided / n);
  std::printf("decided_fail_units %d units\n", early_fail_decided);
  std::printf("decision_time_median_s %.0f s\n", Median(decided_times));
  std::printf("decision_disagreement_rate %.4f 1\n", disagree / n);
  std::printf("decision_disagreement_rate_accept_reject %.4f 1\n", disagree_side / n);
  std::printf("decision_error_rate_vs_truth_early %.4f 1\n", early_wrong / n);
  std::printf("decision_error_rate_vs_truth_full %.4f 1\n", full_wrong / n);
  std::printf("verdict_category_error_rate_vs_truth_early %.4f 1\n", early_cat / n);
  std::printf("verdict_category_error_rate_vs_truth_full %.4f 1\n", full_cat / n);
  if (calibration) PrintCalibration(results);
  return 0;
}
