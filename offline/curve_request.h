// The curves a user asks for (estimators, tau grid, stop rule, confidence
// intervals), computed exactly from a phase record, and their table. Shared
// by `imuqual analyze FILE` and `imuqual reanalyze RUN --exact`.
#ifndef IMUQUAL_OFFLINE_CURVE_REQUEST_H_
#define IMUQUAL_OFFLINE_CURVE_REQUEST_H_

#include <string>
#include <utility>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"
#include "common/status.h"
#include "report/table_writer.h"

namespace imuqual::offline {

struct CurveRequest {
  std::vector<allan::Deviation> devs;
  allan::TauGridSpec grid;
  allan::StopRule stop = allan::StopRule::kBins9;
  allan::CiMethod ci = allan::CiMethod::kNone;
  double confidence = 0.682689492137086;
};

// From command-line words: "oadev,mdev", "octave", "bins9", "chi2", 0.68.
// Errors name the flag.
Result<CurveRequest> ParseCurveRequest(const std::string& devs, const std::string& grid,
                                       const std::string& stop, const std::string& ci,
                                       double confidence);

// Exact curves, one per requested estimator.
std::vector<allan::Curve> ComputeCurves(const allan::PhaseRecord& phase,
                                        const CurveRequest& request);

// A curve with the axis it belongs to ("" when there is only one series).
using LabeledCurve = std::pair<std::string, allan::Curve>;

// Columns [axis,] [dev_type,] m, tau, n, dev [, lo, hi, edf, alpha].
report::TableWriter CurveTable(const std::vector<LabeledCurve>& curves, bool with_ci,
                               bool with_dev_type, bool with_axis);

}  // namespace imuqual::offline

#endif  // IMUQUAL_OFFLINE_CURVE_REQUEST_H_
