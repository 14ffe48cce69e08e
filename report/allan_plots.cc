#include "report/allan_plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>

#include "analyze/allan/model_quantities.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"
#include "common/log.h"
#include "common/text_util.h"
#include "report/model_plot.h"
#include "report/svg_plot.h"
#include "report/time_series.h"
#include "store/outcome.h"
#include "store/query.h"

namespace imuqual::report {
namespace {

using allan::NoiseTerm;

constexpr char kLimitColor[] = "#d62728";     // red: the limit
constexpr char kMarginalColor[] = "#e69f00";  // amber: the marginal band's edge
constexpr char kPassCurveColor[] = "#4a78a8";
constexpr char kUnjudgedCurveColor[] = "#999999";
// Points of the model curve: smooth at plot size, one per ~1/20 decade over
// the usual 4-5 decades of tau.
constexpr int kModelPoints = 96;
// Wide enough a legend for "x min: 24.57 deg/h @ 5.12 s".
constexpr int kPlotWidthPx = 800;
constexpr int kLegendWidthPx = 215;

// Axis colours of a run plot: no red or amber (the limit lines' colours).
std::string AxisColor(size_t i) {
  static const char* kColors[] = {"#1f77b4", "#2ca02c", "#9467bd", "#8c564b",
                                  "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};
  return kColors[i % (sizeof kColors / sizeof kColors[0])];
}

allan::SensorKind Sensor(pb::AxisKind kind) {
  return kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
}

// Datasheet units per base unit of `term` (every conversion is linear).
double DatasheetPerBase(NoiseTerm term, pb::AxisKind kind) {
  return allan::ToDatasheetUnits(term, Sensor(kind), 1.0).value;
}

std::string DatasheetUnit(NoiseTerm term, pb::AxisKind kind) {
  return std::string(allan::ToDatasheetUnits(term, Sensor(kind), 1.0).unit);
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

const char* KindWord(pb::AxisKind kind) { return kind == pb::ACCEL ? "accelerometer" : "gyro"; }
const char* RateUnit(pb::AxisKind kind) { return kind == pb::ACCEL ? "m/s^2" : "deg/s"; }

// The y axes: datasheet units (deg/h, ug: those of the limits and tables) on
// the left, the curve's own unit (deg/s, m/s^2) on the right.
void DatasheetAxes(pb::AxisKind kind, LogLogPlot* p) {
  p->y_scale = DatasheetPerBase(NoiseTerm::kBiasInstability, kind);
  p->y_label = "Allan deviation [" + DatasheetUnit(NoiseTerm::kBiasInstability, kind) + "]";
  p->y2_label = std::string("[") + RateUnit(kind) + "]";
}

const pb::Measurement* FindMeasurementRow(const AxisPlotData& a, std::string_view name) {
  for (const pb::Measurement& m : a.measurements) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

int Severity(const std::string& verdict) { return store::OutcomeSeverity(verdict); }

// Whether a unit's curve in a lot overlay is drawn bold, in its own colour
// and with its band: its axis is judged FAIL, INCONCLUSIVE or MARGINAL.
bool DrawnBold(const std::string& verdict) {
  const pb::Outcome o = store::OutcomeFromText(verdict);
  return o == pb::FAIL || o == pb::INCONCLUSIVE || o == pb::MARGINAL;
}

// The colour of the i-th unit with `verdict` (FAIL, INCONCLUSIVE, MARGINAL)
// in a lot overlay: a shade of its verdict's colour family (reds for FAIL,
// violets for INCONCLUSIVE, ambers and browns for MARGINAL), distinct for the
// first six of each, so that units are told apart and their verdict read at a
// glance; none is the PASS curves' blue.
std::string FlaggedUnitColor(const std::string& verdict, size_t i) {
  static const char* kFail[] = {"#d62728", "#8c1c13", "#ff6f6f", "#b2182b", "#67000d", "#e34a33"};
  static const char* kInconclusive[] = {"#5a32a3", "#9467bd", "#3f007d",
                                        "#807dba", "#54278f", "#b4a7d6"};
  static const char* kMarginal[] = {"#e69f00", "#8c6d1f", "#f0c05a",
                                    "#b8860b", "#fdd049", "#6b4c00"};
  const char* const* family = verdict == "FAIL"           ? kFail
                              : verdict == "INCONCLUSIVE" ? kInconclusive
                                                          : kMarginal;
  return family[i % 6];
}

std::string WorstOutcome(const std::vector<pb::Measurement>& ms) {
  std::string worst;
  for (const pb::Measurement& m : ms) {
    const std::string v = store::OutcomeText(m.outcome());
    if (Severity(v) > Severity(worst)) worst = v;
  }
  return worst;
}

// The measured curve with its confidence band (where the curve has one).
PlotSeries CurveSeries(const allan::Curve& curve, std::string label, std::string color) {
  PlotSeries s;
  s.label = std::move(label);
  s.color = std::move(color);
  bool band = false;
  for (const allan::CurvePoint& p : curve.points) {
    s.x.push_back(p.tau_s);
    s.y.push_back(p.dev);
    s.lo.push_back(p.lo);
    s.hi.push_back(p.hi);
    band |= std::isfinite(p.lo) && std::isfinite(p.hi);
  }
  if (!band) {
    s.lo.clear();
    s.hi.clear();
  }
  return s;
}

// The axis's noise model over the curve's tau span, dashed in the axis's
// colour (several axes on one plot: the model's terms would crowd it).
std::optional<PlotSeries> ModelSeries(const AxisPlotData& a, std::string label, std::string color) {
  if (!a.curve || a.curve->points.empty() || !(a.curve->tau0_s > 0)) return std::nullopt;
  const std::optional<ArchivedModel> m = LoadArchivedModel(a);
  if (!m) return std::nullopt;
  if (!m->adequate) label += " (inadequate)";
  const double t0 = a.curve->points.front().tau_s, t1 = a.curve->points.back().tau_s;
  if (!(t0 > 0) || !(t1 > t0)) return std::nullopt;
  PlotSeries s;
  s.label = std::move(label);
  s.color = std::move(color);
  s.dashed = true;
  s.markers = false;
  for (int i = 0; i < kModelPoints; ++i) {
    const double tau = t0 * std::pow(t1 / t0, static_cast<double>(i) / (kModelPoints - 1));
    s.x.push_back(tau);
    s.y.push_back(m->model.Deviation(tau / a.curve->tau0_s, a.curve->tau0_s));
  }
  return s;
}

// The bias-instability point: the measured curve minimum and its tau.
std::optional<PlotMarker> MinimumMarker(const AxisPlotData& a, std::string label_prefix,
                                        std::string color) {
  const pb::Measurement* bi = FindMeasurementRow(a, judge::kBiasInstability);
  const pb::Measurement* tau = FindMeasurementRow(a, judge::kTauAtMinimum);
  if (bi == nullptr || tau == nullptr || !std::isfinite(bi->value()) ||
      !std::isfinite(tau->value())) {
    return std::nullopt;
  }
  PlotMarker m;
  m.x = tau->value();
  m.y = bi->value() / DatasheetPerBase(NoiseTerm::kBiasInstability, a.kind);
  m.color = std::move(color);
  if (!label_prefix.empty()) {
    m.label = std::move(label_prefix);
    m.label += Num(bi->value());
    m.label += " ";
    m.label += bi->unit();
    m.label += " @ ";
    char tau_text[32];
    std::snprintf(tau_text, sizeof tau_text, "%.3g s", tau->value());
    m.label += tau_text;
  }
  return m;
}

// What hovering over a unit's curve in a lot overlay says: the unit, its
// slot, the axis's verdict and its curve minimum, the run.
std::string CurveTooltip(const RunPlotData& run, const AxisPlotData& a) {
  std::string t = run.info.serial;
  if (!run.info.slot.empty()) t += " (slot " + run.info.slot + ")";
  t += " " + a.axis + ": " + (a.verdict.empty() ? std::string("not judged") : a.verdict);
  if (auto m = MinimumMarker(a, "minimum ", "")) t += "; " + m->label;
  t += "; run " + run.info.run_id;
  return t;
}

// How a limit on a measurement shows on the Allan deviation plot: the line
// sigma(tau) = limit x scale / (datasheet units per base unit) x tau^slope,
// from the IEEE 952 model term it bounds.
struct LimitLine {
  std::string_view measurement;
  NoiseTerm term;
  double slope;
  double scale;
  std::string_view label;
};
const LimitLine kLimitLines[] = {
    // The curve minimum itself, and IEEE's B = minimum / 0.664.
    {judge::kBiasInstability, NoiseTerm::kBiasInstability, 0, 1, "BI"},
    {judge::kBiasInstabilityIeee, NoiseTerm::kBiasInstability, 0, allan::kBiasInstabilityFactor,
     "BI (IEEE)"},
    // Slope-line read-offs: sigma = N / sqrt(tau), sigma = K sqrt(tau / 3).
    {judge::kAngleRandomWalk, NoiseTerm::kAngleRandomWalk, -0.5, 1, "ARW"},
    {judge::kVelocityRandomWalk, NoiseTerm::kAngleRandomWalk, -0.5, 1, "VRW"},
    {judge::kRateRandomWalk, NoiseTerm::kRateRandomWalk, 0.5, 1 / std::numbers::sqrt3, "RRW"},
    // Fitted terms, each its model term alone: sqrt(3) Q / tau, N / sqrt(tau),
    // 0.664 B, K sqrt(tau / 3), R tau / sqrt(2).
    {judge::kFitQuantization, NoiseTerm::kQuantization, -1, std::numbers::sqrt3, "fit Q"},
    {judge::kFitAngleRandomWalk, NoiseTerm::kAngleRandomWalk, -0.5, 1, "fit ARW"},
    {judge::kFitVelocityRandomWalk, NoiseTerm::kAngleRandomWalk, -0.5, 1, "fit VRW"},
    {judge::kFitBiasInstability, NoiseTerm::kBiasInstability, 0, allan::kBiasInstabilityFactor,
     "fit B"},
    {judge::kFitRateRandomWalk, NoiseTerm::kRateRandomWalk, 0.5, 1 / std::numbers::sqrt3,
     "fit RRW"},
    {judge::kFitRateRamp, NoiseTerm::kRateRamp, 1, 1 / std::numbers::sqrt2, "fit R"},
};

// The IEEE 952 slope-line read-offs of one axis, as kalibr_allan and
// allan_variance_ros draw them: the -1/2 line through N at tau = 1 s and the
// +1/2 line through K at tau = 3 s, each with its read-off point (in the
// legend: the value archived, "<=" when it is only an upper bound).
bool AddReadOffLines(const AxisPlotData& a, LogLogPlot* p) {
  bool added = false;
  struct ReadOff {
    std::string_view measurement;
    const char* name;
    double tau_s;
  };
  const ReadOff read_offs[] = {{judge::kAngleRandomWalk, "N", 1.0},
                               {judge::kVelocityRandomWalk, "N", 1.0},
                               {judge::kRateRandomWalk, "K", 3.0}};
  for (const ReadOff& r : read_offs) {
    const pb::Measurement* m = FindMeasurementRow(a, r.measurement);
    if (m == nullptr || !std::isfinite(m->value()) || m->value() <= 0) continue;
    const LimitLine* shape = nullptr;
    for (const LimitLine& l : kLimitLines) {
      if (l.measurement == r.measurement) shape = &l;
    }
    if (shape == nullptr) continue;
    const double base = m->value() / DatasheetPerBase(shape->term, a.kind);
    const std::string value = std::string(m->qualifier() == pb::UPPER_BOUND ? "<=" : "=") +
                              Num(m->value()) + " " + m->unit();
    PlotLine line;
    line.label = std::string(r.name) + " line";
    line.y = base * shape->scale;  // sigma at tau = 1 s
    line.slope = shape->slope;
    line.color = "#7f7f7f";
    p->lines.push_back(std::move(line));
    PlotMarker point;
    point.label = std::string(r.name) + value + " @" + Num(r.tau_s) + "s";
    point.x = r.tau_s;
    point.y = base * shape->scale * std::pow(r.tau_s, shape->slope);
    point.color = "#7f7f7f";
    point.sets_range = false;  // a K far below the curve must not squash it
    p->markers.push_back(std::move(point));
    added = true;
  }
  return added;
}

// The plan's limits that an Allan plot of `axes` (all of `kind`) can show.
void AddPlanLines(const pb::TestPlan& plan, pb::AxisKind kind, const std::vector<std::string>& axes,
                  std::vector<PlotLine>* lines) {
  for (const pb::Limit& limit : plan.limits()) {
    if (limit.axis_kind() != pb::AXIS_KIND_UNSPECIFIED && limit.axis_kind() != kind) continue;
    std::vector<std::string> covered;
    for (const std::string& a : axes) {
      if (limit.axes().empty() ||
          std::find(limit.axes().begin(), limit.axes().end(), a) != limit.axes().end()) {
        covered.push_back(a);
      }
    }
    if (covered.empty()) continue;
    const LimitLine* shape = nullptr;
    for (const LimitLine& l : kLimitLines) {
      if (l.measurement == limit.measurement()) shape = &l;
    }
    if (shape == nullptr) continue;  // not a level of the Allan curve
    const NoiseTerm term = shape->term;
    const double slope = shape->slope, scale = shape->scale;
    const std::string what(shape->label);
    if (limit.unit() != DatasheetUnit(term, kind)) continue;
    std::string suffix;
    if (!limit.axes().empty() && axes.size() > 1) {
      suffix = " (";
      for (size_t i = 0; i < covered.size(); ++i) {
        if (i > 0) suffix += ",";
        suffix += covered[i];
      }
      suffix += ")";
    }
    // A sloped line runs parallel to its marginal line, too close for two
    // labels: the limit's label names both.
    auto add = [&](const std::optional<double>& v, const char* bound, const char* color,
                   const std::optional<double>& marginal) {
      if (!v || !(*v > 0)) return;
      PlotLine l;
      if (!(slope != 0 && std::string_view(bound).starts_with("marginal") &&
            (limit.has_high() || limit.has_low()))) {
        l.label = what;
        l.label += " ";
        l.label += bound;
        l.label += " ";
        l.label += Num(*v);
        if (slope != 0 && marginal) {
          l.label += ", marginal ";
          l.label += Num(*marginal);
        }
        l.label += " ";
        l.label += limit.unit();
        l.label += suffix;
      }
      l.y = *v * scale / DatasheetPerBase(term, kind);
      l.slope = slope;
      l.color = color;
      for (const PlotLine& o : *lines) {
        if (o.label == l.label && o.y == l.y && o.slope == l.slope) return;
      }
      lines->push_back(std::move(l));
    };
    auto opt = [](bool has, double v) { return has ? std::optional<double>(v) : std::nullopt; };
    const std::optional<double> high = opt(limit.has_high(), limit.high());
    const std::optional<double> marginal_high =
        opt(limit.has_marginal_high(), limit.marginal_high());
    const std::optional<double> low = opt(limit.has_low(), limit.low());
    const std::optional<double> marginal_low = opt(limit.has_marginal_low(), limit.marginal_low());
    add(high, "limit", kLimitColor, marginal_high);
    add(marginal_high, "marginal", kMarginalColor, std::nullopt);
    add(low, "low limit", kLimitColor, marginal_low);
    add(marginal_low, "marginal low", kMarginalColor, std::nullopt);
  }
}

// "68.3 % confidence (chi2)": what the bands are.
std::string BandNote(const allan::Curve& curve, const char* prefix) {
  if (curve.ci == allan::CiMethod::kNone) return "no confidence band stored";
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s%.1f %% confidence (%s)", prefix, 100 * curve.confidence,
                std::string(allan::CiMethodName(curve.ci)).c_str());
  return buf;
}

}  // namespace

std::optional<ArchivedModel> LoadArchivedModel(const AxisPlotData& a) {
  std::vector<allan::ModelQuantity> parameters;
  for (const pb::Measurement& m : a.measurements) {
    if (!m.name().starts_with(judge::kModelParameterPrefix)) continue;
    allan::ModelQuantity q;
    q.name = m.name().substr(judge::kModelParameterPrefix.size());
    q.value = m.value();
    q.unit = m.unit();
    parameters.push_back(std::move(q));
  }
  if (parameters.empty()) return std::nullopt;
  const Result<allan::CompositeModel> model = allan::ModelFromTerms(parameters, Sensor(a.kind));
  if (!model.ok() || model->terms.empty()) return std::nullopt;
  const pb::Measurement* p = FindMeasurementRow(a, judge::kNoiseModelPValue);
  const bool adequate = p == nullptr || judge::NoiseModelAdequate(*p);
  return ArchivedModel{*model, adequate};
}

Result<RunPlotData> LoadRunPlotData(store::Archive& archive, const std::string& run_id) {
  auto key = archive.FindRunKey(run_id);
  if (!key.ok()) return key.status();
  if (!*key) return Status::NotFound("no run '" + run_id + "' in " + archive.path());
  auto info = archive.LoadRun(run_id);
  if (!info.ok()) return info.status();
  auto result = archive.LoadResult(**key);
  if (!result.ok()) return result.status();
  auto curves = archive.LoadCurves(**key);
  if (!curves.ok()) return curves.status();
  return MakeRunPlotData(std::move(*info), *result, *curves);
}

RunPlotData MakeRunPlotData(store::RunInfo info, const std::optional<store::ResultRecord>& result,
                            const std::vector<store::CurveRecord>& curves) {
  RunPlotData d;
  d.info = std::move(info);
  if (!d.plan.ParseFromString(d.info.plan)) d.plan.Clear();
  std::vector<pb::Measurement> measurements;
  if (result) {
    d.verdict = result->verdict;
    d.reasons = result->reasons;
    measurements = result->measurements;
  }
  for (const store::AxisInfo& ax : d.info.axes) {
    AxisPlotData a;
    a.axis = ax.name;
    a.kind = ax.kind;
    for (const store::CurveRecord& c : curves) {
      if (c.axis != ax.name) continue;
      if (!a.curve || (a.curve->deviation != allan::Deviation::kOadev &&
                       c.curve.deviation == allan::Deviation::kOadev)) {
        a.curve = c.curve;
      }
    }
    for (const pb::Measurement& m : measurements) {
      if (m.axis() == ax.name) a.measurements.push_back(m);
    }
    a.verdict = WorstOutcome(a.measurements);
    d.axes.push_back(std::move(a));
  }
  return d;
}

std::vector<AllanPlot> RunAllanPlots(const RunPlotData& run, const std::string& axis) {
  std::vector<pb::AxisKind> kinds;
  for (const AxisPlotData& a : run.axes) {
    if (!axis.empty() && a.axis != axis) continue;
    if (std::find(kinds.begin(), kinds.end(), a.kind) == kinds.end()) kinds.push_back(a.kind);
  }
  std::vector<AllanPlot> plots;
  for (pb::AxisKind kind : kinds) {
    LogLogPlot p;
    DatasheetAxes(kind, &p);
    p.marker_labels_in_legend = true;
    p.width = kPlotWidthPx;
    p.legend_width = kLegendWidthPx;
    std::vector<std::string> names;
    const allan::Curve* first_curve = nullptr;
    bool read_off_lines = false;
    size_t i = 0;
    for (const AxisPlotData& a : run.axes) {
      if (a.kind != kind || (!axis.empty() && a.axis != axis)) continue;
      names.push_back(a.axis);
      const std::string color = AxisColor(i++);
      if (!a.curve) continue;
      if (first_curve == nullptr) first_curve = &*a.curve;
      std::string label = a.axis;
      if (!a.verdict.empty()) {
        label += " (";
        label += a.verdict;
        label += ")";
      }
      p.series.push_back(CurveSeries(*a.curve, label, color));
      if (!axis.empty()) {
        // One axis: the model and each of its terms (model_plot.h).
        if (const std::optional<ArchivedModel> m = LoadArchivedModel(a)) {
          AddModelSeries(m->model, a.curve->tau0_s, a.curve->points.front().tau_s,
                         a.curve->points.back().tau_s, m->adequate, &p);
        }
        read_off_lines = AddReadOffLines(a, &p);
      } else if (auto model = ModelSeries(a, a.axis + " noise model", color)) {
        p.series.push_back(std::move(*model));
      }
      if (auto m = MinimumMarker(a, a.axis + ": ", color)) p.markers.push_back(std::move(*m));
    }
    AddPlanLines(run.plan, kind, names, &p.lines);
    AllanPlot out;
    out.key = kind == pb::ACCEL ? "accel" : "gyro";
    out.title = run.info.serial;
    out.title += ", ";
    out.title += KindWord(kind);
    out.title += names.size() == 1 ? " axis " : " axes ";
    for (size_t k = 0; k < names.size(); ++k) {
      if (k > 0) out.title += ", ";
      out.title += names[k];
    }
    if (!run.verdict.empty()) {
      out.title += ": unit ";
      out.title += run.verdict;
    }
    p.title = out.title;
    if (first_curve != nullptr) p.notes.push_back(BandNote(*first_curve, "band: "));
    p.notes.push_back("dashed: IEEE 952 model fit");
    p.notes.push_back("ring: curve minimum (BI)");
    if (read_off_lines) p.notes.push_back("grey: N, K lines (read at 1, 3 s)");
    p.notes.push_back("run " + run.info.run_id);
    out.svg = p.ToSvg();
    plots.push_back(std::move(out));
  }
  return plots;
}

std::vector<AllanPlot> LotAllanPlots(const std::string& lot, const std::vector<RunPlotData>& runs,
                                     const std::string& axis) {
  // Axis names in order of first appearance; the kind is the first run's.
  std::vector<std::pair<std::string, pb::AxisKind>> names;
  for (const RunPlotData& r : runs) {
    for (const AxisPlotData& a : r.axes) {
      if (!axis.empty() && a.axis != axis) continue;
      auto same = [&](const auto& n) { return n.first == a.axis; };
      if (std::none_of(names.begin(), names.end(), same)) names.emplace_back(a.axis, a.kind);
    }
  }
  std::vector<AllanPlot> plots;
  for (const auto& [name, kind] : names) {
    // Units on this axis by verdict, the bold ones drawn last (on top).
    std::vector<std::pair<const RunPlotData*, const AxisPlotData*>> members;
    for (const RunPlotData& r : runs) {
      for (const AxisPlotData& a : r.axes) {
        if (a.axis == name && a.kind == kind && a.curve) members.emplace_back(&r, &a);
      }
    }
    std::stable_sort(members.begin(), members.end(), [](const auto& x, const auto& y) {
      return Severity(x.second->verdict) < Severity(y.second->verdict);
    });
    int pass = 0, unjudged = 0;
    for (const auto& m : members) {
      pass += m.second->verdict == "PASS";
      unjudged += m.second->verdict.empty();
    }
    LogLogPlot p;
    DatasheetAxes(kind, &p);
    p.width = kPlotWidthPx;
    p.legend_width = kLegendWidthPx;
    bool pass_listed = false, unjudged_listed = false;
    std::map<std::string, size_t> of_verdict;  // flagged units drawn so far, per verdict
    for (const auto& [run, a] : members) {
      if (DrawnBold(a->verdict)) {
        // Each flagged unit its own shade of its verdict's colour, named in
        // the legend with its verdict.
        const std::string color = FlaggedUnitColor(a->verdict, of_verdict[a->verdict]++);
        PlotSeries s = CurveSeries(*a->curve, run->info.serial + " " + a->verdict, color);
        s.stroke_width = 2.2;
        s.markers = false;
        s.tooltip = CurveTooltip(*run, *a);
        p.series.push_back(std::move(s));
        if (auto m = MinimumMarker(*a, "", color)) p.markers.push_back(std::move(*m));
        continue;
      }
      const bool judged = a->verdict == "PASS";
      PlotSeries s = CurveSeries(*a->curve, "", judged ? kPassCurveColor : kUnjudgedCurveColor);
      s.tooltip = CurveTooltip(*run, *a);
      s.lo.clear();
      s.hi.clear();
      s.markers = false;
      s.stroke_width = 1.2;
      s.opacity = 0.6;
      bool& listed = judged ? pass_listed : unjudged_listed;
      s.in_legend = !listed;
      listed = true;
      s.label = judged ? "PASS (" + std::to_string(pass) + ")"
                       : "not judged (" + std::to_string(unjudged) + ")";
      p.series.push_back(std::move(s));
    }
    std::set<std::string> plan_seen;
    for (const RunPlotData& r : runs) {
      const std::string serialized = r.plan.SerializeAsString();
      if (plan_seen.insert(serialized).second) AddPlanLines(r.plan, kind, {name}, &p.lines);
    }
    AllanPlot out;
    out.key = name;
    out.title = "Lot ";
    out.title += lot;
    out.title += ", ";
    out.title += KindWord(kind);
    out.title += " axis ";
    out.title += name;
    out.title += ": ";
    out.title += std::to_string(members.size());
    out.title += members.size() == 1 ? " unit" : " units";
    p.title = out.title;
    p.notes.push_back("blue: PASS; flagged units in shades");
    p.notes.push_back("of red (FAIL), violet (INCONCLUSIVE),");
    p.notes.push_back("amber (MARGINAL), one per unit");
    p.notes.push_back("hover a curve: unit, verdict, minimum");
    if (!members.empty()) {
      p.notes.push_back("bands: FAIL, INCONCLUSIVE and MARGINAL units,");
      p.notes.push_back(BandNote(*members.front().second->curve, ""));
    }
    p.notes.push_back("ring: curve minimum (BI)");
    out.svg = p.ToSvg();
    plots.push_back(std::move(out));
  }
  return plots;
}

}  // namespace imuqual::report
