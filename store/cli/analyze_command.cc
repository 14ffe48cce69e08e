#include "store/cli/analyze_command.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"
#include "analyze/allan/units.h"
#include "common/log.h"
#include "common/numeric_text.h"
#include "common/text_util.h"
#include "store/cli/curve_request.h"
#include "store/cli/svg_plot.h"
#include "store/cli/table_writer.h"

namespace imuqual::cli {
namespace {

using allan::Curve;
using allan::Deviation;
using allan::NoiseTerm;

struct Parsed {
  CurveRequest curves;
  Format format;
  std::optional<allan::SensorKind> kind;
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
  if (!(o.rate_hz > 0) || !std::isfinite(o.rate_hz)) {
    return Status::InvalidArgument("--rate must be a positive rate in Hz");
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

TableWriter FitTable(const allan::NoiseFit& fit, const Curve& curve,
                     const std::optional<allan::SensorKind>& kind) {
  TableWriter t({"term", "fit", "sigma", "slope_line", "unit", "note"}, 5);
  for (NoiseTerm term : allan::kNoiseTerms) {
    const allan::TermEstimate& e = fit.term(term);
    double line_value = allan::kNaN;
    std::string note;
    if (term == NoiseTerm::kBiasInstability) {
      if (auto min = allan::FindCurveMinimum(curve)) line_value = min->bias_instability_ieee;
      note = "slope_line = curve minimum / 0.664";
    } else {
      const allan::SlopeReadoff r = allan::ReadSlopeLine(curve, term);
      line_value = r.value;
      if (r.upper_bound_only) note = "slope line: upper bound only (no point on the slope)";
    }
    if (!e.active) note = note.empty() ? "not in the fitted model" : note + "; not in the fitted model";
    const auto [v, unit] = Present(term, kind, e.value);
    t.AddRow({Cell::Text(std::string(allan::NoiseTermName(term))), Cell::Real(v),
              Cell::Real(e.active ? Present(term, kind, e.sigma).first : allan::kNaN),
              Cell::Real(Present(term, kind, line_value).first), Cell::Text(unit), Cell::Text(note)});
  }
  return t;
}

std::string PlotCurves(const std::vector<Curve>& curves, const allan::NoiseFit* fit,
                       const Curve* fit_curve, const std::string& title) {
  LogLogPlot plot;
  plot.title = title;
  plot.y_label = "deviation";
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
    PlotSeries model;
    model.label = "IEEE 952 fit";
    model.color = "#555555";
    model.markers = false;
    model.dashed = true;
    const double t0 = fit_curve->points.front().tau_s, t1 = fit_curve->points.back().tau_s;
    for (int i = 0; i <= 100; ++i) {
      const double tau = t0 * std::pow(t1 / t0, i / 100.0);
      model.x.push_back(tau);
      model.y.push_back(fit->ModelDeviation(tau));
    }
    plot.series.push_back(std::move(model));
    if (auto min = allan::FindCurveMinimum(*fit_curve)) {
      char label[64];
      std::snprintf(label, sizeof label, "minimum %.4g at %.4g s", min->dev, min->tau_s);
      plot.markers.push_back({label, min->tau_s, min->dev, "#d62728"});
    }
  }
  return plot.ToSvg();
}

}  // namespace

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
  auto values = ParseSeries(*text, o.path, o.column);
  if (!values.ok()) {
    LogError(values.status().message());
    return 1;
  }
  const double tau0 = 1.0 / o.rate_hz;
  const allan::PhaseRecord phase = o.type == "rate" ? allan::PhaseFromRate(*values, tau0)
                                                    : allan::PhaseFromPhase(*values, tau0);
  const std::vector<Curve> curves = ComputeCurves(phase, p.curves);

  // The fit works on an Allan variance curve: the OADEV (or ADEV) asked for,
  // else an octave OADEV computed for it.
  std::optional<allan::NoiseFit> fit;
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
      const std::vector<int64_t> m = allan::AveragingFactors(allan::TauGridSpec{}, tau0, phase.size(),
                                                             Deviation::kOadev, p.curves.stop);
      fit_curve = allan::ComputeDeviation(phase, Deviation::kOadev, m);
    }
    allan::FitOptions fo;
    fo.stop = allan::StopRule::kNone;  // the curve is already cut by --stop
    auto f = allan::FitNoiseModel(fit_curve, fo);
    if (!f.ok()) {
      LogError("--fit: " + f.status().message());
      return 1;
    }
    fit = *f;
  }

  const bool with_ci = p.curves.ci != allan::CiMethod::kNone;
  if (p.format == Format::kTable) {
    std::printf("%s: %zu %s samples at %g Hz, %lld invalid\n", o.path.c_str(), values->size(),
                o.type.c_str(), o.rate_hz, static_cast<long long>(phase.invalid_count()));
    for (const Curve& c : curves) {
      std::printf("\n%s (grid %s, stop %s, ci %s)\n", std::string(allan::DeviationName(c.deviation)).c_str(),
                  o.grid.c_str(), o.stop.c_str(), o.ci.c_str());
      std::printf("%s", CurveTable({{"", c}}, with_ci, false, false).Render(Format::kTable).c_str());
    }
    if (fit) {
      std::printf("\nIEEE 952 noise model (weighted NNLS, %d points, %d re-weighted passes)\n",
                  fit->points_used, fit->irls_passes);
      std::printf("%s", FitTable(*fit, fit_curve, p.kind).Render(Format::kTable).c_str());
    }
  } else if (p.format == Format::kCsv) {
    std::printf("%s", CurveTable(Unlabeled(curves), with_ci, true, false).Render(Format::kCsv).c_str());
    if (fit) std::printf("\n%s", FitTable(*fit, fit_curve, p.kind).Render(Format::kCsv).c_str());
  } else {
    std::string json = "{\"file\": \"" + o.path + "\", \"samples\": " + std::to_string(values->size()) +
                       ", \"rate_hz\": " + std::to_string(o.rate_hz) + ",\n\"curves\": " +
                       CurveTable(Unlabeled(curves), with_ci, true, false).Render(Format::kJson);
    if (fit) json += ",\n\"fit\": " + FitTable(*fit, fit_curve, p.kind).Render(Format::kJson);
    std::printf("%s}\n", json.c_str());
  }
  if (!o.plot_path.empty()) {
    const std::string svg = PlotCurves(curves, fit ? &*fit : nullptr, fit ? &fit_curve : nullptr,
                                       o.path.substr(o.path.find_last_of('/') + 1));
    Status st = WriteStringToFile(o.plot_path, svg);
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
  }
  return 0;
}

}  // namespace imuqual::cli
