#include "offline/analyze_command.h"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/dynamic_allan.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/model_quantities.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/stationarity.h"
#include "analyze/allan/tau_grid.h"
#include "analyze/allan/units.h"
#include "analyze/judge/plan_file.h"
#include "analyze/judge/stationarity_measure.h"
#include "common/log.h"
#include "common/numeric_text.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "offline/curve_request.h"
#include "report/dynamic_allan_plot.h"
#include "report/marks.h"
#include "report/model_plot.h"
#include "report/svg_plot.h"
#include "report/table_writer.h"

namespace imuqual::offline {
using report::AddModelSeries;
using report::Cell;
using report::Format;
using report::JsonString;
using report::LogLogPlot;
using report::PaletteColor;
using report::ParseFormat;
using report::PlotSeries;
using report::TableWriter;

namespace {

using allan::Curve;
using allan::Deviation;
using allan::NoiseTerm;

struct Parsed {
  CurveRequest curves;
  Format format;
  std::optional<allan::SensorKind> kind;
  double factor = 1.0;  // values to the base unit: scale x unit
};

Result<Parsed> ParseOptions(const AnalyzeFileOptions& o) {
  Parsed p;
  auto request = ParseCurveRequest(o.devs, o.grid, o.stop, o.ci, o.confidence);
  if (!request.ok()) return request.status();
  p.curves = *request;
  auto format = ParseFormat(o.format);
  if (!format.ok()) return format.status();
  p.format = *format;
  if (o.kind == "gyro") {
    p.kind = allan::SensorKind::kGyro;
  } else if (o.kind == "accel") {
    p.kind = allan::SensorKind::kAccelerometer;
  } else if (!o.kind.empty()) {
    return Status::InvalidArgument("--kind must be gyro or accel");
  }
  if (!o.rate_given) {
    return Status::InvalidArgument(
        "--rate is required: the series' sample rate in Hz (e.g. --rate 100); analyze does not "
        "assume one (every tau would be off by it)");
  }
  if (!(o.rate_hz > 0) || !std::isfinite(o.rate_hz)) {
    return Status::InvalidArgument("--rate must be a positive rate in Hz");
  }
  if (!(o.fit_min_tau_s >= 0 && o.fit_min_tau_s <= 1)) {
    return Status::InvalidArgument(
        "--fit-min-tau must be in [0, 1] s (the figures are read at 1 s)");
  }
  if (o.fit_min_tau_s > 0 && !o.fit) {
    return Status::InvalidArgument("--fit-min-tau needs --fit");
  }
  if (o.long_tau_check && !o.fit) {
    return Status::InvalidArgument("--long-tau-check needs --fit");
  }
  if (o.fit_long_taus && !o.fit) {
    return Status::InvalidArgument("--fit-long-taus needs --fit");
  }
  if (o.fit_long_taus && o.long_tau_check) {
    return Status::InvalidArgument(
        "--long-tau-check tests a model fitted without the long taus; with --fit-long-taus the "
        "Theo1 points are in the fit (its long-tau moments table shows them against the model)");
  }
  if (!(o.davar_window_s >= 0) || !std::isfinite(o.davar_window_s)) {
    return Status::InvalidArgument("--davar-window must be >= 0 s (0: a quarter of the record)");
  }
  if (o.davar_window_s > 0 && o.davar_path.empty()) {
    return Status::InvalidArgument("--davar-window needs --davar FILE.svg");
  }
  if (!o.davar_path.empty() && o.type != "rate") {
    return Status::InvalidArgument("--davar needs --type rate");
  }
  if (o.stationarity_level != 0) {
    if (!(o.stationarity_level > 0 && o.stationarity_level < 0.5)) {
      return Status::InvalidArgument(
          "--stationarity must be a false-alarm level in (0, 0.5), e.g. 0.01");
    }
    if (o.type != "rate") return Status::InvalidArgument("--stationarity needs --type rate");
  }
  if (o.judge_longest_segment && o.stationarity_level == 0) {
    return Status::InvalidArgument(
        "--judge-longest-segment needs --stationarity LEVEL (the scan finds what cuts the record)");
  }
  if (!o.stationarity_plan.empty()) {
    if (o.stationarity_level == 0) {
      return Status::InvalidArgument("--stationarity-plan needs --stationarity LEVEL");
    }
    if (o.kind.empty()) {
      return Status::InvalidArgument(
          "--stationarity-plan needs --kind gyro or accel (the plan's reference model of that "
          "kind, in base units)");
    }
  }
  if (!std::isfinite(o.scale) || o.scale == 0) {
    return Status::InvalidArgument("--scale must be a finite, non-zero number");
  }
  p.factor = o.scale;
  if (!o.unit.empty()) {
    if (!p.kind) {
      return Status::InvalidArgument("--unit " + o.unit + ": give --kind gyro or accel too");
    }
    const double to_base = allan::OutputUnitToBase(o.unit, *p.kind);
    if (!std::isfinite(to_base)) {
      return Status::InvalidArgument(
          "--unit " + o.unit + " is not a unit for " +
          (*p.kind == allan::SensorKind::kGyro ? "a gyro" : "an accelerometer") + " (" +
          std::string(allan::OutputUnitNames(*p.kind)) + ")");
    }
    p.factor *= to_base;
  }
  if (o.type != "rate" && o.type != "phase") {
    return Status::InvalidArgument("--type must be rate or phase");
  }
  return p;
}

std::vector<LabeledCurve> Unlabeled(const std::vector<Curve>& curves) {
  std::vector<LabeledCurve> out;
  for (const Curve& c : curves) out.emplace_back("", c);
  return out;
}

// Datasheet units when the sensor kind is known, else the input's base units.
std::pair<double, std::string> Present(NoiseTerm term, const std::optional<allan::SensorKind>& kind,
                                       double base) {
  if (kind) {
    const allan::DatasheetValue v = allan::ToDatasheetUnits(term, *kind, base);
    return {v.value, std::string(v.unit)};
  }
  static const char* kBase[] = {"u*s", "u*sqrt(s)", "u", "u/sqrt(s)", "u/s"};
  return {base, kBase[static_cast<int>(term)]};
}

// The slope-line (or curve-minimum) read-off that stands beside a model
// figure, and its 1-sigma uncertainty where it has one (N's line fit, the
// minimum's chi-square error; NaN otherwise).
std::pair<double, double> ReadOff(const std::string& name, const Curve& curve,
                                  const std::optional<allan::SensorKind>& kind) {
  auto present = [&](NoiseTerm term, double base) { return Present(term, kind, base).first; };
  const std::optional<allan::CurveMinimum> min = allan::FindCurveMinimum(curve);
  if (name == "angle_random_walk" || name == "velocity_random_walk") {
    const allan::SlopeReadoff n = allan::ReadSlopeLine(curve, NoiseTerm::kAngleRandomWalk);
    return {present(NoiseTerm::kAngleRandomWalk, n.value),
            present(NoiseTerm::kAngleRandomWalk, n.uncertainty)};
  }
  if (name == "rate_random_walk") {
    return {present(NoiseTerm::kRateRandomWalk,
                    allan::ReadSlopeLine(curve, NoiseTerm::kRateRandomWalk).value),
            allan::kNaN};
  }
  if (!min) return {allan::kNaN, allan::kNaN};
  const double u_min = allan::MinimumUncertainty(curve, *min);
  if (name == "bias_instability") {
    return {present(NoiseTerm::kBiasInstability, min->dev),
            present(NoiseTerm::kBiasInstability, u_min)};
  }
  if (name == "bias_instability_ieee") {
    return {present(NoiseTerm::kBiasInstability, min->bias_instability_ieee),
            present(NoiseTerm::kBiasInstability, u_min / allan::kBiasInstabilityFactor)};
  }
  if (name == "tau_at_minimum") {
    // Its u as the station's (none where the minimum is the longest tau).
    const allan::MinimumTauSpread spread = allan::MinimumTauSelectionSpread(curve, *min);
    return {min->tau_s, spread.resolved ? min->tau_s * spread.u_ln_tau : allan::kNaN};
  }
  return {allan::kNaN, allan::kNaN};
}

// The fit's quantities; `for_people` (the table format) quotes a value with
// its sigma as a measurement is (u to two significant digits, the value to
// u's last digit: "0.2832 ± 0.0011"), CSV and JSON carry every digit.
TableWriter QuantityTable(const allan::CompositeFit& fit, const Curve& curve,
                          const std::optional<allan::SensorKind>& kind, bool for_people = false) {
  TableWriter t({"term", "value", "sigma", "unit", "read_off", "read_off_u", "role", "note"}, 5);
  for (const allan::ModelQuantity& q : allan::DescribeCompositeFit(fit, kind)) {
    Cell value = Cell::Real(q.value), sigma = Cell::Real(q.sigma);
    if (for_people && std::isfinite(q.value) && std::isfinite(q.sigma) && q.sigma > 0) {
      const auto [v, u] = report::QuotedWithUncertainty(q.value, q.sigma);
      value = Cell::NumText(v);
      sigma = Cell::NumText(u);
    }
    const auto [read_off, read_off_u] =
        q.figure ? ReadOff(q.name, curve, kind) : std::pair{allan::kNaN, allan::kNaN};
    Cell read_off_cell = Cell::Real(read_off), read_off_u_cell = Cell::Real(read_off_u);
    if (for_people && std::isfinite(read_off) && std::isfinite(read_off_u) && read_off_u > 0) {
      const auto [v, u] = report::QuotedWithUncertainty(read_off, read_off_u);
      read_off_cell = Cell::NumText(v);
      read_off_u_cell = Cell::NumText(u);
    }
    t.AddRow({Cell::Text(q.name), value, sigma, Cell::Text(q.unit), read_off_cell, read_off_u_cell,
              Cell::Text(q.figure ? "figure" : "parameter"), Cell::Text(q.note)});
  }
  return t;
}

TableWriter CandidateTable(const allan::CompositeFit& fit) {
  TableWriter t({"model", "parameters", "objective", "criterion", "p_value", "weight"}, 5);
  for (const allan::ModelCandidate& c : fit.candidates) {
    t.AddRow({Cell::Text(c.name), Cell::Int(c.parameters), Cell::Real(c.objective),
              Cell::Real(c.criterion), Cell::Real(c.p_value), Cell::Real(c.weight)});
  }
  return t;
}

// The model at every tau of the curve (analysed or not), for comparison
// point by point with the measured deviation and its interval.
TableWriter ModelCurveTable(const allan::CompositeFit& fit, const Curve& curve) {
  TableWriter t({"tau", "dev"}, 6);
  for (const allan::CurvePoint& p : curve.points) {
    t.AddRow({Cell::Real(p.tau_s), Cell::Real(fit.ModelDeviation(p.tau_s))});
  }
  return t;
}

// Theo1 beyond the fitted curve against the model (CompositeModel::
// ExpectedTheo1): at even m from twice the fit curve's last effective tau, by
// octaves, to the record's reach (m <= N - 1). Under the model Theo1^2 /
// E[Theo1] ~ chi2(edf) / edf, edf allan::Theo1MomentEdf (the model's noise
// there, as the fit weighs its own Theo1 moments).
struct LongTauCheck {
  double tau_s = 0;  // 0.75 m tau0
  int64_t m = 0;
  double measured = 0, expected = 0;  // deviations, base units
  double edf = 0;                     // NaN when Theo1 has none there
  double lo = 0, hi = 0;              // 95 % range of measured / expected
  double Ratio() const { return measured / expected; }
  bool Inside() const { return std::isfinite(edf) && Ratio() >= lo && Ratio() <= hi; }
};

// The unit the check's deviations are shown in: --kind's datasheet unit of
// bias instability, else the input's (`unnamed` names it).
allan::DatasheetValue LongTauUnit(const std::optional<allan::SensorKind>& kind,
                                  std::string_view unnamed) {
  return kind ? allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, *kind, 1.0)
              : allan::DatasheetValue{1.0, unnamed};
}

// A row with the 95 % chi-square range of measured / expected for `edf`
// (NaN: none).
LongTauCheck LongTauRow(double tau_s, int64_t m, double measured, double expected, double edf) {
  LongTauCheck c;
  c.tau_s = tau_s;
  c.m = m;
  c.measured = measured;
  c.expected = expected;
  c.edf = edf;
  if (std::isfinite(edf) && edf > 0) {
    const boost::math::chi_squared chi2(edf);
    c.lo = std::sqrt(boost::math::quantile(chi2, 0.025) / edf);
    c.hi = std::sqrt(boost::math::quantile(chi2, 0.975) / edf);
  }
  return c;
}

std::vector<LongTauCheck> CheckLongTau(const allan::PhaseRecord& phase,
                                       const allan::CompositeFit& fit, const Curve& fit_curve) {
  std::vector<LongTauCheck> out;
  if (fit_curve.points.empty()) return out;
  const double tau0 = phase.tau0_s;
  const int64_t n = phase.size();
  const std::vector<int64_t> m_list =
      allan::Theo1OctavesBeyond(fit_curve.points.back().tau_s, tau0, n);
  const Curve theo1 = allan::ComputeDeviation(phase, Deviation::kTheo1, m_list);
  for (const allan::CurvePoint& p : theo1.points) {
    const double r = 0.75 * static_cast<double>(p.m);
    out.push_back(LongTauRow(r * tau0, p.m, p.dev, std::sqrt(fit.model.ExpectedTheo1(p.m, tau0)),
                             allan::Theo1MomentEdf(fit.model, tau0, p.m, n).value_or(allan::kNaN)));
  }
  return out;
}

// The Theo1 moments a fit made with --fit-long-taus weighed, as the check's
// rows (in sample: the model was fitted to them).
std::vector<LongTauCheck> FitLongTauRows(const allan::CompositeFit& fit) {
  std::vector<LongTauCheck> out;
  for (const allan::GmwmPoint& p : fit.points) {
    if (p.theo1) {
      out.push_back(LongTauRow(p.tau_s, p.m, std::sqrt(p.avar), std::sqrt(p.model_avar), p.edf));
    }
  }
  return out;
}

// `in_fit`: the rows are the fit's own Theo1 moments (FitLongTauRows).
std::string LongTauCheckText(const std::vector<LongTauCheck>& rows,
                             const std::optional<allan::SensorKind>& kind, bool in_fit) {
  const allan::DatasheetValue unit = LongTauUnit(kind, "(input unit)");
  std::string out =
      in_fit ? "long-tau moments in the fit: Theo1 beyond the Allan range against the fitted "
               "model's expectation of it (Howe & Tasset's bias included; 95 % chi-square range "
               "for Theo1's edf at the model's slope)\n"
             : "long-tau check: Theo1 beyond the fitted taus against the model's expectation of it "
               "(Howe & Tasset's bias included; 95 % chi-square range for Theo1's edf at the "
               "model's slope)\n";
  if (rows.empty()) {
    return out + "  none: the record reaches no octave beyond the Allan range's last tau\n";
  }
  auto g = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return std::string(b);
  };
  int outside = 0;
  for (const LongTauCheck& c : rows) {
    const bool known = std::isfinite(c.edf);
    outside += known && !c.Inside();
    const std::string range = g(c.lo) + "-" + g(c.hi) + " (edf " + g(c.edf) + ")";
    const std::string verdict = !known       ? "no edf for the model's slope there"
                                : c.Inside() ? "inside " + range
                                             : "OUTSIDE " + range + ": the model does not hold there";
    char line[160];
    std::snprintf(line, sizeof line,
                  "  tau %-9.4g m %-8lld Theo1 %-10.4g model %-10.4g %s ratio %.3f  ", c.tau_s,
                  static_cast<long long>(c.m), c.measured * unit.value, c.expected * unit.value,
                  std::string(unit.unit).c_str(), c.Ratio());
    out += line + verdict + "\n";
  }
  if (outside > 0 && in_fit) {
    out += "  " + std::to_string(outside) +
           " point(s) outside: the model misses the record there even with these points in its "
           "fit; the points are correlated, read them together\n";
  } else if (outside > 0) {
    out += "  " + std::to_string(outside) +
           " point(s) outside: the model extrapolates wrongly beyond the fitted taus (a term the "
           "fitted range cannot see, e.g. a rate random walk whose minimum lies beyond T/9); the "
           "points are correlated, read them together\n";
  }
  return out;
}

std::string FitSummary(const allan::CompositeFit& fit, double min_tau_s) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "noise model %s (GMWM, %d points, %d parameters): J = %.4g on %d dof, p = %.3g: %s",
                fit.model.Name().c_str(), fit.points_used, fit.parameters, fit.objective, fit.dof,
                fit.p_value, fit.adequate ? "adequate" : "INADEQUATE (the model does not fit)");
  std::string out = buf;
  if (!fit.points.empty()) {
    std::snprintf(buf, sizeof buf, "\n  fitted over tau %g ... %g s", fit.points.front().tau_s,
                  fit.points.back().tau_s);
    out += buf;
    if (min_tau_s > 0) out += " (--fit-min-tau: the shorter taus are left to the sensor's filter)";
  }
  if (!fit.adequate) out += "\n  largest misfits: " + allan::LargestResiduals(fit);
  return out;
}

// A JSON number, null when not finite (JSON has no NaN).
std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  return ShortestReal(v);
}

std::string FitJson(const allan::CompositeFit& fit, const Curve& curve,
                    const std::optional<allan::SensorKind>& kind) {
  return "{\"model\": \"" + fit.model.Name() +
         "\", \"adequate\": " + (fit.adequate ? "true" : "false") +
         ", \"p_value\": " + JsonNumber(fit.p_value) +
         ", \"objective\": " + JsonNumber(fit.objective) + ", \"dof\": " + std::to_string(fit.dof) +
         ", \"parameters\": " + std::to_string(fit.parameters) +
         (fit.points.empty() ? std::string()
                             : ", \"fitted_tau_s\": [" + JsonNumber(fit.points.front().tau_s) +
                                   ", " + JsonNumber(fit.points.back().tau_s) + "]") +
         ", \"criterion\": \"AICc, 3.84 per one-parameter term\", \"criterion_value\": " +
         JsonNumber(fit.criterion) +
         ",\n\"terms\": " + QuantityTable(fit, curve, kind).Render(Format::kJson) +
         ",\n\"curve\": " + ModelCurveTable(fit, curve).Render(Format::kJson) +
         ",\n\"candidates\": " + CandidateTable(fit).Render(Format::kJson) + "}";
}

// "adis.csv, column ax_g (accel, g), 100 Hz": what the plot is of.
std::string PlotTitle(const AnalyzeFileOptions& o) {
  std::string title = o.path.substr(o.path.find_last_of('/') + 1);
  if (!o.column.empty()) title += ", column " + o.column;
  if (!o.kind.empty()) title += " (" + o.kind + (o.unit.empty() ? "" : ", " + o.unit) + ")";
  char rate[32];
  std::snprintf(rate, sizeof rate, ", %g Hz", o.rate_hz);
  return title + rate;
}

std::string PlotCurves(const std::vector<Curve>& curves, const allan::CompositeFit* fit,
                       const Curve* fit_curve, const std::string& title,
                       const std::optional<allan::SensorKind>& kind, bool phase) {
  LogLogPlot plot;
  plot.title = title;
  if (kind) {  // datasheet units on the left, the base unit on the right
    const bool gyro = *kind == allan::SensorKind::kGyro;
    plot.y_scale = allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, *kind, 1.0).value;
    plot.y_label =
        "deviation [" +
        std::string(allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, *kind, 1.0).unit) + "]";
    plot.y2_label = gyro ? "[deg/s]" : "[m/s^2]";
  } else {
    plot.y_label = phase ? "deviation [fractional frequency, phase in s]"
                         : "deviation [the input's unit x --scale]";
  }
  for (size_t i = 0; i < curves.size(); ++i) {
    PlotSeries s;
    s.label = std::string(allan::DeviationName(curves[i].deviation));
    s.color = PaletteColor(i);
    for (const allan::CurvePoint& p : curves[i].points) {
      s.x.push_back(p.tau_s);
      s.y.push_back(p.dev);
      s.lo.push_back(p.lo);
      s.hi.push_back(p.hi);
    }
    if (curves[i].ci == allan::CiMethod::kNone) {
      s.lo.clear();
      s.hi.clear();
    }
    plot.series.push_back(std::move(s));
  }
  if (fit != nullptr && fit_curve != nullptr && !fit_curve->points.empty()) {
    AddModelSeries(fit->model, fit->tau0_s, fit_curve->points.front().tau_s,
                   fit_curve->points.back().tau_s, fit->adequate, &plot);
    if (auto min = allan::FindCurveMinimum(*fit_curve)) {
      // In the left axis's unit (the datasheet's, with --kind).
      char label[96];
      const std::string unit =
          kind ? " " + std::string(allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, *kind, 1.0)
                                       .unit)
               : "";
      const bool last = min->m == fit_curve->points.back().m;
      std::snprintf(label, sizeof label, "minimum %.4g%s at %.4g s%s", min->dev * plot.y_scale,
                    unit.c_str(), min->tau_s, last ? " (last point: not resolved)" : "");
      plot.markers.push_back({label, min->tau_s, min->dev, "#d62728"});
    }
  }
  return plot.ToSvg();
}

}  // namespace

// What the scan looked for and at which level, or why it could not.
std::string StationaritySummary(const allan::StationarityScan& scan,
                                const std::string& reference_source) {
  if (!scan.scanned) return "stationarity: not scanned: " + scan.note + "\n";
  const std::string model = scan.models.empty() ? "?" : scan.models.front();
  const std::string against = reference_source.empty()
                                  ? model + " (the adequate candidate with the most wander)"
                                  : model + " (the plan's reference: " + reference_source + ")";
  char text[768];
  std::snprintf(
      text, sizeof text,
      "stationarity: level steps and bursts in %d bins of %.4g s against the noise model\n"
      "%s, false-alarm level %.3g per\n"
      "record (calibrated on records drawn from that model), %d scan%s: %s\n",
      scan.bins, scan.bin_s, against.c_str(), scan.false_alarm, scan.passes,
      scan.passes == 1 ? "" : "s",
      scan.events.empty()
          ? "no event found"
          : (std::to_string(scan.events.size()) + (scan.events.size() == 1 ? " event" : " events"))
                .c_str());
  return text;
}

// The noise level's scan: its largest change, whether it is an event.
std::string NoiseLevelSummary(const allan::NoiseLevelChange& n, double tolerance) {
  if (!n.scanned) return "noise level: not scanned: " + n.note + "\n";
  char text[320];
  std::snprintf(text, sizeof text,
                "noise level (mean square difference of successive samples per bin): largest "
                "change x%.4g +- %.2g at %.0f s, p %.2g over %d bins: ",
                n.ratio, n.ratio_sigma, n.time_s, n.p, n.bins);
  char within[64];
  std::snprintf(within, sizeof within, "significant, within the tolerance x%.4g", 1 + tolerance);
  return text + std::string(n.found() ? "an event" : n.significant ? within : "no change found") +
         "\n";
}

// One row per event: where, what, its size with its 1-sigma (datasheet rate
// units when the kind is known), z at detection and the p adjusted for the
// whole scan.
TableWriter EventTable(const allan::StationarityScan& scan,
                       const std::optional<allan::SensorKind>& kind) {
  const std::string unit = Present(NoiseTerm::kBiasInstability, kind, 1.0).second;
  TableWriter t({"event", "at_s", "window_s", "size", "size_sigma", "unit", "z", "p_adjusted"}, 4);
  for (const allan::StationarityEvent& e : scan.events) {
    const allan::EventAxis& a = e.axes.front();
    t.AddRow({Cell::Text(std::string(allan::EventKindName(e.kind))), Cell::Real(e.time_s),
              Cell::Real(e.window_s),
              Cell::Real(Present(NoiseTerm::kBiasInstability, kind, a.size).first),
              Cell::Real(Present(NoiseTerm::kBiasInstability, kind, a.sigma).first),
              Cell::Text(unit), Cell::Real(a.z), Cell::Real(e.p_adjusted)});
  }
  return t;
}

// The stretch of the record that --judge-longest-segment judges: the one
// with the most valid samples that no found event touches, each event cut
// with a scan bin either side (a step or a noise-level change at its time, a
// burst from its start to its end, a step in missing data across the missing
// stretch), as a station's JUDGE_LONGEST_SEGMENT cuts an axis. The whole
// record where nothing was found or the scan could not run.
struct JudgedStretch {
  int64_t begin = 0, end = 0;  // samples [begin, end)
  int64_t valid = 0;           // valid samples in it
  int64_t record_valid = 0;    // valid samples in the whole record
  bool whole_record = true;
  std::string why;  // what cut the record, or why it is judged whole
};

JudgedStretch LongestStretch(const allan::StationarityScan& scan,
                             const std::optional<allan::NoiseLevelChange>& noise,
                             const std::vector<double>& values, double tau0) {
  JudgedStretch out;
  const auto n = static_cast<int64_t>(values.size());
  out.end = n;
  for (double v : values) out.record_valid += std::isfinite(v) ? 1 : 0;
  out.valid = out.record_valid;
  if (!scan.scanned) {
    out.why = "the whole record: not scanned (" + scan.note + ")";
    return out;
  }
  std::vector<std::pair<double, double>> cuts;
  std::vector<std::string> named;
  const double w = scan.bin_s;
  for (const allan::StationarityEvent& e : scan.events) {
    const allan::EventAxis& a = e.axes.front();
    if (!a.named) continue;
    cuts.push_back(allan::EventCut(e, a, w));
    char text[96];
    if (std::isfinite(a.gap_from_s)) {
      std::snprintf(text, sizeof text, "missing data %.0f-%.0f s", a.gap_from_s, a.gap_to_s);
    } else if (e.kind == allan::EventKind::kStep) {
      std::snprintf(text, sizeof text, "step at %.0f s", e.time_s);
    } else {
      std::snprintf(text, sizeof text, "%s %.0f-%.0f s",
                    std::string(allan::EventKindName(e.kind)).c_str(), e.time_s,
                    e.time_s + e.window_s);
    }
    named.push_back(text);
  }
  if (noise && noise->found()) {
    cuts.emplace_back(noise->time_s - w, noise->time_s + w);
    char text[96];
    std::snprintf(text, sizeof text, "noise level x%.3g at %.0f s", noise->ratio, noise->time_s);
    named.push_back(text);
  }
  if (cuts.empty()) {
    out.why = "the whole record: no event found";
    return out;
  }
  // The stretch with the most valid samples (the earliest of equal ones).
  const std::vector<allan::Segment> stretches =
      allan::UncutStretches(cuts, static_cast<double>(n) * tau0);
  out.whole_record = false;
  out.begin = out.end = 0;
  out.valid = 0;
  for (const allan::Segment& seg : stretches) {
    const int64_t from = std::clamp<int64_t>(std::llround(seg.begin_s / tau0), 0, n);
    const int64_t to = std::clamp<int64_t>(std::llround(seg.end_s / tau0), from, n);
    int64_t valid = 0;
    for (int64_t i = from; i < to; ++i) valid += std::isfinite(values[i]) ? 1 : 0;
    if (valid > out.valid) out.begin = from, out.end = to, out.valid = valid;
  }
  std::string list;
  for (const std::string& t : named) list += (list.empty() ? "" : ", ") + t;
  char bin[48];
  std::snprintf(bin, sizeof bin, " (a %.4g s bin either side)", w);
  out.why = "cut by " + list + bin;
  return out;
}

// The judged stretch as one row: where it lies and why.
TableWriter StretchTable(const JudgedStretch& s, double tau0) {
  TableWriter t({"judged_from_s", "judged_to_s", "samples", "valid", "whole_record", "why"}, 6);
  t.AddRow({Cell::Real(static_cast<double>(s.begin) * tau0),
            Cell::Real(static_cast<double>(s.end) * tau0), Cell::Int(s.end - s.begin),
            Cell::Int(s.valid), Cell::Bool(s.whole_record), Cell::Text(s.why)});
  return t;
}

// The long-tau check's rows for --format csv and json (deviations in the
// datasheet unit of --kind, else the input's).
TableWriter LongTauCheckTable(const std::vector<LongTauCheck>& rows,
                              const std::optional<allan::SensorKind>& kind) {
  const allan::DatasheetValue unit = LongTauUnit(kind, "");
  TableWriter t(
      {"tau_s", "m", "theo1", "model", "unit", "ratio", "edf", "range_lo", "range_hi", "inside"},
      6);
  for (const LongTauCheck& c : rows) {
    t.AddRow({Cell::Real(c.tau_s), Cell::Int(c.m), Cell::Real(c.measured * unit.value),
              Cell::Real(c.expected * unit.value), Cell::Text(std::string(unit.unit)),
              Cell::Real(c.Ratio()), Cell::Real(c.edf), Cell::Real(c.lo), Cell::Real(c.hi),
              Cell::Bool(c.Inside())});
  }
  return t;
}

int AnalyzeFileCommand(const AnalyzeFileOptions& o) {
  auto parsed = ParseOptions(o);
  if (!parsed.ok()) {
    LogError(parsed.status().message());
    return 2;
  }
  const Parsed& p = *parsed;
  auto text = ReadFileToString(o.path);
  if (!text.ok()) {
    LogError(text.status().message());
    return 1;
  }
  // One rule for bad samples, as the station's CSV source: a cell that is
  // not a number is an invalid sample (counted below, its first named).
  std::vector<std::string> bad_cells;
  auto values = ParseSeries(*text, o.path, o.column, &bad_cells);
  if (!values.ok()) {
    LogError(values.status().message());
    return 1;
  }
  for (const std::string& w : bad_cells) LogWarning(w);
  if (p.factor != 1.0) {
    for (double& v : *values) v *= p.factor;
  }
  const double tau0 = 1.0 / o.rate_hz;
  // The stationarity scan: the series as one axis, its own noise model.
  std::optional<allan::StationarityScan> scan;
  std::string reference_source;  // the plan's reference model scanned against, if any
  std::optional<allan::NoiseLevelChange> noise;
  double noise_tolerance = judge::kDefaultNoiseLevelTolerance;
  if (o.stationarity_level > 0) {
    allan::StationarityOptions so;
    so.false_alarm = o.stationarity_level;
    Result<allan::StationarityScan> s = Status::NotFound("not scanned");
    if (!o.stationarity_plan.empty()) {
      auto plan = judge::LoadPlan(o.stationarity_plan);
      if (!plan.ok()) {
        LogError("--stationarity-plan: " + plan.status().message());
        return 1;
      }
      const pb::AxisKind kind = o.kind == "accel" ? pb::ACCEL : pb::GYRO;
      const pb::ReferenceNoiseModel* reference = judge::ReferenceModelFor(*plan, kind);
      if (reference == nullptr) {
        LogError("--stationarity-plan: " + o.stationarity_plan +
                 " has no stationarity "
                 "reference_model for " +
                 pb::AxisKind_Name(kind) + " axes");
        return 1;
      }
      so.bin_s = plan->stationarity().bin_s();
      if (plan->stationarity().noise_level_tolerance() != 0) {
        noise_tolerance = plan->stationarity().noise_level_tolerance();
      }
      s = allan::ScanStationarity({std::span<const double>(*values)},
                                  {judge::ReferenceModel(*reference)}, tau0, so);
      if (s.ok()) reference_source = reference->source();
    } else {
      s = allan::ScanStationarityRefitting({std::span<const double>(*values)}, tau0, so);
    }
    if (!s.ok()) {
      LogError("--stationarity: " + s.status().message());
      return 1;
    }
    scan = *s;
    // The noise level over the same bins (no model; the plan's tolerance).
    if (scan->scanned && noise_tolerance >= 0) {
      const int64_t bin_samples = std::llround(scan->bin_s / tau0);
      auto n =
          allan::ScanNoiseLevel(allan::BinMeanSquareDifferences(*values, bin_samples, scan->bins),
                                scan->bin_s, o.stationarity_level, noise_tolerance);
      if (!n.ok()) {
        LogError("--stationarity: " + n.status().message());
        return 1;
      }
      noise = *n;
    }
  }

  // --judge-longest-segment: the curves, the fit and every read-off are the
  // longest stretch's that no found event touches (as a plan's
  // JUDGE_LONGEST_SEGMENT judges a station's axis).
  std::optional<JudgedStretch> stretch;
  std::vector<double> stretch_values;
  if (o.judge_longest_segment) {
    stretch = LongestStretch(*scan, noise, *values, tau0);
    if (stretch->valid == 0) {
      LogError("--judge-longest-segment: no stretch without events holds a valid sample (" +
               stretch->why + ")");
      return 1;
    }
    stretch_values.assign(values->begin() + stretch->begin, values->begin() + stretch->end);
  }
  const std::vector<double>& series = stretch ? stretch_values : *values;
  const allan::PhaseRecord phase =
      o.type == "rate" ? allan::PhaseFromRate(series, tau0) : allan::PhaseFromPhase(series, tau0);
  const std::vector<Curve> curves = ComputeCurves(phase, p.curves);

  // The fit works on an Allan variance curve: the OADEV (or ADEV) asked for,
  // else an octave OADEV computed for it.
  std::optional<allan::CompositeFit> fit;
  Curve fit_curve;
  if (o.fit) {
    bool found = false;
    for (const Curve& c : curves) {
      if (!found && (c.deviation == Deviation::kOadev || c.deviation == Deviation::kAdev)) {
        fit_curve = c;
        found = true;
      }
    }
    if (!found) {
      const std::vector<int64_t> m = allan::AveragingFactors(
          allan::TauGridSpec{}, tau0, phase.size(), Deviation::kOadev, p.curves.stop);
      fit_curve = allan::ComputeDeviation(phase, Deviation::kOadev, m);
    }
    // The fit's first pass weighs each point by the edf of its identified
    // noise: identify it whatever --ci shows (as the station's final curves
    // do), so that the interval option never changes the model.
    if (fit_curve.ci != allan::CiMethod::kChi2) {  // chi2 at any level: the same edf
      allan::AttachConfidence(phase, allan::CiMethod::kChi2, allan::kOneSigmaConfidence,
                              &fit_curve);
    }
    allan::GmwmOptions fo;
    fo.stop = allan::StopRule::kNone;  // the curve is already cut by --stop
    fo.min_tau_s = o.fit_min_tau_s;
    std::vector<allan::Theo1Moment> long_taus;
    if (o.fit_long_taus && !fit_curve.points.empty()) {
      long_taus = allan::Theo1MomentsBeyond(phase, fit_curve.points.back().tau_s);
    }
    auto f = allan::FitCompositeModel(fit_curve, fo, long_taus);
    if (!f.ok()) {
      LogError("--fit: " + f.status().message());
      return 1;
    }
    fit = *f;
  }

  // The dynamic Allan deviation, before anything is printed: a window that
  // does not fit the record is an error of the command.
  std::optional<allan::DynamicAllan> davar;
  if (!o.davar_path.empty()) {
    allan::DynamicAllanOptions dop;
    dop.window_s = o.davar_window_s;
    auto d = allan::ComputeDynamicAllan(std::span<const double>(*values), tau0, {}, dop);
    if (!d.ok()) {
      LogError("--davar: " + d.status().message());
      return 1;
    }
    davar = std::move(*d);
  }

  std::optional<std::vector<LongTauCheck>> long_tau;
  if (fit && o.long_tau_check) long_tau = CheckLongTau(phase, *fit, fit_curve);
  if (fit && o.fit_long_taus) long_tau = FitLongTauRows(*fit);
  const bool with_ci = p.curves.ci != allan::CiMethod::kNone;
  // The whole record's invalid samples (the phase's are the judged stretch's).
  const int64_t invalid = stretch ? static_cast<int64_t>(values->size()) - stretch->record_valid
                                  : phase.invalid_count();
  if (p.format == Format::kTable) {
    std::printf("%s: %zu %s samples at %g Hz, %lld invalid\n", o.path.c_str(), values->size(),
                o.type.c_str(), o.rate_hz, static_cast<long long>(invalid));
    if (stretch) {
      std::printf(
          "judged on %.6g-%.6g s (%lld samples, %lld valid): %s; the curves, fit and "
          "read-offs below are this stretch's\n",
          static_cast<double>(stretch->begin) * tau0, static_cast<double>(stretch->end) * tau0,
          static_cast<long long>(stretch->end - stretch->begin),
          static_cast<long long>(stretch->valid), stretch->why.c_str());
    }
    for (const Curve& c : curves) {
      std::printf("\n%s (grid %s, stop %s, ci %s)\n",
                  std::string(allan::DeviationName(c.deviation)).c_str(), o.grid.c_str(),
                  o.stop.c_str(), o.ci.c_str());
      std::printf("%s",
                  CurveTable({{"", c}}, with_ci, false, false).Render(Format::kTable).c_str());
    }
    if (fit) {
      std::printf("\n%s\n", FitSummary(*fit, o.fit_min_tau_s).c_str());
      std::printf("%s",
                  QuantityTable(*fit, fit_curve, p.kind, true).Render(Format::kTable).c_str());
      std::printf(
          "\ncandidates (those the J test accepts first, then best criterion first; criterion J "
          "+ 3.84 per Q/N/B/K/R term + 2 per Gauss-Markov or sinusoid parameter + "
          "2k(k+1)/(p-k-1); figures and IEEE terms are averaged with the weights)\n%s",
          CandidateTable(*fit).Render(Format::kTable).c_str());
    }
    if (long_tau) {
      std::printf("\n%s", LongTauCheckText(*long_tau, p.kind, o.fit_long_taus).c_str());
    }
    if (scan) std::printf("\n%s", StationaritySummary(*scan, reference_source).c_str());
    if (scan && !scan->events.empty()) {
      std::printf("%s", EventTable(*scan, p.kind).Render(Format::kTable).c_str());
    }
    if (noise) std::printf("%s", NoiseLevelSummary(*noise, noise_tolerance).c_str());
  } else if (p.format == Format::kCsv) {
    std::printf("%s",
                CurveTable(Unlabeled(curves), with_ci, true, false).Render(Format::kCsv).c_str());
    if (fit) {
      std::printf("\n%s", QuantityTable(*fit, fit_curve, p.kind).Render(Format::kCsv).c_str());
      std::printf("\n%s", CandidateTable(*fit).Render(Format::kCsv).c_str());
    }
    if (long_tau) {
      std::printf("\n%s", LongTauCheckTable(*long_tau, p.kind).Render(Format::kCsv).c_str());
    }
    if (scan && scan->scanned)
      std::printf("\n%s", EventTable(*scan, p.kind).Render(Format::kCsv).c_str());
    if (stretch) std::printf("\n%s", StretchTable(*stretch, tau0).Render(Format::kCsv).c_str());
  } else {
    std::string json = "{\"file\": " + report::JsonString(o.path) +
                       ", \"samples\": " + std::to_string(values->size()) +
                       ", \"invalid_samples\": " + std::to_string(invalid) +
                       ", \"rate_hz\": " + std::to_string(o.rate_hz) + ",\n\"curves\": " +
                       CurveTable(Unlabeled(curves), with_ci, true, false).Render(Format::kJson);
    if (fit) json += ",\n\"fit\": " + FitJson(*fit, fit_curve, p.kind);
    if (long_tau) {
      json += ",\n\"" + std::string(o.fit_long_taus ? "long_tau_moments" : "long_tau_check") +
              "\": " + LongTauCheckTable(*long_tau, p.kind).Render(Format::kJson);
    }
    if (scan) {
      json +=
          ",\n\"stationarity\": {\"scanned\": " + std::string(scan->scanned ? "true" : "false") +
          ", \"note\": " + JsonString(scan->note) +
          ", \"false_alarm\": " + JsonNumber(scan->false_alarm) +
          ", \"bin_s\": " + JsonNumber(scan->bin_s) +
          ", \"model\": " + JsonString(scan->models.empty() ? "" : scan->models.front()) +
          ", \"events\": " + EventTable(*scan, p.kind).Render(Format::kJson);
      if (noise) {
        json +=
            ", \"noise_level\": {\"scanned\": " + std::string(noise->scanned ? "true" : "false") +
            ", \"note\": " + JsonString(noise->note) +
            ", \"bins\": " + std::to_string(noise->bins) + ", \"p\": " + JsonNumber(noise->p) +
            ", \"time_s\": " + JsonNumber(noise->time_s) +
            ", \"ratio\": " + JsonNumber(noise->ratio) +
            ", \"ratio_sigma\": " + JsonNumber(noise->ratio_sigma) +
            ", \"tolerance\": " + JsonNumber(noise_tolerance) +
            ", \"event\": " + std::string(noise->found() ? "true" : "false") + "}";
      }
      json += "}";
    }
    if (stretch) {
      json += ",\n\"judged_segment\": " + StretchTable(*stretch, tau0).Render(Format::kJson);
    }
    std::printf("%s}\n", json.c_str());
  }
  if (!o.plot_path.empty()) {
    const std::string svg =
        PlotCurves(curves, fit ? &*fit : nullptr, fit ? &fit_curve : nullptr, PlotTitle(o), p.kind,
                   o.type == "phase");
    Status st = WriteStringToFile(o.plot_path, svg);
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
  }
  if (davar) {
    report::DynamicAllanPlotStyle style;
    style.title = PlotTitle(o) + ": dynamic Allan deviation";
    if (p.kind) {  // datasheet units on the left, the base unit on the right
      const allan::DatasheetValue unit =
          allan::ToDatasheetUnits(NoiseTerm::kBiasInstability, *p.kind, 1.0);
      style.y_scale = unit.value;
      style.y_label = "Allan deviation [" + std::string(unit.unit) + "]";
      style.y2_label = *p.kind == allan::SensorKind::kGyro ? "[deg/s]" : "[m/s^2]";
    } else {
      style.y_label = "Allan deviation [the input's unit x --scale]";
    }
    Status st = WriteStringToFile(o.davar_path, report::DynamicAllanSvg(*davar, style));
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
  }
  return 0;
}

}  // namespace imuqual::offline
