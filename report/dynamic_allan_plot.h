// The dynamic Allan deviation as a plot a line reads at a glance: one Allan
// curve per window of the record (allan/dynamic_allan.h), early windows blue,
// late ones red, on the log-log axes of the Allan plots. A stationary record
// draws one bundle of curves as wide as their intervals; a window that holds
// a bias step, a ramp or a burst stands out above the bundle at the taus the
// event spans, and its tooltip names the window. Self-contained SVG.
#ifndef IMUQUAL_REPORT_DYNAMIC_ALLAN_PLOT_H_
#define IMUQUAL_REPORT_DYNAMIC_ALLAN_PLOT_H_

#include <string>

#include "analyze/allan/dynamic_allan.h"
#include "common/status.h"
#include "store/archive.h"

namespace imuqual::report {

struct DynamicAllanPlotStyle {
  std::string title;
  // Left axis: the deviation times y_scale under y_label (e.g. 3600 and
  // "deg/h" for deg/s data); y2_label, when set, names the data's own unit
  // on a right axis.
  double y_scale = 1;
  std::string y_label = "Allan deviation";
  std::string y2_label;
};

// The plot of `davar` (at least one window).
std::string DynamicAllanSvg(const allan::DynamicAllan& davar, const DynamicAllanPlotStyle& style);

// Per axis of a stored run, the dynamic Allan deviation of its record after
// the plan's warm-up (to the last archived sample, also past an early
// decision; missing, invalid and out-of-range samples are gaps), in
// datasheet units; one axis in memory at a time. NotFound names the run or
// says it has no archived sample; InvalidArgument when the record is too
// short for windows of 64 samples, or too long to hold in memory here (more
// than 2^24 samples per axis: `imuqual export --format samples` and
// `imuqual analyze --davar` take it).
Result<std::vector<std::string>> RunDynamicAllanSvgs(store::Archive& archive,
                                                     const std::string& run_id);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_DYNAMIC_ALLAN_PLOT_H_
