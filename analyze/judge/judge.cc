#include "analyze/judge/judge.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>

#include "analyze/judge/measurements.h"
#include "analyze/judge/stationarity_measure.h"

namespace imuqual::judge {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// Where the axis was judged: its judged_segment's note up to its first comma
// ("the stretch 0-1192 s of the 2400 s record"), or "the whole record".
std::string JudgedSegmentText(const std::vector<pb::Measurement>& ms, const std::string& axis) {
  for (const pb::Measurement& m : ms) {
    if (m.axis() == axis && m.name() == kJudgedSegment) return JudgedStretchText(m);
  }
  return std::string(kWholeRecordNote);
}

const AxisDesc* FindAxis(const std::vector<AxisDesc>& axes, const std::string& name) {
  for (const AxisDesc& a : axes) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

// 2: names the axis, 1: names its kind, 0: applies to all, -1: does not apply.
int Specificity(const pb::Limit& limit, const AxisDesc* axis) {
  if (axis == nullptr) return limit.axes_size() == 0 ? 0 : -1;
  if (limit.axes_size() > 0) {
    return std::find(limit.axes().begin(), limit.axes().end(), axis->name) != limit.axes().end()
               ? 2
               : -1;
  }
  if (limit.axis_kind() == pb::AXIS_KIND_UNSPECIFIED) return 0;
  return limit.axis_kind() == axis->kind ? 1 : -1;
}

void CopyLimits(const pb::Limit& limit, pb::Measurement* m) {
  if (limit.has_low()) m->set_low(limit.low());
  if (limit.has_high()) m->set_high(limit.high());
  if (limit.has_marginal_low()) m->set_marginal_low(limit.marginal_low());
  if (limit.has_marginal_high()) m->set_marginal_high(limit.marginal_high());
}

bool Guarded(pb::Limit::DecisionRule rule) {
  return rule == pb::Limit::GUARDED || rule == pb::Limit::GUARDED_ACCEPTANCE ||
         rule == pb::Limit::GUARDED_REJECTION;
}

// What one bound (low or high) says of a value.
enum class Side { kInside, kInconclusive, kOutside };

// `outside`: how far the value lies beyond the bound (negative: inside);
// `w`: the guard band's half-width (0: none).
Side AtBound(pb::Limit::DecisionRule rule, double outside, double w) {
  switch (rule) {
    case pb::Limit::GUARDED:
      if (std::abs(outside) < w) return Side::kInconclusive;
      break;
    case pb::Limit::GUARDED_ACCEPTANCE:
      if (outside > 0) return Side::kOutside;
      return -outside >= w ? Side::kInside : Side::kInconclusive;
    case pb::Limit::GUARDED_REJECTION:
      if (outside <= 0) return Side::kInside;
      return outside >= w ? Side::kOutside : Side::kInconclusive;
    default:
      break;
  }
  return outside > 0 ? Side::kOutside : Side::kInside;
}

// The outcome of one judged measurement and, unless PASS, why.
struct Decision {
  pb::Outcome outcome = pb::PASS;
  std::string reason;
};

std::string Who(const pb::Measurement& m) {
  return (m.axis().empty() ? "" : m.axis() + ": ") + m.name();
}

std::string UnitSuffix(const pb::Measurement& m) { return m.unit() == "1" ? "" : " " + m.unit(); }

// A value the truth lies at or below: an upper bound, or a curve minimum at
// the curve's last point (the true minimum may lie lower, and later: so its
// tau is not one).
bool IsUpperBound(const pb::Measurement& m) {
  return m.qualifier() == pb::UPPER_BOUND ||
         (m.qualifier() == pb::MINIMUM_NOT_RESOLVED && m.name() != kTauAtMinimum);
}

}  // namespace

bool GuardedOnLogScale(const pb::Measurement& m) {
  return m.name() == kTauAtMinimum && m.value() > 0;
}

double SigmasAbove(const pb::Measurement& m, double bound) {
  const double v = m.value(), u = m.has_uncertainty() ? m.uncertainty() : NAN;
  if (!(u > 0) || !std::isfinite(u)) return NAN;
  if (GuardedOnLogScale(m)) return (bound > 0 ? std::log(v / bound) : INFINITY) / (u / v);
  return (v - bound) / u;
}

namespace {

// Applies `limit` under `rule` with guard band `w` (0: none) to the
// measurement's finite value. A measurement guarded on the log scale
// (GuardedOnLogScale) is compared as ln v against ln b with the band w / v.
Decision DecideValue(const pb::Limit& limit, pb::Limit::DecisionRule rule, double w,
                     const pb::Measurement& m) {
  const double v = m.value();
  const std::string unit = UnitSuffix(m);
  const bool bound = IsUpperBound(m);
  const bool with_u = w > 0 && m.has_uncertainty();
  const bool log_scale = GuardedOnLogScale(m) && w > 0;
  const std::string shown =
      Who(m) + " " + Num(v) + (with_u ? " ± " + Num(m.uncertainty()) : "") + unit +
      (m.qualifier() == pb::UPPER_BOUND            ? " (upper bound)"
       : m.qualifier() == pb::MINIMUM_NOT_RESOLVED ? " (minimum not resolved)"
                                                   : "");
  const std::string rule_name = DecisionRuleName(rule);
  // The band as applied: [v / f, v f] with f = exp(w / v) on the log scale.
  const std::string band_text = log_scale ? "w = " + Num(w) + unit +
                                                ", on ln: " + Num(v * std::exp(-w / v)) + "-" +
                                                Num(v * std::exp(w / v)) + unit
                                          : "w = " + Num(w);
  const std::string band = w > 0 ? " (" + band_text + ", " + rule_name + ")" : "";

  Decision d;
  auto at = [&](bool high) {
    if (!(high ? limit.has_high() : limit.has_low())) return Side::kInside;
    const double b = high ? limit.high() : limit.low();
    if (!bound && log_scale) {
      // ln v - ln b; a bound at or below 0 lies below every positive value.
      const double above = b > 0 ? std::log(v / b) : INFINITY;
      return AtBound(rule, high ? above : -above, w / v);
    }
    if (!bound) return AtBound(rule, high ? v - b : b - v, w);
    // An upper bound: the truth lies at or below it.
    if (high && v <= b) return Side::kInside;   // conforms, whatever the band
    if (!high && v < b) return Side::kOutside;  // lies lower still
    return Guarded(rule) ? Side::kInconclusive : high ? Side::kOutside : Side::kInside;
  };
  const Side sides[2] = {at(false), at(true)};
  const char* names[2] = {"low", "high"};
  const double bounds[2] = {limit.low(), limit.high()};
  // A FAIL at either bound first, then an inconclusive one.
  for (int i = 0; i < 2; ++i) {
    if (sides[i] != Side::kOutside) continue;
    d.outcome = pb::FAIL;
    d.reason = shown + (i == 0 ? " below " : " above ") + names[i] + " limit " + Num(bounds[i]) +
               unit + band;
    return d;
  }
  for (int i = 0; i < 2; ++i) {
    if (sides[i] != Side::kInconclusive) continue;
    d.outcome = pb::INCONCLUSIVE;
    if (bound) {
      d.reason = shown + ": only an upper bound, " + (i == 0 ? "not shown above" : "above") +
                 " the " + names[i] + " limit " + Num(bounds[i]) + unit + ": inconclusive (" +
                 rule_name + ")";
    } else {
      d.reason = shown + " within the guard band (" + band_text + ") of the " + names[i] +
                 " limit " + Num(bounds[i]) + unit + ": inconclusive (" + rule_name + ")";
    }
    return d;
  }
  // Marginal limits are always simple.
  if (limit.has_marginal_low() && v < limit.marginal_low()) {
    d.outcome = pb::MARGINAL;
    d.reason = shown + " marginal (below " + Num(limit.marginal_low()) + unit + ")";
  } else if (limit.has_marginal_high() && v > limit.marginal_high()) {
    d.outcome = pb::MARGINAL;
    d.reason = shown + " marginal (above " + Num(limit.marginal_high()) + unit + ")";
  }
  return d;
}

constexpr const char* kNoUncertainty = "no uncertainty: simple acceptance";

}  // namespace

const char* OutcomeName(pb::Outcome outcome) {
  switch (outcome) {
    case pb::PASS:
      return "PASS";
    case pb::MARGINAL:
      return "MARGINAL";
    case pb::FAIL:
      return "FAIL";
    case pb::INCONCLUSIVE:
      return "INCONCLUSIVE";
    case pb::ABORTED:
      return "ABORTED";
    case pb::ERROR:
      return "ERROR";
    default:
      return "-";
  }
}

const char* DecisionRuleName(pb::Limit::DecisionRule rule) {
  switch (rule) {
    case pb::Limit::SIMPLE:
      return "simple";
    case pb::Limit::GUARDED:
      return "guarded";
    case pb::Limit::GUARDED_ACCEPTANCE:
      return "guarded acceptance";
    case pb::Limit::GUARDED_REJECTION:
      return "guarded rejection";
    default:
      return "default";
  }
}

pb::Limit::DecisionRule ResolvedRule(const pb::TestPlan& plan, const pb::Limit& limit) {
  if (limit.decision_rule() != pb::Limit::RULE_DEFAULT) return limit.decision_rule();
  if (plan.default_decision_rule() != pb::Limit::RULE_DEFAULT) return plan.default_decision_rule();
  return pb::Limit::SIMPLE;
}

double ResolvedGuardK(const pb::TestPlan& plan, const pb::Limit& limit) {
  if (limit.has_guard_k()) return limit.guard_k();
  if (plan.has_default_guard_k()) return plan.default_guard_k();
  return kDefaultGuardK;
}

pb::Outcome Evaluate(const pb::Limit& limit, double value) {
  if (std::isnan(value)) return pb::FAIL;
  if ((limit.has_low() && value < limit.low()) || (limit.has_high() && value > limit.high())) {
    return pb::FAIL;
  }
  if ((limit.has_marginal_low() && value < limit.marginal_low()) ||
      (limit.has_marginal_high() && value > limit.marginal_high())) {
    return pb::MARGINAL;
  }
  return pb::PASS;
}

const pb::Limit* FindLimit(const pb::TestPlan& plan, const std::string& name,
                           const AxisDesc* axis) {
  const pb::Limit* best = nullptr;
  int best_rank = -1;
  for (const pb::Limit& limit : plan.limits()) {
    if (limit.measurement() != name) continue;
    const int rank = Specificity(limit, axis);
    if (rank > best_rank) {
      best = &limit;
      best_rank = rank;
    }
  }
  return best;
}

void JudgeMeasurement(const pb::TestPlan& plan, const pb::Limit& limit, pb::Measurement* m,
                      std::string* reason) {
  CopyLimits(limit, m);
  m->clear_guard_band();
  pb::Limit::DecisionRule rule = ResolvedRule(plan, limit);
  Decision d;
  if (std::isnan(m->value())) {
    // Nothing to compare: the rule does not enter.
    m->set_decision_rule(pb::Limit::SIMPLE);
    d.outcome = pb::FAIL;
    if (m->model_inadequate()) {
      // Withheld because the noise model does not fit: the plan says what
      // that means, and the note ("not measurable: noise model inadequate
      // (...)") is the reason.
      d.outcome =
          plan.on_inadequate_model() == pb::TestPlan::INADEQUATE_FAIL ? pb::FAIL : pb::MARGINAL;
      d.reason = Who(*m) + " " + m->note();
    } else {
      d.reason = Who(*m) + " not measured" + (m->note().empty() ? "" : " (" + m->note() + ")");
    }
  } else {
    double w = 0;
    bool for_lack_of_u = false;
    const bool has_u =
        m->has_uncertainty() && std::isfinite(m->uncertainty()) && m->uncertainty() >= 0;
    // A guard band only where there is a bound to guard (a limit of marginal
    // bounds only is judged simply) and a value that is not a bound.
    const bool bounded = limit.has_low() || limit.has_high();
    if (!bounded) rule = pb::Limit::SIMPLE;
    if (Guarded(rule) && !IsUpperBound(*m)) {
      if (!has_u) {
        // No uncertainty to guard with: said, not pretended.
        rule = pb::Limit::SIMPLE;
        for_lack_of_u = true;
        if (!m->note().ends_with(kNoUncertainty)) {
          m->set_note(m->note().empty() ? kNoUncertainty : m->note() + "; " + kNoUncertainty);
        }
      } else {
        w = ResolvedGuardK(plan, limit) * m->uncertainty();
      }
    }
    m->set_decision_rule(rule);
    // The band used, 0 included (a zero uncertainty): absent only when none.
    if (Guarded(rule) && !IsUpperBound(*m)) m->set_guard_band(w);
    d = DecideValue(limit, rule, w, *m);
    if (d.outcome != pb::PASS && for_lack_of_u) {
      d.reason += std::string(" (") + kNoUncertainty + ")";
    }
  }
  m->set_outcome(d.outcome);
  if (reason != nullptr) *reason = d.outcome == pb::PASS ? "" : d.reason;
}

Judgement Judge(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                std::vector<pb::Measurement>* measurements) {
  // Implicit limit from the plan's minimum duration.
  pb::TestPlan effective = plan;
  if (plan.min_duration_s() > 0 && FindLimit(plan, std::string(kDuration), nullptr) == nullptr) {
    pb::Limit* dur = effective.add_limits();
    dur->set_measurement(std::string(kDuration));
    dur->set_low(plan.min_duration_s());
    dur->set_unit("s");
  }

  // Every applicable limit must meet a measurement; missing ones are FAILs.
  auto has = [&](const std::string& axis, const std::string& name) {
    return std::any_of(measurements->begin(), measurements->end(), [&](const pb::Measurement& m) {
      return m.axis() == axis && m.name() == name;
    });
  };
  auto missing = [](const std::string& axis, const std::string& name, std::string_view unit) {
    pb::Measurement m = NewMeasurement(axis, name, std::nan(""), unit, "no value was produced");
    m.set_qualifier(pb::NOT_MEASURABLE);
    m.set_uncertainty_method("none: not measured");
    return m;
  };
  for (const pb::Limit& limit : effective.limits()) {
    const MeasurementDef* def = FindMeasurement(limit.measurement());
    if (def == nullptr) continue;  // ValidatePlan rejects these
    if (def->run_level) {
      if (!has("", limit.measurement())) {
        measurements->push_back(missing("", limit.measurement(), def->gyro_unit));
      }
      continue;
    }
    for (const AxisDesc& axis : axes) {
      if (Specificity(limit, &axis) < 0 || UnitFor(*def, axis.kind).empty()) continue;
      if (!has(axis.name, limit.measurement())) {
        measurements->push_back(missing(axis.name, limit.measurement(), UnitFor(*def, axis.kind)));
      }
    }
  }

  Judgement j;
  std::vector<std::string> qualifier_reasons;  // after the judged ones
  for (pb::Measurement& m : *measurements) {
    const AxisDesc* axis = m.axis().empty() ? nullptr : FindAxis(axes, m.axis());
    const pb::Limit* limit = FindLimit(effective, m.name(), axis);
    if (limit == nullptr && axis != nullptr && m.name() == kStationarityEvents &&
        plan.has_stationarity()) {
      // No limit on the count: the plan's on_event judges it, and every
      // event is named in the reasons whatever it does to the verdict.
      const pb::Outcome o = StationarityOutcome(plan, m.value());
      m.set_outcome(o);
      m.set_decision_rule(pb::Limit::RULE_DEFAULT);
      m.clear_guard_band();
      const std::string what = m.axis() + ": stationarity: " + StationarityEventSummary(m);
      const std::string action = pb::Stationarity::OnEvent_Name(plan.stationarity().on_event());
      if (o != pb::OUTCOME_UNSET && o != pb::PASS) {
        j.reasons.push_back(what + " (the plan's on_event: " + action + ")");
      } else if (o == pb::OUTCOME_UNSET && m.value() > 0) {
        qualifier_reasons.push_back(
            what + " (" + action + ": the verdict is the limits'" +
            (plan.stationarity().on_event() == pb::Stationarity::JUDGE_LONGEST_SEGMENT
                 ? " on " + JudgedSegmentText(*measurements, m.axis())
                 : std::string()) +
            ")");
      }
      continue;
    }
    if (limit == nullptr && axis != nullptr && m.name() == kJudgedSegment) {
      // No limit on the stretch: where events cut the record, its data at
      // least the plan's minimum duration (and some), else the unit is not
      // judged (a retest), never failed for its events. The whole record is
      // the duration limit's to judge.
      const double need = plan.min_duration_s();
      const bool enough =
          JudgedWholeRecord(m) || (std::isfinite(m.value()) && m.value() > 0 && m.value() >= need);
      m.set_outcome(enough ? pb::PASS : pb::INCONCLUSIVE);
      m.set_decision_rule(pb::Limit::RULE_DEFAULT);
      m.clear_guard_band();
      if (!enough) {
        j.reasons.push_back(m.axis() + ": the stretch without a found event holds " +
                            Num(m.value()) + " s of data, " +
                            (m.value() > 0
                                 ? "less than the plan's " + Num(need) + " s (min_duration_s)"
                                 : std::string("none to judge")) +
                            ": not judged, retest");
      }
      continue;
    }
    if (limit == nullptr || (!m.axis().empty() && axis == nullptr)) {
      m.set_outcome(pb::OUTCOME_UNSET);
      m.set_decision_rule(pb::Limit::RULE_DEFAULT);
      m.clear_guard_band();
      continue;
    }
    std::string reason;
    JudgeMeasurement(effective, *limit, &m, &reason);
    if (!reason.empty()) j.reasons.push_back(reason);
  }
  j.verdict = VerdictOf(*measurements);
  for (std::string& r : qualifier_reasons) j.reasons.push_back(std::move(r));
  return j;
}

Judgement JudgeInterim(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                       std::vector<pb::Measurement>* measurements) {
  const Judgement judged = Judge(plan, axes, measurements);
  Judgement out;
  size_t next_reason = 0;
  for (pb::Measurement& m : *measurements) {
    const pb::Outcome o = m.outcome();
    if (o == pb::OUTCOME_UNSET) continue;
    std::string reason = o != pb::PASS && next_reason < judged.reasons.size()
                             ? judged.reasons[next_reason++]
                             : std::string();
    const double v = m.value(), u = m.has_uncertainty() ? m.uncertainty() : std::nan("");
    const AxisDesc* axis = m.axis().empty() ? nullptr : FindAxis(axes, m.axis());
    const pb::Limit* limit = FindLimit(plan, m.name(), axis);
    std::string pending;
    if (std::isfinite(v) && m.qualifier() == pb::MINIMUM_NOT_RESOLVED && o != pb::PASS) {
      pending = "the curve's minimum is its last point so far, not resolved yet";
    } else if (std::isfinite(v) && std::isfinite(u) && u > 0 && limit != nullptr &&
               !IsUpperBound(m)) {
      const double w = ResolvedGuardK(plan, *limit) * u;
      for (const auto& [has, bound, side] :
           {std::tuple{limit->has_low(), limit->low(), "low"},
            std::tuple{limit->has_high(), limit->high(), "high"}}) {
        if (has && std::abs(v - bound) < w && pending.empty()) {
          pending = "within " + Num(ResolvedGuardK(plan, *limit)) + " u of the " + side +
                    " limit " + Num(bound) + UnitSuffix(m);
        }
      }
    }
    if (!pending.empty()) {
      m.set_outcome(pb::INCONCLUSIVE);
      reason = "pending: " + Who(m) + " " + Num(v) +
               (std::isfinite(u) ? " ± " + Num(u) : std::string()) + UnitSuffix(m) + ", " +
               pending;
    }
    if (m.outcome() != pb::PASS) out.reasons.push_back(reason);
  }
  out.verdict = VerdictOf(*measurements);
  return out;
}

pb::Outcome VerdictOf(const std::vector<pb::Measurement>& measurements) {
  bool any = false, fail = false, inconclusive = false, marginal = false;
  for (const pb::Measurement& m : measurements) {
    const pb::Outcome o = m.outcome();
    if (o == pb::OUTCOME_UNSET) continue;
    any = true;
    fail |= o == pb::FAIL;
    inconclusive |= o == pb::INCONCLUSIVE;
    marginal |= o == pb::MARGINAL;
  }
  return !any           ? pb::OUTCOME_UNSET
         : fail         ? pb::FAIL
         : inconclusive ? pb::INCONCLUSIVE
         : marginal     ? pb::MARGINAL
                        : pb::PASS;
}

}  // namespace imuqual::judge
