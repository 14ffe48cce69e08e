#include "store/cli/reanalyze_command.h"

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "analyze/judge/judge.h"
#include "common/log.h"
#include "store/archive.h"
#include "store/checksums.h"
#include "store/cli/curve_request.h"
#include "store/reanalysis.h"

namespace imuqual::cli {
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
    std::printf("run %s (unit %s, lot %s): %zu samples per axis at %g Hz from device counter %lld%s\n",
                o.run_id.c_str(), run->info.serial.c_str(), run->info.lot.c_str(),
                run->samples[0].size(), run->info.nominal_rate_hz,
                static_cast<long long>(run->first_counter),
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

int Live(store::Archive& archive, const ReanalyzeOptions& o, Format format) {
  // Damage at rest is reported, and so is what the re-analysis finds.
  const bool checksums_ok = !o.check || CheckRunChecksums(archive, o.run_id) == 0;
  auto outcome = store::ReanalyzeRun(archive, o.run_id);
  if (!outcome.ok()) {
    LogError(outcome.status().message());
    return outcome.status().code() == Status::Code::kNotFound ? 2 : 1;
  }
  std::vector<LabeledCurve> curves(outcome->curves.begin(), outcome->curves.end());
  if (format == Format::kTable) {
    std::printf("run %s re-analysed as live: verdict %s\n", o.run_id.c_str(),
                judge::OutcomeName(outcome->judgement.verdict));
  }
  std::printf("%s", CurveTable(curves, true, true, true).Render(format).c_str());
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
    const auto& x = it->second->points;
    const auto& y = curve.points;
    by_axis.erase(it);
    if (x.size() != y.size()) {
      problems.push_back("axis " + axis + ": " + std::to_string(x.size()) + " points archived, " +
                         std::to_string(y.size()) + " re-analysed");
      continue;
    }
    size_t differ = 0;
    for (size_t p = 0; p < x.size(); ++p) {
      if (x[p].m != y[p].m || x[p].dev != y[p].dev || x[p].n != y[p].n) ++differ;
    }
    if (differ > 0) {
      problems.push_back("axis " + axis + ": " + std::to_string(differ) + " of " +
                         std::to_string(x.size()) + " points differ");
    }
  }
  for (const auto& [axis, curve] : by_axis) {
    problems.push_back("axis " + axis + ": archived but not an axis of the run");
  }
  if (!problems.empty()) {
    std::string what;
    for (const std::string& p : problems) what += (what.empty() ? "" : "; ") + p;
    LogError("run " + o.run_id + " fails the check: " + what);
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
    return 1;
  }
  return o.exact ? Exact(**archive, o, *format) : Live(**archive, o, *format);
}

}  // namespace imuqual::cli
