#include "store/cli/reanalyze_command.h"

#include <cstdio>

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
  if (o.check && CheckRunChecksums(archive, o.run_id) != 0) return 1;
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
  // Bit for bit against what the live analysis archived.
  auto archived = archive.LoadCurves(**archive.FindRunKey(o.run_id));
  if (!archived.ok()) {
    LogError(archived.status().message());
    return 1;
  }
  size_t differences = archived->size() == curves.size() ? 0 : 1;
  for (size_t i = 0; differences == 0 && i < curves.size(); ++i) {
    const auto& x = (*archived)[i].curve.points;
    const auto& y = curves[i].second.points;
    if ((*archived)[i].axis != curves[i].first || x.size() != y.size()) {
      ++differences;
      continue;
    }
    for (size_t p = 0; p < x.size(); ++p) {
      if (x[p].m != y[p].m || x[p].dev != y[p].dev || x[p].n != y[p].n) ++differences;
    }
  }
  if (differences > 0) {
    LogError("re-analysis differs from the archived result of " + o.run_id + " (" +
             std::to_string(differences) + " differences)");
    return 1;
  }
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
