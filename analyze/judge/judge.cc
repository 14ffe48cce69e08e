#include "analyze/judge/judge.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
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

std::string Reason(const pb::Measurement& m) {
  const std::string who = (m.axis().empty() ? "" : m.axis() + ": ") + m.name();
  const std::string unit = m.unit() == "1" ? "" : " " + m.unit();
  if (std::isnan(m.value())) {
    if (m.note().starts_with("not measurable")) return who + " " + m.note();
    return who + " not measured" + (m.note().empty() ? "" : " (" + m.note() + ")");
  }
  const std::string v = who + " " + Num(m.value()) + unit +
                        (m.note().starts_with("upper bound") ? " (upper bound)" : "");
  if (m.outcome() == pb::FAIL) {
    if (m.has_low() && m.value() < m.low()) return v + " below low limit " + Num(m.low()) + unit;
    return v + " above high limit " + Num(m.high()) + unit;
  }
  if (m.has_marginal_low() && m.value() < m.marginal_low()) {
    return v + " marginal (below " + Num(m.marginal_low()) + unit + ")";
  }
  return v + " marginal (above " + Num(m.marginal_high()) + unit + ")";
}

}  // namespace

const char* OutcomeName(pb::Outcome outcome) {
  switch (outcome) {
    case pb::PASS:
      return "PASS";
    case pb::MARGINAL:
      return "MARGINAL";
    case pb::FAIL:
      return "FAIL";
    default:
      return "-";
  }
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
  for (const pb::Limit& limit : effective.limits()) {
    const MeasurementDef* def = FindMeasurement(limit.measurement());
    if (def == nullptr) continue;  // ValidatePlan rejects these
    if (def->run_level) {
      if (!has("", limit.measurement())) {
        pb::Measurement m;
        m.set_name(limit.measurement());
        m.set_value(std::nan(""));
        m.set_unit(std::string(def->gyro_unit));
        m.set_note("no value was produced");
        measurements->push_back(m);
      }
      continue;
    }
    for (const AxisDesc& axis : axes) {
      if (Specificity(limit, &axis) < 0 || UnitFor(*def, axis.kind).empty()) continue;
      if (!has(axis.name, limit.measurement())) {
        pb::Measurement m;
        m.set_axis(axis.name);
        m.set_name(limit.measurement());
        m.set_value(std::nan(""));
        m.set_unit(std::string(UnitFor(*def, axis.kind)));
        m.set_note("no value was produced");
        measurements->push_back(m);
      }
    }
  }

  Judgement j;
  bool any_judged = false, any_fail = false, any_marginal = false;
  for (pb::Measurement& m : *measurements) {
    const AxisDesc* axis = m.axis().empty() ? nullptr : FindAxis(axes, m.axis());
    const pb::Limit* limit = FindLimit(effective, m.name(), axis);
    if (limit == nullptr || (!m.axis().empty() && axis == nullptr)) {
      m.set_outcome(pb::OUTCOME_UNSET);
      continue;
    }
    CopyLimits(*limit, &m);
    m.set_outcome(Evaluate(*limit, m.value()));
    if (m.model_inadequate() && std::isnan(m.value())) {
      // Withheld because the noise model does not fit: the plan says what
      // that means.
      m.set_outcome(plan.on_inadequate_model() == pb::TestPlan::INADEQUATE_FAIL ? pb::FAIL
                                                                                : pb::MARGINAL);
    }
    any_judged = true;
    if (m.outcome() == pb::FAIL) any_fail = true;
    if (m.outcome() == pb::MARGINAL) any_marginal = true;
    if (m.outcome() == pb::FAIL || m.outcome() == pb::MARGINAL) j.reasons.push_back(Reason(m));
  }
  j.verdict = !any_judged    ? pb::OUTCOME_UNSET
              : any_fail     ? pb::FAIL
              : any_marginal ? pb::MARGINAL
                             : pb::PASS;
  return j;
}

}  // namespace imuqual::judge
