#include "analyze/judge/plan.h"

#include <google/protobuf/util/message_differencer.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "analyze/allan/stationarity.h"
#include "analyze/allan/units.h"
#include "analyze/judge/builtin_plans.h"
#include "analyze/judge/early_decision.h"
#include "analyze/judge/measurements.h"
#include "common/strings.h"
#include "proto/text_proto.h"

namespace imuqual::judge {
namespace {

// Maps a top-level field (and index) to its line in the source text, if the
// plan came from text.
// `sub` optionally names a field inside the index-th message of `field`.
using Locator = std::function<int(const char* field, int index, const char* sub)>;

bool Finite(double v) { return std::isfinite(v); }

Status Fail(const Locator& where, const char* field, int index, const std::string& path,
            const std::string& problem, const char* sub = nullptr) {
  const int line = where ? where(field, index, sub) : -1;
  std::string prefix = line > 0 ? std::to_string(line) + ": " : std::string();
  return Status::InvalidArgument(prefix + path + ": " + problem);
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// The first problem of limit i (each limit's checks build on the ones before).
Status ValidateLimit(const pb::TestPlan& plan, int i, const Locator& where) {
  std::map<std::string, pb::AxisKind> axis_kinds;
  for (const pb::Axis& a : plan.axes()) axis_kinds[a.name()] = a.kind();
  {
    const pb::Limit& lim = plan.limits(i);
    const std::string path = "limits[" + std::to_string(i) + "]";
    // `sub` is ".field" or "" (the whole limit).
    auto fail = [&](const std::string& sub, const std::string& problem) {
      return Fail(where, "limits", i, path + sub, problem, sub.empty() ? nullptr : sub.c_str() + 1);
    };
    const MeasurementDef* def = FindMeasurement(lim.measurement());
    if (def == nullptr) {
      std::vector<std::string> known;
      for (const MeasurementDef& d : MeasurementCatalog()) known.emplace_back(d.name);
      return fail(".measurement", "unknown measurement '" + lim.measurement() + "'" +
                                      DidYouMean(lim.measurement(), known) +
                                      " (known: " + Join(known, ", ") + ")");
    }
    for (const std::string& axis : lim.axes()) {
      if (!axis_kinds.count(axis)) {
        std::vector<std::string> names;
        for (const auto& [name, kind] : axis_kinds) names.push_back(name);
        return fail(".axes", "no axis named '" + axis + "' in the plan" + DidYouMean(axis, names));
      }
    }
    // The unit must be the measurement's unit on every axis kind it applies
    // to: the named axes' kinds, the limit's kind, or every kind.
    std::vector<pb::AxisKind> kinds;
    if (def->run_level || lim.axis_kind() != pb::AXIS_KIND_UNSPECIFIED) {
      kinds.push_back(def->run_level ? pb::GYRO : lim.axis_kind());
    } else if (lim.axes_size() > 0) {
      for (const std::string& axis : lim.axes()) {
        if (std::find(kinds.begin(), kinds.end(), axis_kinds[axis]) == kinds.end()) {
          kinds.push_back(axis_kinds[axis]);
        }
      }
    } else {
      if (!def->gyro_unit.empty()) kinds.push_back(pb::GYRO);
      if (!def->accel_unit.empty()) kinds.push_back(pb::ACCEL);
    }
    for (pb::AxisKind kind : kinds) {
      const std::string_view unit = UnitFor(*def, kind);
      const char* kind_name = kind == pb::ACCEL ? "accelerometer" : "gyro";
      if (unit.empty()) {
        return fail(".axis_kind", std::string(def->name) + " is not defined on " + kind_name +
                                      " axes");
      }
      if (lim.unit() != unit) {
        return fail(".unit", "'" + lim.unit() + "' is not the unit of " + std::string(def->name) +
                                 (def->run_level ? std::string()
                                                 : std::string(" on ") + kind_name + " axes") +
                                 " (" + std::string(unit) + ")" +
                                 (kinds.size() > 1 ? "; set axis_kind" : ""));
      }
    }
    if (!lim.has_low() && !lim.has_high()) return fail("", "needs low, high or both");
    for (auto [name, has, v] :
         {std::tuple{".low", lim.has_low(), lim.low()}, {".high", lim.has_high(), lim.high()},
          {".marginal_low", lim.has_marginal_low(), lim.marginal_low()},
          {".marginal_high", lim.has_marginal_high(), lim.marginal_high()}}) {
      if (has && !Finite(v)) return fail(name, "must be a finite number");
    }
    if (lim.has_low() && lim.has_high() && lim.low() > lim.high()) {
      return fail("", "low " + Num(lim.low()) + " is above high " + Num(lim.high()));
    }
    if (lim.has_marginal_low()) {
      if (!lim.has_low()) return fail(".marginal_low", "needs low");
      if (lim.marginal_low() < lim.low() || (lim.has_high() && lim.marginal_low() > lim.high())) {
        return fail(".marginal_low", "must lie within [low, high]");
      }
    }
    if (lim.has_marginal_high()) {
      if (!lim.has_high()) return fail(".marginal_high", "needs high");
      if (lim.marginal_high() > lim.high() || (lim.has_low() && lim.marginal_high() < lim.low())) {
        return fail(".marginal_high", "must lie within [low, high]");
      }
    }
    if (lim.has_marginal_low() && lim.has_marginal_high() &&
        lim.marginal_low() > lim.marginal_high()) {
      return fail("", "marginal_low is above marginal_high");
    }
    if (!pb::Limit::DecisionRule_IsValid(lim.decision_rule())) {
      return fail(".decision_rule", "unknown decision rule " + std::to_string(lim.decision_rule()));
    }
    if (lim.has_guard_k() && !(lim.guard_k() > 0 && Finite(lim.guard_k()))) {
      return fail(".guard_k", "must be a finite number > 0 (w = guard_k * u)");
    }
  }
  return Status::Ok();
}

Status ValidateEarlyDecision(const pb::TestPlan& plan, const Locator& where);
Status ValidateNoiseModelRange(const pb::TestPlan& plan, int i, const Locator& where,
                               std::set<int>* kinds);
Status ValidateSensorRange(const pb::TestPlan& plan, int i, const Locator& where,
                           std::set<int>* kinds);
Status ValidateStationarity(const pb::TestPlan& plan, const Locator& where);

// Every problem of the plan, each "LINE: path: problem" (or "path: problem"
// without a source), field by field (rates and durations, axes, grid, rules,
// early decisions, noise-model ranges, limits): a plan with three mistakes
// says all three at once.
std::vector<std::string> Problems(const pb::TestPlan& plan, const Locator& where) {
  std::vector<std::string> out;
  auto add = [&](const Status& st) {
    if (!st.ok()) out.push_back(st.message());
  };
  if (!(plan.nominal_rate_hz() > 0) || !Finite(plan.nominal_rate_hz())) {
    add(Fail(where, "nominal_rate_hz", -1, "nominal_rate_hz", "must be a positive rate in Hz"));
  }
  if (!(plan.min_duration_s() >= 0) || !Finite(plan.min_duration_s())) {
    add(Fail(where, "min_duration_s", -1, "min_duration_s", "must be >= 0 s"));
  }
  if (!(plan.warmup_s() >= 0) || !Finite(plan.warmup_s())) {
    add(Fail(where, "warmup_s", -1, "warmup_s", "must be >= 0 s"));
  }
  std::set<std::string> names;
  for (int i = 0; i < plan.axes_size(); ++i) {
    const pb::Axis& a = plan.axes(i);
    const std::string path = "axes[" + std::to_string(i) + "]";
    if (a.name().empty() || a.name().size() > 32 ||
        a.name().find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                   "0123456789_-") != std::string::npos) {
      add(Fail(where, "axes", i, path + ".name",
               "'" + a.name() + "' must be 1-32 letters, digits, '_' or '-'", "name"));
    } else if (!names.insert(a.name()).second) {
      add(Fail(where, "axes", i, path + ".name", "duplicate axis '" + a.name() + "'", "name"));
    }
    if (a.kind() == pb::AXIS_KIND_UNSPECIFIED) {
      add(Fail(where, "axes", i, path + ".kind", "must be GYRO or ACCEL", "kind"));
    }
  }
  const pb::TauGrid& grid = plan.grid();
  if (grid.kind() == pb::TauGrid::LOG_DENSE &&
      (grid.points_per_decade() < 1 || grid.points_per_decade() > 100)) {
    add(Fail(where, "grid", -1, "grid.points_per_decade", "must be 1..100 for LOG_DENSE"));
  }
  if (grid.kind() == pb::TauGrid::EXPLICIT) {
    if (grid.tau_s_size() == 0) add(Fail(where, "grid", -1, "grid.tau_s", "EXPLICIT needs taus"));
    if (std::any_of(grid.tau_s().begin(), grid.tau_s().end(),
                    [](double t) { return !(t > 0) || !Finite(t); })) {
      add(Fail(where, "grid", -1, "grid.tau_s", "taus must be > 0"));
    }
  }
  const std::string& stop = plan.stop_rule();
  if (!stop.empty() && stop != "bins9" && stop != "stable32" && stop != "none") {
    add(Fail(where, "stop_rule", -1, "stop_rule",
             "'" + stop + "' is not one of bins9, stable32, none" +
                 DidYouMean(stop, {"bins9", "stable32", "none"})));
  }
  if (!pb::Limit::DecisionRule_IsValid(plan.default_decision_rule())) {
    add(Fail(where, "default_decision_rule", -1, "default_decision_rule",
             "unknown decision rule " + std::to_string(plan.default_decision_rule())));
  }
  if (plan.has_default_guard_k() &&
      !(plan.default_guard_k() > 0 && Finite(plan.default_guard_k()))) {
    add(Fail(where, "default_guard_k", -1, "default_guard_k",
             "must be a finite number > 0 (w = guard_k * u)"));
  }
  add(ValidateEarlyDecision(plan, where));
  std::set<int> range_kinds;
  for (int i = 0; i < plan.noise_model_range_size(); ++i) {
    add(ValidateNoiseModelRange(plan, i, where, &range_kinds));
  }
  std::set<int> full_scale_kinds;
  for (int i = 0; i < plan.sensor_range_size(); ++i) {
    add(ValidateSensorRange(plan, i, where, &full_scale_kinds));
  }
  add(ValidateStationarity(plan, where));
  for (int i = 0; i < plan.limits_size(); ++i) add(ValidateLimit(plan, i, where));
  return out;
}

// The stationarity block's first problem.
Status ValidateStationarity(const pb::TestPlan& plan, const Locator& where) {
  const bool segments = plan.has_stationarity() &&
                        plan.stationarity().on_event() == pb::Stationarity::JUDGE_LONGEST_SEGMENT;
  for (int i = 0; i < plan.limits_size() && !segments; ++i) {
    if (plan.limits(i).measurement() == kJudgedSegment) {
      return Fail(where, "limits", i, "limits[" + std::to_string(i) + "].measurement",
                  "judged_segment needs stationarity.on_event JUDGE_LONGEST_SEGMENT (the stretch "
                  "an axis is judged on)",
                  "measurement");
    }
  }
  if (!plan.has_stationarity()) {
    for (int i = 0; i < plan.limits_size(); ++i) {
      if (plan.limits(i).measurement() == kStationarityEvents) {
        return Fail(where, "limits", i, "limits[" + std::to_string(i) + "].measurement",
                    "stationarity_events needs the plan's stationarity block (the scan that "
                    "counts them)",
                    "measurement");
      }
    }
    return Status::Ok();
  }
  const pb::Stationarity& s = plan.stationarity();
  auto bad = [&](const std::string& path, const std::string& problem) {
    return Fail(where, "stationarity", -1, "stationarity." + path, problem);
  };
  if (s.false_alarm() != 0 && !(s.false_alarm() >= 0.001 && s.false_alarm() < 0.5)) {
    return bad("false_alarm", "must be in [0.001, 0.5) (0: 0.01), got " + Num(s.false_alarm()));
  }
  if (!(s.bin_s() >= 0 && Finite(s.bin_s()))) {
    return bad("bin_s", "must be >= 0 s (0: the record's length / 300), got " + Num(s.bin_s()));
  }
  if (!pb::Stationarity::OnEvent_IsValid(s.on_event())) {
    return bad("on_event", "unknown action " + std::to_string(s.on_event()));
  }
  if (!Finite(s.noise_level_tolerance()) || s.noise_level_tolerance() > 10) {
    return bad("noise_level_tolerance",
               "must be a factor's excess of at most 10 (0: 0.05; negative: the noise level is "
               "not scanned), got " +
                   Num(s.noise_level_tolerance()));
  }
  std::set<int> kinds;
  const double nyquist = plan.nominal_rate_hz() / 2;
  for (int i = 0; i < s.reference_model_size(); ++i) {
    const pb::ReferenceNoiseModel& r = s.reference_model(i);
    const std::string path = "reference_model[" + std::to_string(i) + "]";
    if (r.axis_kind() != pb::GYRO && r.axis_kind() != pb::ACCEL) {
      return bad(path + ".axis_kind", "must be GYRO or ACCEL");
    }
    if (!kinds.insert(r.axis_kind()).second) {
      return bad(path + ".axis_kind", "a second model for " + pb::AxisKind_Name(r.axis_kind()) +
                                          " axes (one per axis kind)");
    }
    if (r.source().empty()) {
      return bad(path + ".source", "must say where the model comes from (the record quotes it)");
    }
    for (auto [name, v] : {std::pair{"quantization", r.quantization()},
                           {"random_walk", r.random_walk()},
                           {"bias_instability", r.bias_instability()},
                           {"rate_random_walk", r.rate_random_walk()},
                           {"rate_ramp", r.rate_ramp()}}) {
      if (!(v >= 0 && Finite(v))) {
        return bad(path + "." + name, "must be a finite number >= 0, got " + Num(v));
      }
    }
    for (int g = 0; g < r.gauss_markov_size(); ++g) {
      const pb::GaussMarkov& gm = r.gauss_markov(g);
      const std::string gp = path + ".gauss_markov[" + std::to_string(g) + "]";
      if (!(gm.sigma() >= 0 && Finite(gm.sigma()))) {
        return bad(gp + ".sigma", "must be a finite number >= 0, got " + Num(gm.sigma()));
      }
      if (!(gm.correlation_time_s() > 0 && Finite(gm.correlation_time_s()))) {
        return bad(gp + ".correlation_time_s",
                   "must be a finite number > 0 s, got " + Num(gm.correlation_time_s()));
      }
    }
    for (int l = 0; l < r.sinusoids_size(); ++l) {
      const pb::Sinusoid& line = r.sinusoids(l);
      const std::string lp = path + ".sinusoids[" + std::to_string(l) + "]";
      if (!(line.amplitude() >= 0 && Finite(line.amplitude()))) {
        return bad(lp + ".amplitude", "must be a finite number >= 0, got " + Num(line.amplitude()));
      }
      if (!(line.frequency_hz() > 0 && line.frequency_hz() <= nyquist)) {
        return bad(lp + ".frequency_hz", "must be in (0, " + Num(nyquist) +
                                             "] Hz (the Nyquist frequency), got " +
                                             Num(line.frequency_hz()));
      }
    }
    const bool random = r.quantization() > 0 || r.random_walk() > 0 || r.bias_instability() > 0 ||
                        r.rate_random_walk() > 0 ||
                        std::any_of(r.gauss_markov().begin(), r.gauss_markov().end(),
                                    [](const pb::GaussMarkov& g) { return g.sigma() > 0; });
    if (!random) {
      return bad(path,
                 "has no random term (quantization, random_walk, bias_instability, "
                 "rate_random_walk or gauss_markov): a scan needs noise to judge against");
    }
  }
  // A verdict on an event (on_event, or a limit on the count) needs a model
  // from outside the record for every axis kind it judges; a plan without
  // axes (its source's) may have either kind.
  const auto missing_kind = [&](pb::AxisKind only) -> std::string {
    if (plan.axes_size() == 0) {
      for (pb::AxisKind k : {pb::GYRO, pb::ACCEL}) {
        if ((only == pb::AXIS_KIND_UNSPECIFIED || only == k) && !kinds.count(k)) {
          return pb::AxisKind_Name(k) + " axes (the plan names no axes: its source may have any)";
        }
      }
    }
    for (const pb::Axis& a : plan.axes()) {
      if (a.kind() == pb::AXIS_KIND_UNSPECIFIED || kinds.count(a.kind())) continue;
      if (only != pb::AXIS_KIND_UNSPECIFIED && only != a.kind()) continue;
      return pb::AxisKind_Name(a.kind()) + " axes (axis '" + a.name() + "')";
    }
    return "";
  };
  constexpr char kWhy[] =
      ": a verdict on an event needs a model from outside the record, whose false-alarm rate "
      "holds";
  if (s.on_event() != pb::Stationarity::QUALIFIER_ONLY) {
    const std::string m = missing_kind(pb::AXIS_KIND_UNSPECIFIED);
    if (!m.empty()) {
      return bad("on_event", pb::Stationarity::OnEvent_Name(s.on_event()) +
                                 " needs a reference_model for " + m + kWhy);
    }
  }
  if (segments && plan.has_early_decision()) {
    return bad("on_event",
               "JUDGE_LONGEST_SEGMENT cannot go with early_decision: the looks judge the whole "
               "record as it grows, the segment is chosen once it has ended");
  }
  for (int i = 0; i < plan.limits_size(); ++i) {
    const pb::Limit& lim = plan.limits(i);
    if (lim.measurement() != kStationarityEvents) continue;
    const std::string m = missing_kind(lim.axis_kind());
    if (!m.empty()) {
      return Fail(
          where, "limits", i, "limits[" + std::to_string(i) + "]",
          "a limit on stationarity_events needs a stationarity.reference_model for " + m + kWhy,
          "measurement");
    }
  }
  // The scan needs at least 32 bins in the shortest record the plan judges.
  const double shortest =
      plan.has_early_decision() ? plan.early_decision().min_duration_s() : plan.min_duration_s();
  if (s.bin_s() > 0 && shortest > 0 && 32 * s.bin_s() > shortest) {
    return bad("bin_s", Num(s.bin_s()) + " s leaves fewer than the 32 bins a scan needs in " +
                            Num(shortest) + " s (the plan's shortest judged record)");
  }
  if (s.bin_s() > 0 && shortest > 0 && shortest / s.bin_s() > allan::kMaxScanBins) {
    return bad("bin_s", Num(s.bin_s()) + " s makes more than " +
                            std::to_string(allan::kMaxScanBins) + " bins of " + Num(shortest) +
                            " s: take a longer bin_s (0: the record's length / 300)");
  }
  return Status::Ok();
}

// Sensor range i's first problem; `kinds` collects the axis kinds seen.
Status ValidateSensorRange(const pb::TestPlan& plan, int i, const Locator& where,
                           std::set<int>* kinds) {
  const pb::SensorRange& r = plan.sensor_range(i);
  const std::string path = "sensor_range[" + std::to_string(i) + "]";
  if (r.axis_kind() != pb::GYRO && r.axis_kind() != pb::ACCEL) {
    return Fail(where, "sensor_range", i, path + ".axis_kind",
                "must be GYRO or ACCEL (full_scale is in deg/s for one, g for the other)",
                "axis_kind");
  }
  if (!kinds->insert(r.axis_kind()).second) {
    return Fail(
        where, "sensor_range", i, path + ".axis_kind",
        "a second range for " + pb::AxisKind_Name(r.axis_kind()) + " axes (one per axis kind)",
        "axis_kind");
  }
  if (!(r.full_scale() > 0 && Finite(r.full_scale()))) {
    return Fail(where, "sensor_range", i, path + ".full_scale",
                std::string("must be a finite number > 0 (") +
                    (r.axis_kind() == pb::GYRO ? "deg/s" : "g") + "), got " + Num(r.full_scale()),
                "full_scale");
  }
  return Status::Ok();
}

// The early-decision block's first problem.
Status ValidateEarlyDecision(const pb::TestPlan& plan, const Locator& where) {
  if (plan.has_early_decision()) {
    const pb::EarlyDecision& e = plan.early_decision();
    auto bad = [&](const char* sub, const std::string& problem) {
      return Fail(where, "early_decision", -1, std::string("early_decision.") + sub, problem, sub);
    };
    if (!(e.risk() > 0 && e.risk() <= 0.2)) return bad("risk", "must be in (0, 0.2]");
    if (!(e.min_duration_s() > 0) || !Finite(e.min_duration_s())) {
      return bad("min_duration_s", "must be > 0 s (no decision before it)");
    }
    if (e.has_look_period_s() && !(e.look_period_s() > 0 && Finite(e.look_period_s()))) {
      return bad("look_period_s", "must be > 0 s");
    }
    const double horizon = e.has_horizon_s() ? e.horizon_s() : plan.min_duration_s();
    if (!(horizon > e.min_duration_s()) || !Finite(horizon)) {
      return bad(e.has_horizon_s() ? "horizon_s" : "min_duration_s",
                 "the horizon (horizon_s, else the plan's min_duration_s, " +
                     std::to_string(horizon) + " s) must exceed early_decision.min_duration_s");
    }
    const double period = e.has_look_period_s() ? e.look_period_s() : kDefaultLookPeriodS;
    if ((horizon - e.min_duration_s()) / period >= kMaxLooks) {
      return bad(e.has_look_period_s() ? "look_period_s" : "horizon_s",
                 "more than " + std::to_string(kMaxLooks) +
                     " looks between min_duration_s and the horizon: take a longer look_period_s");
    }
  }
  return Status::Ok();
}

// Noise-model range i's first problem; `kinds` collects the axis kinds seen.
Status ValidateNoiseModelRange(const pb::TestPlan& plan, int i, const Locator& where,
                               std::set<int>* kinds) {
  {
    const pb::NoiseModelRange& r = plan.noise_model_range(i);
    const std::string path = "noise_model_range[" + std::to_string(i) + "]";
    if (!pb::AxisKind_IsValid(r.axis_kind())) {
      return Fail(where, "noise_model_range", i, path + ".axis_kind", "unknown axis kind",
                  "axis_kind");
    }
    if (!kinds->insert(r.axis_kind()).second) {
      return Fail(where, "noise_model_range", i, path + ".axis_kind",
                  "a second range for " + pb::AxisKind_Name(r.axis_kind()) +
                      " axes (one per axis kind)",
                  "axis_kind");
    }
    if (!(r.min_tau_s() >= 0 && r.min_tau_s() <= 1)) {
      return Fail(where, "noise_model_range", i, path + ".min_tau_s",
                  "must be in [0, 1] s (the figures are read at 1 s), got " + Num(r.min_tau_s()),
                  "min_tau_s");
    }
    if (r.reason().empty()) {
      return Fail(where, "noise_model_range", i, path + ".reason",
                  "must say why the short taus are not fitted (the record quotes it)", "reason");
    }
  }
  return Status::Ok();
}

}  // namespace

const pb::NoiseModelRange* NoiseModelRangeFor(const pb::TestPlan& plan, pb::AxisKind kind) {
  const pb::NoiseModelRange* any = nullptr;
  for (const pb::NoiseModelRange& r : plan.noise_model_range()) {
    if (r.axis_kind() == kind) return &r;
    if (r.axis_kind() == pb::AXIS_KIND_UNSPECIFIED) any = &r;
  }
  return any;
}

double OutOfRangeAt(const pb::TestPlan& plan, pb::AxisKind kind) {
  for (const pb::SensorRange& r : plan.sensor_range()) {
    if (r.axis_kind() != kind || kind == pb::AXIS_KIND_UNSPECIFIED) continue;
    return kind == pb::ACCEL ? r.full_scale() * allan::kStandardGravityMetersPerSecSq
                             : r.full_scale();
  }
  return std::numeric_limits<double>::infinity();
}

Status ValidatePlan(const pb::TestPlan& plan) {
  // One line (a decoded plan's problems go into a run's reasons): "; " apart.
  const std::vector<std::string> problems = Problems(plan, nullptr);
  return problems.empty() ? Status::Ok() : Status::InvalidArgument(Join(problems, "; "));
}

Result<pb::TestPlan> ParsePlanText(std::string_view text, std::string_view source_name) {
  pb::TestPlan plan;
  pb::TextProto parsed;
  const std::string src(source_name);
  IMUQUAL_RETURN_IF_ERROR(parsed.Parse(text, src, &plan));
  Locator where = [&](const char* field, int index, const char* sub) {
    return parsed.LineOf(pb::TestPlan::descriptor(), field, index, sub);
  };
  const std::vector<std::string> problems = Problems(plan, where);
  if (!problems.empty()) {
    // Every problem at once, one per line. Located ones start with the line
    // number: "src:14: ..."; others "src: ...".
    std::vector<std::string> lines;
    for (const std::string& p : problems) {
      const bool located = !p.empty() && std::isdigit(static_cast<unsigned char>(p[0]));
      lines.push_back(src + (located ? ":" : ": ") + p);
    }
    return Status::InvalidArgument(Join(lines, "\n"));
  }
  return plan;
}

std::vector<std::string> BuiltinPlanNames() {
  std::vector<std::string> names;
  for (const BuiltinPlanFile& f : BuiltinPlanFiles()) names.emplace_back(f.name);
  return names;
}

Result<pb::TestPlan> BuiltinPlan(std::string_view name) {
  for (const BuiltinPlanFile& f : BuiltinPlanFiles()) {
    if (f.name == name) return ParsePlanText(f.text, "builtin:" + std::string(name));
  }
  return Status::NotFound("no built-in plan '" + std::string(name) + "' (built in: " +
                          Join(BuiltinPlanNames(), ", ") + ")");
}

pb::TestPlan CompletedPlan(const pb::TestPlan& plan, double source_rate_hz,
                           const std::vector<pb::Axis>& source_axes) {
  pb::TestPlan completed = plan;
  if (!(completed.nominal_rate_hz() > 0)) completed.set_nominal_rate_hz(source_rate_hz);
  if (completed.axes_size() == 0) {
    for (const pb::Axis& axis : source_axes) *completed.add_axes() = axis;
  }
  return completed;
}

bool IsCompletionOf(const pb::TestPlan& announced, const pb::TestPlan& accepted) {
  const std::vector<pb::Axis> axes(announced.axes().begin(), announced.axes().end());
  return google::protobuf::util::MessageDifferencer::Equals(
      CompletedPlan(accepted, announced.nominal_rate_hz(), axes), announced);
}

std::string_view PlanStopRule(const pb::TestPlan& plan) {
  return plan.stop_rule().empty() ? std::string_view("bins9") : plan.stop_rule();
}

}  // namespace imuqual::judge
