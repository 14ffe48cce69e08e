// Allan deviation plots from the archive as self-contained SVG, for one run
// or overlaid for a lot: what `imuqual plot` writes and the HTML lot report
// shows.
//
// What a plot shows (log-log, tau in s; the deviation in datasheet units,
// deg/h for gyros and ug for accelerometers, on the left axis, and in the
// curve's own unit, deg/s or m/s^2, on the right):
//  - the measured overlapping Allan deviation with its confidence band (the
//    interval stored with the curve, at its level and method);
//  - the fitted IEEE 952 model (run plots), dashed, from the run's stored
//    fit_* measurements converted back to base units:
//      sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2;
//  - the bias-instability point (the curve minimum, as measured), ringed;
//  - the plan's limit lines on levels of the curve: bias_instability (the
//    curve minimum) horizontal at limit/3600 deg/s or limit x 9.80665e-6
//    m/s^2; bias_instability_ieee and fit_bias_instability at 0.664 x that;
//    angle/velocity random walk as the -1/2 line sigma = N/sqrt(tau), rate
//    random walk as the +1/2 line sigma = K sqrt(tau/3) (where IEEE 952 reads
//    them off); the other fitted terms as their model term alone
//    (sqrt(3) Q/tau, R tau/sqrt(2)). Red: the limit, amber: the marginal
//    band's edge. Limits on other measurements (tau_at_minimum, bias_offset,
//    gaps, ...) are not levels of the curve and are not drawn.
#ifndef IMUQUAL_REPORT_ALLAN_PLOTS_H_
#define IMUQUAL_REPORT_ALLAN_PLOTS_H_

#include <optional>
#include <string>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/allan/curve.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"
#include "store/archive.h"

namespace imuqual::report {

// One axis of a run as the plots need it.
struct AxisPlotData {
  std::string axis;
  pb::AxisKind kind = pb::GYRO;
  std::optional<allan::Curve> curve;          // the oadev curve (else the first stored)
  std::vector<pb::Measurement> measurements;  // the axis's stored measurements
  std::string verdict;  // worst outcome of those: "FAIL", "MARGINAL", "PASS", "" (none judged)
};

// The axis's noise model, rebuilt from the stored model_* parameters
// (judge/measure.h), and whether it passed its J test. nullopt without a
// model or when a stored parameter does not make one (the model would be
// wrong).
struct ArchivedModel {
  allan::CompositeModel model;
  bool adequate = true;
};
std::optional<ArchivedModel> LoadArchivedModel(const AxisPlotData& a);

// A run with its plan, verdict and per-axis curves and measurements.
struct RunPlotData {
  store::RunInfo info;
  pb::TestPlan plan;    // empty if the stored plan does not parse
  std::string verdict;  // the run's verdict, "" if not judged
  std::vector<std::string> reasons;
  std::vector<AxisPlotData> axes;  // in the run's axis order
};

// Reads one run. NotFound names the run and the archive.
Result<RunPlotData> LoadRunPlotData(store::Archive& archive, const std::string& run_id);
// The same from a run's records already read (store::Archive::LoadLotRuns).
RunPlotData MakeRunPlotData(store::RunInfo info, const std::optional<store::ResultRecord>& result,
                            const std::vector<store::CurveRecord>& curves);

struct AllanPlot {
  std::string key;    // "gyro"/"accel" (run plots) or the axis name (lot plots)
  std::string title;  // what the plot shows, plain text
  std::string svg;    // a complete <svg> element
};

// The plots of one run (see PlotCommand), or only `axis` if not "".
// Empty when the run has no such axis.
std::vector<AllanPlot> RunAllanPlots(const RunPlotData& run, const std::string& axis);

// The lot overlays of `runs` (one run per unit), one per axis name, or only
// `axis` if not "". Empty when no run has such an axis.
std::vector<AllanPlot> LotAllanPlots(const std::string& lot, const std::vector<RunPlotData>& runs,
                                     const std::string& axis);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_ALLAN_PLOTS_H_
