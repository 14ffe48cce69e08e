#include "offline/plan_soak_command.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/allan/model_quantities.h"
#include "analyze/judge/early_decision.h"
#include "analyze/judge/plan_file.h"
#include "analyze/service/run_analyzer.h"
#include "common/exit_codes.h"
#include "common/log.h"
#include "report/allan_plots.h"
#include "report/lot_model_view.h"
#include "store/archive.h"

namespace imuqual::offline {
using report::ArchivedModel;
using report::AxisPlotData;
using report::LoadArchivedModel;
using report::LoadLatestRuns;
using report::RunPlotData;

namespace {

std::optional<allan::SensorKind> Sensor(pb::AxisKind kind) {
  return kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
}

// A composite model (base units) as the simulator's truth of one axis.
pb::AxisTruth TruthOf(const allan::CompositeModel& model, const std::string& axis) {
  pb::AxisTruth t;
  t.set_axis(axis);
  for (const allan::ModelTerm& term : model.terms) {
    switch (term.kind) {
      case allan::TermKind::kQuantization:
        t.set_quantization(term.scale);
        break;
      case allan::TermKind::kWhite:
        t.set_random_walk(term.scale);
        break;
      case allan::TermKind::kFlicker:
        t.set_bias_instability(term.scale);
        break;
      case allan::TermKind::kRandomWalk:
        t.set_rate_random_walk(term.scale);
        break;
      case allan::TermKind::kDrift:
        t.set_rate_ramp(term.scale);
        break;
      case allan::TermKind::kGaussMarkov: {
        pb::GaussMarkov* g = t.add_gauss_markov();
        g->set_sigma(term.scale);
        g->set_correlation_time_s(term.correlation_time_s);
        break;
      }
      case allan::TermKind::kSinusoid: {
        pb::Sinusoid* s = t.add_sinusoids();
        s->set_amplitude(term.scale);
        s->set_frequency_hz(term.frequency_hz);
        break;
      }
    }
  }
  return t;
}

std::vector<std::string> SplitComma(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) {
    const size_t b = cell.find_first_not_of(" \t\r");
    const size_t e = cell.find_last_not_of(" \t\r");
    out.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
  }
  return out;
}

// --model FILE: one truth, every plan axis described.
Result<pb::SimTruth> ReadModelFile(const std::string& path, const pb::TestPlan& plan) {
  std::ifstream in(path);
  if (!in) return Status::NotFound(path + ": cannot be read");
  std::map<std::string, std::vector<allan::ModelQuantity>> terms;
  std::string line;
  int line_no = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    const std::vector<std::string> cells = SplitComma(line);
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (!header) {
      if (cells != std::vector<std::string>{"axis", "name", "value", "unit"}) {
        return Status::InvalidArgument(where + "the header must be axis,name,value,unit");
      }
      header = true;
      continue;
    }
    if (cells.size() != 4) {
      return Status::InvalidArgument(where + "expected 4 columns (axis,name,value,unit), found " +
                                     std::to_string(cells.size()));
    }
    allan::ModelQuantity q;
    q.name = cells[1].starts_with("model_") ? cells[1].substr(6) : cells[1];
    char* end = nullptr;
    q.value = std::strtod(cells[2].c_str(), &end);
    if (cells[2].empty() || *end != '\0' || !std::isfinite(q.value)) {
      return Status::InvalidArgument(where + "value '" + cells[2] + "' is not a number");
    }
    q.unit = cells[3];
    terms[cells[0]].push_back(q);
  }
  if (!header) return Status::InvalidArgument(path + ": empty (expected axis,name,value,unit)");
  pb::SimTruth truth;
  for (const pb::Axis& axis : plan.axes()) {
    auto it = terms.find(axis.name());
    if (it == terms.end()) {
      return Status::InvalidArgument(path + ": no model terms for the plan's axis '" + axis.name() +
                                     "'");
    }
    auto model = allan::ModelFromTerms(it->second, Sensor(axis.kind()));
    if (!model.ok()) {
      return Status::InvalidArgument(path + ": axis " + axis.name() + ": " +
                                     model.status().message());
    }
    if (model->terms.empty()) {
      return Status::InvalidArgument(path + ": axis " + axis.name() +
                                     ": no known model term (white_noise, flicker_floor, ...)");
    }
    *truth.add_axes() = TruthOf(*model, axis.name());
  }
  // Not a structured binding: Clang 14 cannot capture one in the lambda.
  for (const auto& entry : terms) {
    const std::string& axis = entry.first;
    if (std::none_of(plan.axes().begin(), plan.axes().end(),
                     [&](const pb::Axis& a) { return a.name() == axis; })) {
      return Status::InvalidArgument(path + ": axis '" + axis + "' is not one of the plan's");
    }
  }
  return truth;
}

// --lot LOT --db FILE: one truth per unit whose latest run has a model on
// every plan axis; `skipped` counts the others.
Result<std::vector<std::pair<std::string, pb::SimTruth>>> ReadLot(const std::string& db,
                                                                  const std::string& lot,
                                                                  const pb::TestPlan& plan,
                                                                  int* skipped) {
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  if (!archive.ok()) return archive.status();
  auto runs = LoadLatestRuns(**archive, lot);
  if (!runs.ok()) return runs.status();
  std::vector<std::pair<std::string, pb::SimTruth>> out;
  for (const RunPlotData& run : *runs) {
    pb::SimTruth truth;
    bool complete = true;
    for (const pb::Axis& axis : plan.axes()) {
      auto a = std::find_if(run.axes.begin(), run.axes.end(),
                            [&](const AxisPlotData& x) { return x.axis == axis.name(); });
      if (a == run.axes.end()) {
        complete = false;
        break;
      }
      const std::optional<ArchivedModel> model = LoadArchivedModel(*a);
      if (!model || !model->adequate) {
        complete = false;
        break;
      }
      *truth.add_axes() = TruthOf(model->model, axis.name());
    }
    if (complete) {
      out.emplace_back(run.info.serial, std::move(truth));
    } else {
      ++*skipped;
    }
  }
  if (out.empty()) {
    return Status::NotFound("lot " + lot +
                            ": no unit has an adequate noise model on every axis "
                            "of the plan (" +
                            std::to_string(*skipped) + " units)");
  }
  return out;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double at = p * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

int64_t FeedSimulatedRecord(sim::ImuSimulator& simulator, double rate_hz, int64_t total,
                            const std::function<bool(const analyze::BatchView&)>& consume) {
  std::vector<std::vector<float>> samples(simulator.num_axes());
  const int batch = std::max(1, static_cast<int>(rate_hz));
  int64_t counter = 0;
  for (int64_t seq = 0; counter < total; ++seq) {
    const int n = static_cast<int>(std::min<int64_t>(batch, total - counter));
    for (auto& s : samples) s.clear();
    simulator.Generate(n, samples);
    analyze::BatchView view;
    view.seq = seq;
    view.first_sample = counter;
    view.nominal_rate_hz = rate_hz;
    for (const auto& s : samples) view.samples.emplace_back(s);
    counter += n;
    if (!consume(view)) break;
  }
  return counter;
}

Result<std::vector<SoakRecord>> SimulateSoaks(const pb::TestPlan& plan,
                                              const std::vector<pb::SimTruth>& truths,
                                              const std::vector<std::string>& names, int records,
                                              uint64_t seed, int threads) {
  if (!plan.has_early_decision()) {
    return Status::InvalidArgument("plan " + plan.name() +
                                   " has no early_decision: nothing to plan");
  }
  if (truths.empty() || records < 1) return Status::InvalidArgument("nothing to simulate");
  const judge::LookSchedule schedule = judge::MakeLookSchedule(plan);
  const double rate = plan.nominal_rate_hz();
  const int64_t total = std::llround((plan.warmup_s() + schedule.horizon_s) * rate);
  for (const pb::SimTruth& t : truths) {
    pb::SimTruth check = t;
    check.set_actual_rate_hz(rate);
    if (auto s = sim::ImuSimulator::Create(check); !s.ok()) return s.status();
  }
  std::vector<SoakRecord> out(records);
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  Status error = Status::Ok();
  std::mutex error_mu;
  auto work = [&]() {
    for (int i = next++; i < records && !failed; i = next++) {
      const size_t u = static_cast<size_t>(i) % truths.size();
      pb::SimTruth truth = truths[u];
      truth.set_actual_rate_hz(rate);
      truth.set_seed(seed * 1000003ULL + static_cast<uint64_t>(i));
      auto simulator = sim::ImuSimulator::Create(truth);
      analyze::RunDescription desc;
      desc.run_id = "plan-soak-" + std::to_string(i);
      desc.serial = names[u];
      desc.nominal_rate_hz = rate;
      for (const pb::Axis& a : plan.axes()) desc.axes.push_back({a.name(), a.kind()});
      desc.plan = plan;
      auto analyzer = analyze::RunAnalyzer::Create(desc);
      if (!simulator.ok() || !analyzer.ok()) {
        std::lock_guard<std::mutex> lock(error_mu);
        error = !simulator.ok() ? simulator.status() : analyzer.status();
        failed = true;
        return;
      }
      FeedSimulatedRecord(*simulator, rate, total, [&](const analyze::BatchView& view) {
        (void)analyzer->AddBatch(view);
        return !analyzer->decided();
      });
      // The decider says all (no Outcome: its curves and measurements unused).
      const judge::EarlyDecider& d = *analyzer->decider();
      SoakRecord& r = out[i];
      r.unit = names[u];
      r.decided = d.unit_decision() != judge::Decision::kPending;
      r.fail = d.unit_decision() == judge::Decision::kFail;
      r.decided_at_s = r.decided ? d.decided_time_s() : schedule.horizon_s;
      if (!d.looks().empty() && !r.decided) {
        for (const judge::LookEntry& e : d.looks().back().entries) {
          if (e.decision == judge::Decision::kPending) r.pending.push_back(e.axis + " " + e.name);
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();
  if (failed) return error;
  return out;
}

int PlanSoakCommand(const PlanSoakOptions& o) {
  const int sources = !o.model.empty() + !o.lot.empty() + !o.profile.empty();
  if (sources != 1) {
    LogError("plan-soak: give exactly one of --model FILE, --lot LOT --db FILE, --profile NAME");
    return kExitUsage;
  }
  if (!o.lot.empty() && o.db.empty()) {
    LogError("plan-soak: --lot needs --db FILE");
    return kExitUsage;
  }
  if (o.records < 1) {
    LogError("plan-soak: --records must be >= 1");
    return kExitUsage;
  }
  auto plan = judge::LoadPlan(o.plan);
  if (!plan.ok()) {
    LogError("plan-soak: " + plan.status().message());
    return kExitUsage;
  }
  if (!plan->has_early_decision()) {
    char soak[32];
    std::snprintf(soak, sizeof soak, "%g", plan->min_duration_s());
    LogError("plan-soak: plan " + o.plan +
             " has no early_decision { risk: ... min_duration_s: ... }: every unit soaks " + soak +
             " s");
    return kExitUsage;
  }
  std::vector<pb::SimTruth> truths;
  std::vector<std::string> names;
  std::string source;
  if (!o.model.empty()) {
    auto t = ReadModelFile(o.model, *plan);
    if (!t.ok()) {
      LogError("plan-soak: " + t.status().message());
      return kExitUsage;
    }
    truths.push_back(*t);
    names.push_back("typical");
    source = "model " + o.model + " (one typical unit; every record a new realisation)";
  } else if (!o.lot.empty()) {
    int skipped = 0;
    auto units = ReadLot(o.db, o.lot, *plan, &skipped);
    if (!units.ok()) {
      LogError("plan-soak: " + units.status().message());
      return kExitUsage;
    }
    for (auto& [serial, truth] : *units) {
      names.push_back(serial);
      truths.push_back(std::move(truth));
    }
    source = "lot " + o.lot + ": noise models of " + std::to_string(truths.size()) + " units" +
             (skipped ? " (" + std::to_string(skipped) +
                            " without an adequate model on every axis: not used)"
                      : "");
  } else {
    auto profile = sim::LotProfileByName(o.profile);
    if (!profile.ok()) {
      LogError("plan-soak: " + profile.status().message());
      return kExitUsage;
    }
    for (int i = 0; i < o.records; ++i) {
      pb::SimTruth t = sim::MakeUnitTruth(*profile, o.seed, i, plan->nominal_rate_hz());
      // The profile's axes must be the plan's.
      if (t.axes_size() != plan->axes_size()) {
        LogError("plan-soak: profile " + o.profile + " has " + std::to_string(t.axes_size()) +
                 " axes, plan " + plan->name() + " " + std::to_string(plan->axes_size()));
        return kExitUsage;
      }
      for (int a = 0; a < t.axes_size(); ++a) t.mutable_axes(a)->set_axis(plan->axes(a).name());
      truths.push_back(std::move(t));
      names.push_back(o.profile + "#" + std::to_string(i));
    }
    char buf[160];
    std::snprintf(buf, sizeof buf, "profile %s (typical unit, spread %.2g, planted failures)",
                  o.profile.c_str(), profile->spread);
    source = buf;
  }

  auto records = SimulateSoaks(*plan, truths, names, o.records, o.seed, o.threads);
  if (!records.ok()) {
    LogError("plan-soak: " + records.status().message());
    return kExitError;
  }
  const judge::LookSchedule s = judge::MakeLookSchedule(*plan);
  const pb::EarlyDecision& e = plan->early_decision();
  int decided = 0, fails = 0;
  std::vector<double> times, slot_ratio;
  std::map<std::string, int> pending;
  for (const SoakRecord& r : *records) {
    decided += r.decided;
    fails += r.fail;
    times.push_back(r.decided_at_s);
    slot_ratio.push_back((plan->warmup_s() + r.decided_at_s) / (plan->warmup_s() + s.horizon_s));
    for (const std::string& p : r.pending) ++pending[p];
  }
  const double n = static_cast<double>(records->size());
  std::printf("plan       %s (%s)\n", plan->name().c_str(), o.plan.c_str());
  std::printf(
      "decisions  risk %g per unit%s; looks every %g s from %g s to %g s (%zu looks), "
      "horizon %g s + %g s warm-up\n",
      e.risk(),
      e.marginal_flags() == pb::EarlyDecision::FLAGS_DECIDED ? ", marginal bands decided too"
      : e.marginal_flags() == pb::EarlyDecision::FLAGS_AGREE_FULL_LENGTH
          ? ", marginal flags as at full length"
          : "",
      s.times_s.size() > 1 ? s.times_s[1] - s.times_s[0] : 0.0,
      s.times_s.empty() ? 0.0 : s.times_s.front(), s.times_s.empty() ? 0.0 : s.times_s.back(),
      s.times_s.size(), s.horizon_s, plan->warmup_s());
  std::printf("source     %s\n", source.c_str());
  std::printf("records    %zu simulated (seed %llu)\n", records->size(),
              static_cast<unsigned long long>(o.seed));
  std::printf(
      "decided    %d of %zu by the horizon (%.1f %%): %d PASS, %d FAIL; %zu pending to "
      "the end (full-length verdict)\n",
      decided, records->size(), 100.0 * decided / n, decided - fails, fails,
      records->size() - decided);
  // The median's Monte Carlo standard error from the binomial order
  // statistics (the records ranked n/2 -+ sqrt(n)/2).
  const double se_lo = Percentile(times, std::max(0.0, 0.5 - 0.5 / std::sqrt(n)));
  const double se_hi = Percentile(times, std::min(1.0, 0.5 + 0.5 / std::sqrt(n)));
  std::printf("time to decide (analysed device time; pending = horizon):\n");
  std::printf("           p10 %.0f s   median %.0f s (+-%.0f s Monte Carlo)   p90 %.0f s\n",
              Percentile(times, 0.1), Percentile(times, 0.5), 0.5 * (se_hi - se_lo),
              Percentile(times, 0.9));
  std::printf("slot time  median %.0f s of %.0f s full (ratio %.2f); mean ratio %.2f\n",
              plan->warmup_s() + Percentile(times, 0.5), plan->warmup_s() + s.horizon_s,
              Percentile(slot_ratio, 0.5), [&] {
                double sum = 0;
                for (double r : slot_ratio) sum += r;
                return sum / n;
              }());
  if (!pending.empty()) {
    std::vector<std::pair<int, std::string>> by_count;
    for (const auto& [what, count] : pending) by_count.emplace_back(count, what);
    std::sort(by_count.rbegin(), by_count.rend());
    std::printf("pending to the end on (records):");
    for (size_t i = 0; i < by_count.size() && i < 8; ++i) {
      std::printf("%s %s %d", i ? "," : "", by_count[i].second.c_str(), by_count[i].first);
    }
    std::printf("\n");
  }
  return 0;
}

}  // namespace imuqual::offline
