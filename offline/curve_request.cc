#include "offline/curve_request.h"

#include <cmath>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "common/strings.h"

namespace imuqual::offline {
using report::Cell;
using report::TableWriter;

Result<CurveRequest> ParseCurveRequest(const std::string& devs, const std::string& grid,
                                       const std::string& stop, const std::string& ci,
                                       double confidence) {
  CurveRequest r;
  for (const std::string& name : Split(devs, ',')) {
    auto d = allan::ParseDeviation(name);
    if (!d) {
      return Status::InvalidArgument(
          "--dev: unknown estimator '" + name +
          "' (adev, oadev, mdev, tdev, hdev, ohdev, totdev, theo1, theobr, theoh, mtotdev, "
          "ttotdev, htotdev)");
    }
    r.devs.push_back(*d);
  }
  auto g = allan::ParseTauGrid(grid);
  if (!g.ok()) return g.status().WithContext("--grid");
  r.grid = *g;
  auto s = allan::ParseStopRule(stop);
  if (!s) return Status::InvalidArgument("--stop must be bins9, stable32 or none");
  r.stop = *s;
  auto c = allan::ParseCiMethod(ci);
  if (!c) return Status::InvalidArgument("--ci must be none, simple or chi2");
  r.ci = *c;
  if (!(confidence > 0 && confidence < 1)) {
    return Status::InvalidArgument("--confidence must be in (0, 1)");
  }
  r.confidence = confidence;
  return r;
}

std::vector<allan::Curve> ComputeCurves(const allan::PhaseRecord& phase,
                                        const CurveRequest& request) {
  std::vector<allan::Curve> curves;
  for (allan::Deviation dev : request.devs) {
    const std::vector<int64_t> m =
        allan::AveragingFactors(request.grid, phase.tau0_s, phase.size(), dev, request.stop);
    allan::Curve curve = allan::ComputeDeviation(phase, dev, m);
    if (request.ci != allan::CiMethod::kNone) {
      allan::AttachConfidence(phase, request.ci, request.confidence, &curve);
    }
    curves.push_back(std::move(curve));
  }
  return curves;
}

TableWriter CurveTable(const std::vector<LabeledCurve>& curves, bool with_ci, bool with_dev_type,
                       bool with_axis) {
  std::vector<std::string> cols;
  if (with_axis) cols.push_back("axis");
  if (with_dev_type) cols.push_back("dev_type");
  for (const char* c : {"m", "tau", "n", "dev"}) cols.push_back(c);
  if (with_ci) {
    for (const char* c : {"lo", "hi", "edf", "alpha", "alpha_from"}) cols.push_back(c);
  }
  TableWriter t(cols, 6);
  for (const auto& [axis, c] : curves) {
    for (const allan::CurvePoint& p : c.points) {
      std::vector<Cell> row;
      if (with_axis) row.push_back(Cell::Text(axis));
      if (with_dev_type) row.push_back(Cell::Text(std::string(allan::DeviationName(c.deviation))));
      row.push_back(Cell::Int(p.m));
      row.push_back(Cell::Real(p.tau_s));
      row.push_back(Cell::Int(p.n));
      row.push_back(Cell::Real(p.dev));
      if (with_ci) {
        row.push_back(Cell::Real(p.lo));
        row.push_back(Cell::Real(p.hi));
        row.push_back(Cell::Real(p.edf));
        row.push_back(p.alpha ? Cell::Int(*p.alpha) : Cell::Text(""));
        // "identified" at this point, or "nearest" identified point's (the
        // long-tau rule, confidence.h).
        row.push_back(Cell::Text(!p.alpha ? "" : p.alpha_inherited ? "nearest" : "identified"));
      }
      t.AddRow(std::move(row));
    }
  }
  return t;
}

}  // namespace imuqual::offline
