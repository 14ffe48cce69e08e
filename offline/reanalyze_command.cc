#include "offline/reanalyze_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "analyze/judge/judge.h"
#include "analyze/judge/measurements.h"
#include "common/exit_codes.h"
#include "common/log.h"
#include "offline/curve_request.h"
#include "report/early_decisions.h"
#include "store/archive.h"
#include "store/checksums.h"
#include "store/outcome.h"
#include "store/reanalysis.h"

namespace imuqual::offline {
using report::DecisionTimeText;
using report::Format;
using report::LooksTable;
using report::ParseFormat;

namespace {

int Exact(store::Archive& archive, const ReanalyzeOptions& o, Format format) {
  auto request = ParseCurveRequest(o.devs, o.grid, o.stop, o.ci, o.confidence);
  if (!request.ok()) {
    LogError(request.status().message());
    return 2;
  }
  auto run = store::LoadRunSamples(archive, o.run_id);
  if (!run.ok()) {
    LogError(run.status().message());
    return run.status().code() == Status::Code::kNotFound ? 2 : 1;
  }
  if (run->samples.empty() || run->samples[0].empty()) {
    LogError("run " + o.run_id + " has no archived samples");
    return 1;
  }
  const double tau0 = 1.0 / run->info.nominal_rate_hz;
  std::vector<LabeledCurve> curves;
  for (size_t a = 0; a < run->samples.size(); ++a) {
    const allan::PhaseRecord phase = allan::PhaseFromRate(run->samples[a], tau0, run->invalid[a]);
    for (allan::Curve& c : ComputeCurves(phase, *request)) {
      curves.emplace_back(run->info.axes[a].name, std::move(c));
    }
  }
  const bool with_ci = request->ci != allan::CiMethod::kNone;
  if (format == Format::kTable) {
    std::printf(
        "run %s (unit %s, lot %s): %zu samples per axis at %g Hz from device counter %lld%s\n",
        o.run_id.c_str(), run->info.serial.c_str(), run->info.lot.c_str(), run->samples[0].size(),
        run->info.nominal_rate_hz, static_cast<long long>(run->first_counter),
        run->skipped_chunks ? " (some chunks skipped: counter went backwards)" : "");
  }
  std::printf("%s", CurveTable(curves, with_ci, true, true).Render(format).c_str());
  return 0;
}

// The run's stored checksums: one line per damaged chunk or result.
int CheckRunChecksums(store::Archive& archive, const std::string& run_id) {
  auto key = archive.FindRunKey(run_id);
  if (!key.ok() || !key->has_value()) return 0;  // re-analysis says the run is not there
  auto problems = store::CheckChecksums(
      archive.db(), **key, [](const std::string& line) { std::printf("%s\n", line.c_str()); });
  if (!problems.ok()) {
    LogError(problems.status().message());
    return 1;
  }
  if (*problems > 0) {
    LogError("run " + run_id + ": " + std::to_string(*problems) +
             " archived chunks or results do not match their checksums");
    return 1;
  }
  return 0;
}

std::string Exactly(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The same number, NaN (not measured; NULL in the archive) included.
bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// An optional field as archived: absent and NaN are both NULL.
double Opt(bool has, double v) { return has ? v : std::nan(""); }

// Each differing point of an axis's curve (at most a few, then a count).
void ComparePoints(const std::string& axis, const std::vector<allan::CurvePoint>& archived,
                   const std::vector<allan::CurvePoint>& again,
                   std::vector<std::string>* problems) {
  constexpr int kShown = 3;
  int differ = 0;
  for (size_t p = 0; p < archived.size(); ++p) {
    const allan::CurvePoint& x = archived[p];
    const allan::CurvePoint& y = again[p];
    const std::pair<const char*, std::pair<double, double>> fields[] = {
        {"m", {static_cast<double>(x.m), static_cast<double>(y.m)}},
        {"tau_s", {x.tau_s, y.tau_s}},
        {"dev", {x.dev, y.dev}},
        {"lo", {x.lo, y.lo}},
        {"hi", {x.hi, y.hi}},
        {"edf", {x.edf, y.edf}},
        {"alpha", {x.alpha ? *x.alpha : std::nan(""), y.alpha ? *y.alpha : std::nan("")}},
        {"alpha inherited", {x.alpha_inherited ? 1.0 : 0.0, y.alpha_inherited ? 1.0 : 0.0}},
        {"n", {static_cast<double>(x.n), static_cast<double>(y.n)}},
        {"stride", {static_cast<double>(x.stride), static_cast<double>(y.stride)}}};
    bool counted = false;
    for (const auto& [name, v] : fields) {
      if (Same(v.first, v.second)) continue;
      if (!counted) ++differ;
      counted = true;
      if (differ <= kShown) {
        problems->push_back("axis " + axis + ", curve point " + std::to_string(p) +
                            " (m=" + std::to_string(x.m) + ") " + name + ": archived " +
                            Exactly(v.first) + ", recomputed " + Exactly(v.second));
      }
    }
  }
  if (differ > kShown) {
    problems->push_back("axis " + axis + ": " + std::to_string(differ) + " of " +
                        std::to_string(archived.size()) + " curve points differ in all");
  }
}

// An outcome's text, "-" when not judged.
std::string Shown(pb::Outcome outcome) {
  const std::string text = store::OutcomeText(outcome);
  return text.empty() ? "-" : text;
}

// A qualifier's or decision rule's text, "none" for the default.
std::string Named(const char* text) { return *text ? text : "none"; }

// The verdict, its reasons and every measurement, by axis and name.
void CompareJudgements(const store::ResultRecord& archived, const analyze::RunOutcome& again,
                       std::vector<std::string>* problems) {
  const std::string recomputed_verdict = Shown(again.judgement.verdict);
  const std::string archived_verdict = archived.verdict.empty() ? "-" : archived.verdict;
  if (archived_verdict != recomputed_verdict) {
    problems->push_back("verdict: archived " + archived_verdict + ", recomputed " +
                        recomputed_verdict);
  }
  const std::set<std::string> a_reasons(archived.reasons.begin(), archived.reasons.end());
  const std::set<std::string> r_reasons(again.judgement.reasons.begin(),
                                        again.judgement.reasons.end());
  for (const std::string& r : a_reasons) {
    if (!r_reasons.count(r)) problems->push_back("reason archived only: " + r);
  }
  for (const std::string& r : r_reasons) {
    if (!a_reasons.count(r)) problems->push_back("reason recomputed only: " + r);
  }
  auto label = [](const pb::Measurement& m) {
    return (m.axis().empty() ? std::string("run") : "axis " + m.axis()) + ", " + m.name();
  };
  std::map<std::pair<std::string, std::string>, const pb::Measurement*> stored;
  for (const pb::Measurement& m : archived.measurements) stored[{m.axis(), m.name()}] = &m;
  // The temperature measurements came after some archives: a run archived
  // without them (by an earlier imuqual) is not a different result for them.
  const auto is_temperature = [](const std::string& name) {
    return name == judge::kTemperatureMean || name == judge::kTemperatureRange ||
           name == judge::kTemperatureSlope;
  };
  const bool archived_temperature =
      std::any_of(archived.measurements.begin(), archived.measurements.end(),
                  [&](const pb::Measurement& m) { return is_temperature(m.name()); });
  for (const pb::Measurement& y : again.measurements) {
    if (!archived_temperature && is_temperature(y.name())) continue;
    auto it = stored.find({y.axis(), y.name()});
    if (it == stored.end()) {
      problems->push_back(label(y) + ": recomputed but not archived");
      continue;
    }
    const pb::Measurement& x = *it->second;
    stored.erase(it);
    const std::pair<const char*, std::pair<double, double>> fields[] = {
        {"value", {x.value(), y.value()}},
        {"uncertainty",
         {Opt(x.has_uncertainty(), x.uncertainty()), Opt(y.has_uncertainty(), y.uncertainty())}},
        {"low", {Opt(x.has_low(), x.low()), Opt(y.has_low(), y.low())}},
        {"high", {Opt(x.has_high(), x.high()), Opt(y.has_high(), y.high())}},
        {"marginal_low",
         {Opt(x.has_marginal_low(), x.marginal_low()),
          Opt(y.has_marginal_low(), y.marginal_low())}},
        {"marginal_high",
         {Opt(x.has_marginal_high(), x.marginal_high()),
          Opt(y.has_marginal_high(), y.marginal_high())}},
        {"guard_band",
         {Opt(x.has_guard_band(), x.guard_band()), Opt(y.has_guard_band(), y.guard_band())}}};
    for (const auto& [name, v] : fields) {
      if (!Same(v.first, v.second)) {
        problems->push_back(label(x) + " " + name + ": archived " + Exactly(v.first) +
                            ", recomputed " + Exactly(v.second));
      }
    }
    if (x.outcome() != y.outcome()) {
      problems->push_back(label(x) + " outcome: archived " + Shown(x.outcome()) + ", recomputed " +
                          Shown(y.outcome()));
    }
    if (x.unit() != y.unit()) {
      problems->push_back(label(x) + " unit: archived " + x.unit() + ", recomputed " + y.unit());
    }
    if (x.qualifier() != y.qualifier()) {
      problems->push_back(label(x) + " qualifier: archived " +
                          Named(store::QualifierText(x.qualifier())) + ", recomputed " +
                          Named(store::QualifierText(y.qualifier())));
    }
    if (x.decision_rule() != y.decision_rule()) {
      problems->push_back(label(x) + " decision rule: archived " +
                          Named(store::DecisionRuleText(x.decision_rule())) + ", recomputed " +
                          Named(store::DecisionRuleText(y.decision_rule())));
    }
    if (x.uncertainty_method() != y.uncertainty_method()) {
      problems->push_back(label(x) + " uncertainty method: archived \"" + x.uncertainty_method() +
                          "\", recomputed \"" + y.uncertainty_method() + "\"");
    }
    if (x.note() != y.note()) {
      problems->push_back(label(x) + " note: archived \"" + x.note() + "\", recomputed \"" +
                          y.note() + "\"");
    }
  }
  for (const auto& [key, m] : stored)
    problems->push_back(label(*m) + ": archived but not recomputed");
}

int Live(store::Archive& archive, const ReanalyzeOptions& o, Format format) {
  // Damage at rest is reported, and so is what the re-analysis finds.
  const bool checksums_ok = !o.check || CheckRunChecksums(archive, o.run_id) == 0;
  auto outcome = store::ReanalyzeRun(archive, o.run_id);
  if (!outcome.ok()) {
    LogError(outcome.status().message());
    return outcome.status().code() == Status::Code::kNotFound ? 2 : 1;
  }
  std::vector<LabeledCurve> curves(outcome->curves.begin(), outcome->curves.end());
  if (o.looks && !outcome->early) {
    LogError("run " + o.run_id + ": its plan has no early_decision, so it has no looks");
    return 1;
  }
  if (format == Format::kTable) {
    std::printf("run %s re-analysed as live: verdict %s\n", o.run_id.c_str(),
                Shown(outcome->judgement.verdict).c_str());
    if (o.looks) {
      const analyze::RunOutcome::Early& e = *outcome->early;
      std::printf("early decisions: %s after %d of %d looks%s\n", judge::DecisionName(e.unit),
                  e.looks_done, e.looks_planned,
                  e.unit == judge::Decision::kPending
                      ? " (full-length verdict)"
                      : (" at " + DecisionTimeText(e.decided_at_s)).c_str());
    }
  }
  // A check answers with its result alone (it printed some 390 curve rows
  // before "equals ... bit for bit"); the curves are the answer otherwise.
  if (!o.check || o.looks) {
    std::printf("%s", o.looks ? LooksTable(outcome->early->looks).Render(format).c_str()
                              : CurveTable(curves, true, true, true).Render(format).c_str());
  }
  if (!o.check) return 0;
  // Complete in the archive (a judgement and a final curve of every axis),
  // and bit for bit what the live analysis archived, axis by axis.
  auto key = archive.FindRunKey(o.run_id);
  if (!key.ok() || !key->has_value()) {
    LogError("run " + o.run_id + " is not in the archive");
    return 1;
  }
  auto archived = archive.LoadCurves(**key);
  auto result = archive.LoadResult(**key);
  if (!archived.ok() || !result.ok()) {
    LogError((archived.ok() ? result.status() : archived.status()).message());
    return 1;
  }
  std::vector<std::string> problems;
  if (!result->has_value()) problems.push_back("no judgement archived");
  std::map<std::string, const allan::Curve*> by_axis;
  for (const store::CurveRecord& c : *archived) by_axis.emplace(c.axis, &c.curve);
  for (const auto& [axis, curve] : curves) {
    auto it = by_axis.find(axis);
    if (it == by_axis.end()) {
      problems.push_back("axis " + axis + ": no archived curve");
      continue;
    }
    const allan::Curve& stored = *it->second;
    if (stored.ci != curve.ci) {
      problems.push_back("axis " + axis + ", curve ci_method: archived " +
                         std::string(allan::CiMethodName(stored.ci)) + ", recomputed " +
                         std::string(allan::CiMethodName(curve.ci)));
    }
    if (!Same(stored.tau0_s, curve.tau0_s)) {
      problems.push_back("axis " + axis + ", curve tau0_s: archived " + Exactly(stored.tau0_s) +
                         ", recomputed " + Exactly(curve.tau0_s));
    }
    const auto& x = stored.points;
    const auto& y = curve.points;
    by_axis.erase(it);
    if (x.size() != y.size()) {
      problems.push_back("axis " + axis + ": " + std::to_string(x.size()) + " points archived, " +
                         std::to_string(y.size()) + " re-analysed");
      continue;
    }
    ComparePoints(axis, x, y, &problems);
  }
  for (const auto& [axis, curve] : by_axis) {
    problems.push_back("axis " + axis + ": archived but not an axis of the run");
  }
  if (result->has_value()) CompareJudgements(**result, *outcome, &problems);
  if (!problems.empty()) {
    // One line per difference: axis, quantity, archived, recomputed.
    LogError("run " + o.run_id + " fails the check: " + std::to_string(problems.size()) +
             " difference" + (problems.size() == 1 ? "" : "s"));
    for (const std::string& p : problems) std::fprintf(stderr, "  %s\n", p.c_str());
    return 1;
  }
  if (!checksums_ok) return 1;
  std::fprintf(stderr, "re-analysis equals the archived result bit for bit\n");
  return 0;
}

}  // namespace

int ReanalyzeCommand(const ReanalyzeOptions& o) {
  auto format = ParseFormat(o.format);
  if (!format.ok()) {
    LogError(format.status().message());
    return 2;
  }
  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  return o.exact ? Exact(**archive, o, *format) : Live(**archive, o, *format);
}

}  // namespace imuqual::offline
