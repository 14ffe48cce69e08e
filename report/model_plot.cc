#include "report/model_plot.h"

#include <cmath>
#include <string>

namespace imuqual::report {

void AddModelSeries(const allan::CompositeModel& model, double tau0_s, double tau_lo, double tau_hi,
                    bool adequate, LogLogPlot* plot) {
  if (model.terms.empty() || !(tau_lo > 0) || !(tau_hi > tau_lo) || !(tau0_s > 0)) return;
  constexpr int kSteps = 160;
  auto series = [&](const allan::CompositeModel& m, std::string label, std::string color,
                    double width, double opacity, bool in_legend, bool sets_range) {
    PlotSeries s;
    s.sets_range = sets_range;
    s.label = std::move(label);
    s.color = std::move(color);
    s.markers = false;
    s.dashed = true;
    s.stroke_width = width;
    s.opacity = opacity;
    s.in_legend = in_legend;
    for (int i = 0; i <= kSteps; ++i) {
      const double tau = tau_lo * std::pow(tau_hi / tau_lo, static_cast<double>(i) / kSteps);
      s.x.push_back(tau);
      s.y.push_back(m.Deviation(tau / tau0_s, tau0_s));
    }
    plot->series.push_back(std::move(s));
  };
  series(model, "model " + model.Name() + (adequate ? "" : " (inadequate)"), "#444444", 1.6, 1.0,
         true, true);
  if (model.terms.size() < 2) return;
  for (size_t i = 0; i < model.terms.size(); ++i) {
    allan::CompositeModel one;
    one.terms.push_back(model.terms[i]);
    // A term alone (a sinusoid, a fast Gauss-Markov part) can lie decades
    // below the data: drawn where it is in the data's range, never widening it.
    series(one, std::string(allan::TermKindSymbol(model.terms[i].kind)), "#999999", 1.0, 0.6,
           i == 0, false);
  }
  plot->series[plot->series.size() - model.terms.size()].label = "model terms";
}

}  // namespace imuqual::report
