// Draws a composite noise model (analyze/allan/composite_model.h) on a
// log-log plot: the model dashed in dark grey and each of its terms dashed
// and faint, over [tau_lo, tau_hi]. An inadequate model is labelled so.
#ifndef IMUQUAL_REPORT_MODEL_PLOT_H_
#define IMUQUAL_REPORT_MODEL_PLOT_H_

#include "analyze/allan/composite_model.h"
#include "report/svg_plot.h"

namespace imuqual::report {

void AddModelSeries(const allan::CompositeModel& model, double tau0_s, double tau_lo, double tau_hi,
                    bool adequate, LogLogPlot* plot);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_MODEL_PLOT_H_
