#include "analyze/judge/stationarity_measure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "analyze/allan/stationarity.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

constexpr char kScanSeparator[] = ". Scan: ";

std::string Fmt(const char* format, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// A level in the bias unit: deg/h for a gyro, ug for an accelerometer (bias
// instability's, and bias_offset's).
allan::DatasheetValue InBiasUnit(double v, pb::AxisKind kind) {
  return allan::ToDatasheetUnits(
      allan::NoiseTerm::kBiasInstability,
      kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro, v);
}
double ToBiasUnit(double v, pb::AxisKind kind) { return InBiasUnit(v, kind).value; }
std::string BiasUnit(pb::AxisKind kind) { return std::string(InBiasUnit(0, kind).unit); }

std::string KindWord(pb::AxisKind kind) { return kind == pb::ACCEL ? "accelerometer" : "gyro"; }

// "level step +167 ± 12 deg/h at 3132 s" / "burst +40 ± 10 deg/h over 600 s from 5000 s".
std::string EventText(const allan::StationarityEvent& e, const allan::EventAxis& a,
                      pb::AxisKind kind) {
  const std::string size = Fmt("%+.3g", ToBiasUnit(a.size, kind)) + " \u00b1 " +
                           Fmt("%.2g", ToBiasUnit(a.sigma, kind)) + " " + BiasUnit(kind);
  if (e.kind == allan::EventKind::kStep) {
    if (std::isfinite(a.gap_from_s)) {
      return "level step " + size + " while the record was missing, between " +
             Fmt("%.0f", a.gap_from_s) + " and " + Fmt("%.0f", a.gap_to_s) + " s";
    }
    return "level step " + size + " at " + Fmt("%.0f", e.time_s) + " s";
  }
  return "burst " + size + " over " + Fmt("%.0f", e.window_s) + " s from " + Fmt("%.0f", e.time_s) +
         " s";
}

// Whether the record's curve gives evidence that the axis's noise lies above
// the reference (then the bound on the scan's false-alarm rate does not
// apply to it), at the taus the scan weighs (from a bin on): a point above
// the reference's deviation by more than 3 of its 1-sigma (the lower bound's
// distance; 3, not 2, for the many correlated points of a dense curve). An
// event in the record raises its long-tau curve too, so evidence here means
// "this unit's noise or its events", never that its noise is below.
struct Envelope {
  bool above = false;
  std::string text;
};
Envelope EnvelopeCheck(const allan::Curve* curve, const allan::CompositeModel& reference,
                       double bin_s) {
  if (curve == nullptr || curve->points.empty()) return {};
  double worst = 0, worst_tau = 0;
  bool above = false;
  double above_tau = 0;
  for (const allan::CurvePoint& p : curve->points) {
    if (!(p.dev > 0) || p.tau_s < bin_s) continue;
    const double ref = reference.Deviation(static_cast<double>(p.m), curve->tau0_s);
    if (!(ref > 0)) continue;
    if (p.dev / ref > worst) {
      worst = p.dev / ref;
      worst_tau = p.tau_s;
    }
    if (std::isfinite(p.lo) && p.dev - 3 * (p.dev - p.lo) > ref && !above) {
      above = true;
      above_tau = p.tau_s;
    }
  }
  if (!(worst > 0)) return {};
  if (above) {
    return {true, "; the record's curve lies above the reference from a bin on (first at " +
                      Fmt("%.3g", above_tau) + " s, by more than 3 sigma; at most " +
                      Fmt("%.3g", worst) + " x its deviation, at " + Fmt("%.3g", worst_tau) +
                      " s): an event raises it, but so does noise above the reference, for "
                      "which the scan's false-alarm rate is not bounded"};
  }
  return {false,
          "; the record's curve shows no noise above the reference from a bin on (at "
          "most " +
              Fmt("%.3g", worst) + " x its deviation, at " + Fmt("%.3g", worst_tau) +
              " s, within 3 sigma)"};
}

}  // namespace

const pb::ReferenceNoiseModel* ReferenceModelFor(const pb::TestPlan& plan, pb::AxisKind kind) {
  for (const pb::ReferenceNoiseModel& r : plan.stationarity().reference_model()) {
    if (r.axis_kind() == kind) return &r;
  }
  return nullptr;
}

int64_t StationarityBinSamples(const pb::TestPlan& plan, int64_t samples, double tau0_s) {
  const double bin_s = plan.stationarity().bin_s() > 0
                           ? plan.stationarity().bin_s()
                           : static_cast<double>(samples) * tau0_s / 300.0;
  return std::max<int64_t>(1, std::llround(bin_s / tau0_s));
}

pb::Outcome StationarityOutcome(const pb::TestPlan& plan, double events) {
  const pb::Stationarity::OnEvent action = plan.stationarity().on_event();
  if (action == pb::Stationarity::QUALIFIER_ONLY) return pb::OUTCOME_UNSET;
  if (!std::isfinite(events)) return pb::INCONCLUSIVE;
  if (events < 1) return pb::PASS;
  switch (action) {
    case pb::Stationarity::JUDGE_LONGEST_SEGMENT:
      return pb::OUTCOME_UNSET;  // the limits judge the stretch without events
    case pb::Stationarity::EVENT_MARGINAL:
      return pb::MARGINAL;
    case pb::Stationarity::EVENT_FAIL:
      return pb::FAIL;
    default:
      return pb::INCONCLUSIVE;
  }
}

std::string StationarityEventSummary(const pb::Measurement& events) {
  const std::string& note = events.note();
  const size_t cut = note.find(kScanSeparator);
  return cut == std::string::npos ? note : note.substr(0, cut);
}

std::vector<pb::Measurement> MeasureStationarity(const pb::TestPlan& plan,
                                                 const std::vector<StationarityAxis>& axes,
                                                 double bin_s, double tau0_s,
                                                 std::vector<EventCuts>* cuts) {
  std::vector<pb::Measurement> out;
  if (cuts != nullptr) cuts->assign(axes.size(), {});
  if (!plan.has_stationarity()) return out;
  const pb::Stationarity& st = plan.stationarity();
  allan::StationarityOptions options;
  if (st.false_alarm() > 0) options.false_alarm = st.false_alarm();
  const double noise_tolerance =
      st.noise_level_tolerance() == 0 ? kDefaultNoiseLevelTolerance : st.noise_level_tolerance();
  std::vector<std::vector<pb::Measurement>> per_axis(axes.size());
  for (const pb::AxisKind kind : {pb::GYRO, pb::ACCEL}) {
    const auto not_scanned = [&](size_t a, const std::string& why) {
      pb::Measurement m = NewMeasurement(axes[a].axis.name, std::string(kStationarityEvents),
                                         allan::kNaN, "1", "not scanned: " + why);
      m.set_qualifier(pb::NOT_MEASURABLE);
      m.set_uncertainty_method("none: a count");
      per_axis[a].push_back(std::move(m));
    };
    // The group: the axes of this kind with data in enough bins (an axis
    // missing most of its record is left out, not let to blind the joint
    // test of the others).
    std::vector<size_t> group;
    std::string left_out;
    for (size_t a = 0; a < axes.size(); ++a) {
      if (axes[a].axis.kind != kind) continue;
      const auto& bm = axes[a].bin_means;
      const int present = allan::BinsWithData(bm);
      if (!bm.empty() && present < options.min_bins && present < static_cast<int>(bm.size())) {
        const std::string why = "data in " + std::to_string(present) + " of its " +
                                std::to_string(bm.size()) + " bins (" +
                                std::to_string(options.min_bins) + " needed)";
        not_scanned(a, why);
        left_out += (left_out.empty() ? "" : "; ") + axes[a].axis.name + ": " + why;
        continue;
      }
      group.push_back(a);
    }
    if (group.empty()) continue;
    const auto not_measurable = [&](const std::string& why) {
      for (size_t a : group) not_scanned(a, why);
    };
    const pb::ReferenceNoiseModel* reference = ReferenceModelFor(plan, kind);
    std::vector<allan::CompositeModel> models;
    std::string failed;
    for (size_t a : group) {
      if (reference != nullptr) {
        models.push_back(ReferenceModel(*reference));
        continue;
      }
      if (axes[a].curve == nullptr) {
        failed = "no Allan curve of axis " + axes[a].axis.name + " to fit a model to";
        break;
      }
      auto fit = allan::FitModelForScan(*axes[a].curve);
      if (!fit.ok()) {
        failed = "no noise model of axis " + axes[a].axis.name + ": " + fit.status().message();
        break;
      }
      models.push_back(*fit);
    }
    if (!failed.empty()) {
      not_measurable(failed);
      continue;
    }
    std::vector<std::vector<double>> means;
    for (size_t a : group) means.push_back(axes[a].bin_means);
    auto scan = allan::ScanBinMeans(means, models, tau0_s, bin_s, options);
    if (!scan.ok()) {
      not_measurable(scan.status().message());
      continue;
    }
    if (!scan->scanned) {
      not_measurable(scan->note);
      continue;
    }
    // Whether each axis's curve lies above the reference (once per axis).
    std::vector<Envelope> envelopes(group.size());
    if (reference != nullptr) {
      for (size_t i = 0; i < group.size(); ++i) {
        envelopes[i] = EnvelopeCheck(axes[group[i]].curve, models[i], scan->bin_s);
      }
    }
    // What the scan was, the same for every axis of the group but the model.
    const auto scan_text = [&](size_t i) {
      std::string t =
          std::to_string(scan->bins) + " bins of " + Fmt("%.4g", scan->bin_s) + " s against ";
      if (reference != nullptr) {
        t += "the plan's reference model " + models[i].Name() + " (" + reference->source() + ")";
      } else {
        t += "the model fitted to this record, " + models[i].Name() +
             " (the adequate candidate with the most wander; a record's own model can explain "
             "a step away or read its wander as one, so the false-alarm level is not held)";
      }
      t += ", false-alarm level " + Fmt("%g", scan->false_alarm) + " per run for the " +
           KindWord(kind) + " axes together" +
           (left_out.empty() ? "" : " (left out, " + left_out + ")") + " (threshold p " +
           Fmt("%.2g", scan->threshold_p) + ", calibrated on records drawn from the model)";
      return t + envelopes[i].text;
    };
    for (size_t i = 0; i < group.size(); ++i) {
      const size_t a = group[i];
      const AxisDesc& axis = axes[a].axis;
      std::vector<std::string> texts;
      std::vector<pb::Measurement> details;
      for (const allan::StationarityEvent& e : scan->events) {
        const allan::EventAxis& ea = e.axes[i];
        if (!ea.named) continue;
        if (cuts != nullptr) (*cuts)[a].push_back(allan::EventCut(e, ea, scan->bin_s));
        const int k = static_cast<int>(texts.size()) + 1;
        texts.push_back(EventText(e, ea, kind));
        const std::string name = std::string(kEventPrefix) + std::to_string(k);
        std::string with;
        if (e.joint) {
          for (size_t j = 0; j < group.size(); ++j) {
            if (j != i && e.axes[j].named)
              with += (with.empty() ? "" : ", ") + axes[group[j]].axis.name;
          }
        }
        pb::Measurement size =
            NewMeasurement(axis.name, name, ToBiasUnit(ea.size, kind), BiasUnit(kind),
                           texts.back() + " from the end of the warm-up (z " + Fmt("%.2g", ea.z) +
                               " at detection; p " + Fmt("%.2g", e.p_adjusted) +
                               " over every candidate of the scan)" +
                               (e.joint ? "; found on the " + KindWord(kind) + " axes together" +
                                              (with.empty() ? "" : ", also on " + with)
                                        : ""));
        size.set_uncertainty(ToBiasUnit(ea.sigma, kind));
        size.set_uncertainty_method(
            "GLS under the scan's noise model " + models[i].Name() +
            ", jointly with the axis's other events (size: after - before)");
        details.push_back(std::move(size));
        const bool in_gap = std::isfinite(ea.gap_from_s);
        pb::Measurement time = NewMeasurement(
            axis.name, name + "_time", in_gap ? ea.gap_from_s : e.time_s, "s",
            (in_gap ? "the start of the missing stretch the step fell in (it ends at " +
                          Fmt("%.0f", ea.gap_to_s) + " s)"
             : e.kind == allan::EventKind::kStep
                 ? std::string("the step's bin boundary, or the middle of the bin holding it")
                 : std::string("the burst's start")) +
                ", s from the end of the warm-up");
        time.set_uncertainty_method(
            in_gap ? "none: anywhere in the missing stretch, " + Fmt("%.0f", ea.gap_from_s) +
                         " to " + Fmt("%.0f", ea.gap_to_s) + " s"
                   : "none: a bin boundary or middle (the scan resolves time to half its bins "
                     "of " +
                         Fmt("%.4g", scan->bin_s) + " s)");
        details.push_back(std::move(time));
        if (e.kind == allan::EventKind::kBurst) {
          pb::Measurement end = NewMeasurement(axis.name, name + "_end", e.time_s + e.window_s, "s",
                                               "the burst's end, s from the end of the warm-up");
          end.set_uncertainty_method(details.back().uncertainty_method());
          details.push_back(std::move(end));
        }
      }
      // The axis's noise level (no model needed; the level split over the
      // group's axes).
      std::string noise_text;
      if (noise_tolerance >= 0 && !axes[a].mean_square.empty()) {
        const double level = scan->false_alarm / static_cast<double>(group.size());
        auto noise =
            allan::ScanNoiseLevel(axes[a].mean_square, scan->bin_s, level, noise_tolerance);
        if (!noise.ok()) {
          noise_text = "; noise level not scanned: " + noise.status().message();
        } else if (!noise->scanned) {
          noise_text = "; noise level not scanned: " + noise->note;
        } else {
          noise_text =
              "; noise level (the mean square difference of successive samples per "
              "bin, CUSUM of its logarithm over " +
              std::to_string(noise->bins) + " bins): p " + Fmt("%.2g", noise->p) + " at a level " +
              Fmt("%.2g", level) + ", the largest change x" + Fmt("%.4g", noise->ratio) +
              " \u00b1 " + Fmt("%.2g", noise->ratio_sigma) + " at " + Fmt("%.0f", noise->time_s) +
              " s, an event beyond x" + Fmt("%.4g", 1 + noise_tolerance) + " either way" +
              (noise->note.empty() ? "" : " (" + noise->note + ")");
          if (noise->found()) {
            if (cuts != nullptr) {
              (*cuts)[a].emplace_back(noise->time_s - scan->bin_s, noise->time_s + scan->bin_s);
            }
            const int k = static_cast<int>(texts.size()) + 1;
            texts.push_back("noise level x" + Fmt("%.4g", noise->ratio) + " \u00b1 " +
                            Fmt("%.2g", noise->ratio_sigma) + " from " +
                            Fmt("%.0f", noise->time_s) + " s");
            const std::string name = std::string(kEventPrefix) + std::to_string(k);
            pb::Measurement size = NewMeasurement(
                axis.name, name, noise->ratio, std::string(kNoiseLevelRatioUnit),
                texts.back() + " from the end of the warm-up: the short-tau noise amplitude " +
                    "after over before (p " + Fmt("%.2g", noise->p) + ")");
            size.set_uncertainty(noise->ratio_sigma);
            size.set_uncertainty_method(
                "the bins' log mean squares' spread from their successive differences, over the "
                "bins before and after");
            details.push_back(std::move(size));
            pb::Measurement time = NewMeasurement(
                axis.name, name + "_time", noise->time_s, "s",
                "the noise level's change: the bin boundary of the largest CUSUM, s from the end "
                "of the warm-up (a gradual drift reads as one change near its middle)");
            time.set_uncertainty_method("none: a bin boundary");
            details.push_back(std::move(time));
          }
        }
      }
      std::string summary = texts.empty() ? "no level step, burst or noise level change found"
                                          : std::to_string(texts.size()) +
                                                (texts.size() == 1 ? " event: " : " events: ");
      for (size_t t = 0; t < texts.size(); ++t) summary += (t ? "; " : "") + texts[t];
      if (!texts.empty() && envelopes[i].above) {
        summary +=
            " (the axis's curve lies above the reference: events raise it, but noise above the "
            "reference may also read as events)";
      }
      pb::Measurement count = NewMeasurement(axis.name, std::string(kStationarityEvents),
                                             static_cast<double>(texts.size()), "1",
                                             summary + kScanSeparator + scan_text(i) + noise_text);
      count.set_uncertainty_method("none: a count");
      per_axis[a].push_back(std::move(count));
      for (pb::Measurement& d : details) per_axis[a].push_back(std::move(d));
    }
  }
  for (auto& list : per_axis) {
    for (pb::Measurement& m : list) out.push_back(std::move(m));
  }
  return out;
}

}  // namespace imuqual::judge
