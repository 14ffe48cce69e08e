#include "analyze/judge/early_decision.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

// A decided PASS must keep the marginal flag the full-length record would
// read with this probability (one-sided normal quantile of 0.99).
constexpr double kFlagZ = 2.3263478740408408;
// Grid of the recursive integration: points per standard deviation of the
// smallest increment between looks, and its extent in standard deviations
// of the last look.
constexpr double kPointsPerSd = 12.0;
constexpr double kGridExtentSd = 9.0;

double UpperTail(double x) { return 0.5 * std::erfc(x / std::sqrt(2.0)); }

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// Adds `text` to the measurement's note ("; " between notes).
void AppendNote(pb::Measurement& m, const std::string& text) {
  m.set_note(m.note().empty() ? text : m.note() + "; " + text);
}

// A MARGINAL measurement's note says what its flag is (FlagProvenance).
void NoteFlag(pb::Measurement& m, const std::string& provenance) {
  if (m.outcome() == pb::MARGINAL) AppendNote(m, provenance);
}

// The continuation density of S(f) (a standard Brownian motion) on a grid,
// stepped look by look: what recursive numerical integration needs.
class Recursion {
 public:
  Recursion(std::span<const double> fractions) {
    double min_sd = std::sqrt(fractions.front());
    for (size_t k = 1; k < fractions.size(); ++k) {
      min_sd = std::min(min_sd, std::sqrt(fractions[k] - fractions[k - 1]));
    }
    const double extent = kGridExtentSd * std::sqrt(fractions.back());
    const double h = min_sd / kPointsPerSd;
    const int n = static_cast<int>(std::ceil(2 * extent / h)) + 1;
    s_.resize(n);
    for (int i = 0; i < n; ++i) s_[i] = -extent + i * h;
    h_ = h;
  }

  // Probability that the process, continuing from the current density (or
  // from 0 at f = 0 when first), is at or above c after an increment of
  // variance d.
  double Crossing(double c, double d) const {
    const double sd = std::sqrt(d);
    if (g_.empty()) return UpperTail(c / sd);
    double p = 0;
    for (size_t j = 0; j < s_.size(); ++j) {
      if (g_[j] == 0) continue;
      p += Weight(j) * g_[j] * UpperTail((c - s_[j]) / sd);
    }
    return p;
  }

  // Steps the density by an increment of variance d and truncates it at c.
  void Step(double c, double d) {
    const double sd = std::sqrt(d);
    const double norm = 1.0 / (sd * std::sqrt(2 * M_PI));
    std::vector<double> next(s_.size(), 0.0);
    if (g_.empty()) {
      for (size_t i = 0; i < s_.size() && s_[i] < c; ++i) {
        next[i] = norm * std::exp(-0.5 * s_[i] * s_[i] / d);
      }
      g_ = std::move(next);
      return;
    }
    // The kernel depends on i - j only (uniform grid); beyond 10 sd it is 0.
    const int reach = static_cast<int>(std::ceil(10 * sd / h_));
    std::vector<double> kernel(2 * reach + 1);
    for (int o = -reach; o <= reach; ++o) {
      const double x = o * h_ / sd;
      kernel[o + reach] = norm * std::exp(-0.5 * x * x);
    }
    std::vector<double> weighted(s_.size());
    for (size_t j = 0; j < s_.size(); ++j) weighted[j] = Weight(j) * g_[j];
    const int n = static_cast<int>(s_.size());
    for (int i = 0; i < n && s_[i] < c; ++i) {
      const int lo = std::max(0, i - reach), hi = std::min(n - 1, i + reach);
      double v = 0;
      for (int j = lo; j <= hi; ++j) v += weighted[j] * kernel[i - j + reach];
      next[i] = v;
    }
    g_ = std::move(next);
  }

 private:
  double Weight(size_t j) const { return (j == 0 || j + 1 == s_.size()) ? 0.5 * h_ : h_; }

  std::vector<double> s_;
  std::vector<double> g_;  // empty before the first look
  double h_ = 0;
};

Status CheckFractions(std::span<const double> fractions) {
  if (fractions.empty()) return Status::InvalidArgument("no looks");
  double prev = 0;
  for (double f : fractions) {
    if (!(f > prev && f <= 1.0)) {
      return Status::InvalidArgument("information fractions must increase within (0, 1]");
    }
    prev = f;
  }
  return Status::Ok();
}

bool IsMinimum(std::string_view name) {
  return name == kBiasInstability || name == kBiasInstabilityIeee;
}

std::string Key(const std::string& axis, const std::string& name) { return axis + "/" + name; }

std::string Who(const pb::Measurement& m) {
  return (m.axis().empty() ? "" : m.axis() + ": ") + m.name();
}

std::string UnitSuffix(const pb::Measurement& m) { return m.unit() == "1" ? "" : " " + m.unit(); }

// Where a measurement stands against its marginal band, read as the
// full-length record would read it. A marginal bound is settled when the
// value is at least kFlagZ sds from it, the sd being what the full record's
// value can still differ from this one's, u sqrt(1 - f); or when the curve's
// own evidence (tau_at_minimum: measure.h MinimumSideEvidence) puts the truth
// on the value's side of it by kFlagZ.
enum class Flag { kNone, kClear, kMarginal, kUnsettled };
Flag FlagOf(const pb::Measurement& m, double fraction, const BoundEvidence& evidence) {
  if (!m.has_marginal_low() && !m.has_marginal_high()) return Flag::kNone;
  const double v = m.value();
  const double u = m.has_uncertainty() ? m.uncertainty() : std::nan("");
  const double sd = u * std::sqrt(std::max(0.0, 1.0 - fraction));
  bool marginal = false, unsettled = false;
  auto check = [&](double b) {
    const bool above = v > b;
    bool settled = std::abs(v - b) >= kFlagZ * sd;  // false for a NaN sd
    if (!settled && evidence && m.name() == kTauAtMinimum) {
      const SideEvidence ev = evidence(m, b);
      settled = (above ? ev.above : ev.below) >= kFlagZ;
    }
    return std::pair<bool, bool>(above, settled);
  };
  if (m.has_marginal_low()) {
    const auto [above, settled] = check(m.marginal_low());
    if (!settled)
      unsettled = true;
    else if (!above)
      marginal = true;
  }
  if (m.has_marginal_high()) {
    const auto [above, settled] = check(m.marginal_high());
    if (!settled)
      unsettled = true;
    else if (above)
      marginal = true;
  }
  return marginal ? Flag::kMarginal : unsettled ? Flag::kUnsettled : Flag::kClear;
}

Decision Worse(Decision a, Decision b) {
  auto rank = [](Decision d) {
    switch (d) {
      case Decision::kFail:
        return 3;
      case Decision::kPending:
        return 2;
      case Decision::kPass:
        return 0;
    }
    return 2;
  };
  return rank(a) >= rank(b) ? a : b;
}

}  // namespace

double SpentAlpha(double fraction, double alpha) {
  const double f = std::clamp(fraction, 0.0, 1.0);
  return alpha * std::log1p((std::exp(1.0) - 1.0) * f);
}

Result<std::vector<double>> SequentialBounds(std::span<const double> fractions, double alpha) {
  IMUQUAL_RETURN_IF_ERROR(CheckFractions(fractions));
  if (!(alpha > 0 && alpha < 0.5)) return Status::InvalidArgument("alpha must be in (0, 0.5)");
  Recursion r(fractions);
  std::vector<double> bounds;
  double prev_f = 0, spent = 0;
  for (double f : fractions) {
    const double target = SpentAlpha(f, alpha) - spent;
    const double d = f - prev_f;
    // Crossing(c) decreases in c: bisect on the S scale.
    double lo = -10 * std::sqrt(f), hi = 40 * std::sqrt(f);
    for (int it = 0; it < 200 && hi - lo > 1e-10; ++it) {
      const double mid = 0.5 * (lo + hi);
      (r.Crossing(mid, d) > target ? lo : hi) = mid;
    }
    const double c = 0.5 * (lo + hi);
    spent += r.Crossing(c, d);
    r.Step(c, d);
    bounds.push_back(c / std::sqrt(f));
    prev_f = f;
  }
  return bounds;
}

double CrossingProbability(std::span<const double> fractions, std::span<const double> bounds) {
  if (!CheckFractions(fractions).ok() || bounds.size() != fractions.size()) return std::nan("");
  Recursion r(fractions);
  double prev_f = 0, total = 0;
  for (size_t k = 0; k < fractions.size(); ++k) {
    const double d = fractions[k] - prev_f;
    const double c = bounds[k] * std::sqrt(fractions[k]);
    total += r.Crossing(c, d);
    r.Step(c, d);
    prev_f = fractions[k];
  }
  return total;
}

LookSchedule MakeLookSchedule(const pb::TestPlan& plan) {
  LookSchedule s;
  if (!plan.has_early_decision()) return s;
  const pb::EarlyDecision& e = plan.early_decision();
  s.horizon_s = e.has_horizon_s() ? e.horizon_s() : plan.min_duration_s();
  s.risk = e.risk();
  const double period = e.has_look_period_s() ? e.look_period_s() : kDefaultLookPeriodS;
  if (!(period > 0) || !(s.horizon_s > 0) || !(e.min_duration_s() > 0)) return s;
  for (int k = 0; k < kMaxLooks; ++k) {
    const double t = e.min_duration_s() + k * period;
    if (t >= s.horizon_s * (1 - 1e-12)) break;
    s.times_s.push_back(t);
    s.fractions.push_back(t / s.horizon_s);
  }
  return s;
}

const char* DecisionName(Decision d) {
  switch (d) {
    case Decision::kPending:
      return "PENDING";
    case Decision::kPass:
      return "PASS";
    case Decision::kFail:
      return "FAIL";
  }
  return "PENDING";
}

bool EarlyDecider::Decides(const pb::Measurement& m) {
  const bool judged = m.has_low() || m.has_high();
  // Record properties, not estimates that converge: judged on the record as
  // analysed when the unit is decided (a temperature range only grows).
  return judged && m.name() != kGapFraction && m.name() != kInvalidFraction &&
         m.name() != kDuration && m.name() != kTemperatureMean && m.name() != kTemperatureRange &&
         m.name() != kTemperatureSlope;
}

Result<EarlyDecider> EarlyDecider::Create(const pb::TestPlan& plan) {
  if (!plan.has_early_decision()) return Status::InvalidArgument("the plan has no early_decision");
  LookSchedule s = MakeLookSchedule(plan);
  if (s.times_s.empty()) {
    return Status::InvalidArgument(
        "early_decision: no look before the horizon (min_duration_s >= horizon)");
  }
  if (!(s.risk > 0 && s.risk <= 0.2)) return Status::InvalidArgument("early_decision.risk");
  EarlyDecider d(std::move(s));
  d.flags_ = plan.early_decision().marginal_flags();
  return d;
}

Decision EarlyDecider::MeasurementDecision(const std::string& axis, const std::string& name) const {
  const std::string key = Key(axis, name);
  for (const Decided& d : decided_) {
    if (d.key == key) return d.decision;
  }
  return Decision::kPending;
}

Look EarlyDecider::Evaluate(int index, const std::vector<pb::Measurement>& measurements,
                            const SettledQuery& settled, const BoundEvidence& evidence) {
  Look look;
  look.index = index;
  if (index < 0 || static_cast<size_t>(index) >= schedule_.times_s.size()) return look;
  look.time_s = schedule_.times_s[index];
  look.fraction = schedule_.fractions[index];
  if (unit_ != Decision::kPending) {
    look.unit = unit_;
    return look;
  }
  // The level of each bound: the risk split among every bound tested.
  if (bounds_.empty()) {
    int count = 0;
    for (const pb::Measurement& m : measurements) {
      if (!Decides(m)) continue;
      count += m.has_low() + m.has_high();
      if (flags_ == pb::EarlyDecision::FLAGS_DECIDED) {
        count += m.has_marginal_low() + m.has_marginal_high();
      }
    }
    alpha_per_bound_ = schedule_.risk / std::max(count, 1);
    auto b = SequentialBounds(schedule_.fractions, std::min(alpha_per_bound_, 0.49));
    if (!b.ok()) return look;
    bounds_ = *b;
  }
  const double z = bounds_[index];
  look.z = z;

  std::map<std::string, bool> settled_cache;
  auto is_settled = [&](const std::string& axis) {
    auto it = settled_cache.find(axis);
    if (it != settled_cache.end()) return it->second;
    const bool s = settled ? settled(axis) : false;
    settled_cache[axis] = s;
    return s;
  };

  Decision unit = Decision::kPass;
  bool any = false;
  // The marginal flags (FLAGS_AGREE_FULL_LENGTH): the unit is MARGINAL once
  // one flag is settled so, PASS once every flag is settled clear.
  bool flag_marginal = false;
  std::string flag_unsettled;
  for (const pb::Measurement& m : measurements) {
    if (!Decides(m)) continue;
    any = true;
    if (flags_ == pb::EarlyDecision::FLAGS_AGREE_FULL_LENGTH) {
      switch (FlagOf(m, look.fraction, evidence)) {
        case Flag::kMarginal:
          flag_marginal = true;
          break;
        case Flag::kUnsettled:
          if (flag_unsettled.empty()) flag_unsettled = Who(m);
          break;
        default:
          break;
      }
    }
    LookEntry e;
    e.axis = m.axis();
    e.name = m.name();
    e.value = m.value();
    e.uncertainty = m.has_uncertainty() ? m.uncertainty() : std::nan("");
    const std::string key = Key(m.axis(), m.name());
    auto prior = std::find_if(decided_.begin(), decided_.end(),
                              [&](const Decided& d) { return d.key == key; });
    if (prior != decided_.end()) {
      e.decision = prior->decision;
      e.why = prior->why;
      unit = Worse(unit, e.decision);
      look.entries.push_back(std::move(e));
      continue;
    }
    const double v = m.value(), u = e.uncertainty;
    const bool is_tau = m.name() == kTauAtMinimum;
    const bool has_u = std::isfinite(u) && u > 0;
    // Evidence the caller reads off the curve (tau_at_minimum, the -1/2
    // read-offs), per direction; what it leaves NaN comes from v and u.
    auto side_evidence = [&](double b) {
      SideEvidence ev = evidence ? evidence(m, b) : SideEvidence{};
      // On the scale the judge guards it on (ln tau for tau_at_minimum).
      const double z = has_u ? SigmasAbove(m, b) : NAN;
      if (!std::isfinite(ev.above)) {
        ev.above = std::isnan(z) ? -INFINITY : z;
        ev.above_source = "";
      }
      if (!std::isfinite(ev.below)) {
        ev.below = std::isnan(z) ? -INFINITY : -z;
        ev.below_source = "";
      }
      return ev;
    };
    const bool usable = std::isfinite(v) && m.qualifier() != pb::NOT_MEASURABLE &&
                        m.qualifier() != pb::MODEL_INADEQUATE && !m.model_inadequate();
    if (!usable) {
      e.why = !std::isfinite(v) ? "not measured yet" : "not measurable";
      unit = Worse(unit, Decision::kPending);
      look.entries.push_back(std::move(e));
      continue;
    }
    const bool minimum_not_resolved = m.qualifier() == pb::MINIMUM_NOT_RESOLVED;
    // A value the truth lies at or below can only confirm "below".
    const bool bound_like =
        m.qualifier() == pb::UPPER_BOUND || (minimum_not_resolved && IsMinimum(m.name()));
    // More data can only lower a curve minimum and move it to longer taus:
    // "above" for a minimum and "below" for its tau need it settled.
    auto above_allowed = [&]() {
      if (bound_like) return false;
      return !IsMinimum(m.name()) || is_settled(m.axis());
    };
    auto below_allowed = [&]() {
      return !is_tau || (!minimum_not_resolved && is_settled(m.axis()));
    };
    enum class Side { kUnknown, kInside, kOutside };
    auto above = [&](double b) { return side_evidence(b).above >= z && above_allowed(); };
    auto below = [&](double b) { return side_evidence(b).below >= z && below_allowed(); };
    auto high_side = [&](double b) {
      return below(b) ? Side::kInside : above(b) ? Side::kOutside : Side::kUnknown;
    };
    auto low_side = [&](double b) {
      return above(b) ? Side::kInside : below(b) ? Side::kOutside : Side::kUnknown;
    };
    const std::string stat = Who(m) + " " + Num(v) + (has_u ? " ± " + Num(u) : "") + UnitSuffix(m);
    // The z that confirmed bound b on the side `truth_above` says, and whence.
    auto zs = [&](double b, bool truth_above) {
      const SideEvidence ev = side_evidence(b);
      const double zz = truth_above ? ev.above : ev.below;
      const std::string source = truth_above ? ev.above_source : ev.below_source;
      return " (" + (source.empty() ? std::string() : source + ": ") + "z " + Num(zz) +
             " >= " + Num(z) + ")";
    };
    Decision d = Decision::kPending;
    bool marginal = false;
    std::string why;
    const Side fh = m.has_high() ? high_side(m.high()) : Side::kInside;
    const Side fl = m.has_low() ? low_side(m.low()) : Side::kInside;
    if (fh == Side::kOutside) {
      d = Decision::kFail;
      why = stat + " confirmed above " + Num(m.high()) + zs(m.high(), true);
    } else if (fl == Side::kOutside) {
      d = Decision::kFail;
      why = stat + " confirmed below " + Num(m.low()) + zs(m.low(), false);
    } else if (fh == Side::kInside && fl == Side::kInside) {
      why = stat + " confirmed inside";
      if (m.has_low()) why += " " + Num(m.low()) + zs(m.low(), true);
      if (m.has_high()) why += (m.has_low() ? " and " : " ") + Num(m.high()) + zs(m.high(), false);
      d = Decision::kPass;
      if (flags_ == pb::EarlyDecision::FLAGS_DECIDED) {
        // The marginal flag decided too: each marginal bound on a confirmed side.
        const Side mh = m.has_marginal_high() ? high_side(m.marginal_high()) : Side::kInside;
        const Side ml = m.has_marginal_low() ? low_side(m.marginal_low()) : Side::kInside;
        if (mh == Side::kUnknown || ml == Side::kUnknown) {
          d = Decision::kPending;
          why += ", not yet on one side of the marginal band (z " + Num(z) + ")";
        } else {
          marginal = mh == Side::kOutside || ml == Side::kOutside;
          why += marginal ? ", confirmed in the marginal band"
                          : ", confirmed clear of the marginal band";
        }
      }
    } else {
      why = stat + ": not yet on one side of a limit (z " + Num(z) + ")";
      if (IsMinimum(m.name()) && !bound_like && !is_settled(m.axis())) {
        why += "; minimum not settled";
      }
      if (minimum_not_resolved) why += "; minimum not resolved";
      if (!has_u) why += "; no uncertainty to decide on";
    }
    e.decision = d;
    e.why = why;
    if (d != Decision::kPending) decided_.push_back({key, d, why, index, marginal});
    unit = Worse(unit, d);
    look.entries.push_back(std::move(e));
  }
  if (!any) unit = Decision::kPending;
  if (unit == Decision::kPass && !flag_marginal && !flag_unsettled.empty()) {
    unit = Decision::kPending;
    look.note = "every limit decided; the marginal flag of " + flag_unsettled +
                " could still read otherwise at full length";
  }
  look.unit = unit;
  if (unit != Decision::kPending) {
    unit_ = unit;
    decided_look_ = index;
  }
  looks_.push_back(look);
  return look;
}

std::string EarlyDecider::FlagProvenance() const {
  if (unit_ == Decision::kPending) return "MARGINAL flag read on the full-length record";
  const std::string at = Num(decided_time_s());
  switch (flags_) {
    case pb::EarlyDecision::FLAGS_AGREE_FULL_LENGTH:
      return "MARGINAL flag read at the decision (" + at +
             " s), settled to agree with the full-length record";
    case pb::EarlyDecision::FLAGS_DECIDED:
      return "MARGINAL flag decided at the decision (" + at + " s) at the plan's risk";
    default:
      return "MARGINAL flag read at the decision (" + at +
             " s); the full-length record may read it otherwise";
  }
}

void EarlyDecider::ApplyTo(std::vector<pb::Measurement>* measurements) const {
  const std::string provenance = FlagProvenance();
  for (pb::Measurement& m : *measurements) {
    const std::string key = Key(m.axis(), m.name());
    auto it = std::find_if(decided_.begin(), decided_.end(),
                           [&](const Decided& d) { return d.key == key; });
    if (it == decided_.end()) {
      if (unit_ != Decision::kPending && Decides(m)) {
        AppendNote(m, "not decided when the unit was (judged on the record analysed)");
      }
      if (unit_ != Decision::kPending) NoteFlag(m, provenance);
      continue;
    }
    // A decided PASS keeps the marginal flag the record analysed shows
    // (marginal bands are read simply, as always).
    const bool flag =
        flags_ == pb::EarlyDecision::FLAGS_DECIDED ? it->marginal : m.outcome() == pb::MARGINAL;
    m.set_outcome(it->decision == Decision::kFail ? pb::FAIL : flag ? pb::MARGINAL : pb::PASS);
    m.clear_guard_band();
    AppendNote(m, std::string("decided ") + DecisionName(it->decision) + " at " +
                      Num(schedule_.times_s[it->look]) + " s (look " +
                      std::to_string(it->look + 1) + "): " + it->why);
    NoteFlag(m, provenance);
  }
}

Judgement JudgeDecided(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                       const EarlyDecider& decider, std::vector<pb::Measurement>* measurements) {
  if (decider.unit_decision() == Decision::kPending) {
    // Pending at every look: the full-length verdict, and its flags say so.
    Judgement j = Judge(plan, axes, measurements);
    const std::string provenance = decider.FlagProvenance();
    for (pb::Measurement& m : *measurements) NoteFlag(m, provenance);
    return j;
  }
  pb::TestPlan effective = plan;
  effective.set_min_duration_s(plan.early_decision().min_duration_s());
  const Judgement simple = Judge(effective, axes, measurements);
  // Judge gives one reason per judged measurement that did not pass, in order.
  std::vector<std::string> reasons(measurements->size());
  size_t next = 0;
  for (size_t i = 0; i < measurements->size(); ++i) {
    const pb::Outcome o = (*measurements)[i].outcome();
    if (o != pb::OUTCOME_UNSET && o != pb::PASS && next < simple.reasons.size()) {
      reasons[i] = simple.reasons[next++];
    }
  }
  decider.ApplyTo(measurements);
  Judgement j;
  for (size_t i = 0; i < measurements->size(); ++i) {
    const pb::Measurement& m = (*measurements)[i];
    const pb::Outcome o = m.outcome();
    if (o == pb::OUTCOME_UNSET || o == pb::PASS) continue;
    const Decision d = decider.MeasurementDecision(m.axis(), m.name());
    if (d == Decision::kPending || o == pb::MARGINAL) {
      if (reasons[i].empty()) continue;
      // The stationarity scan is read at the end of the record, not at a look.
      const bool flag = o == pb::MARGINAL && m.name() != kStationarityEvents;
      j.reasons.push_back(flag ? reasons[i] + " (" + decider.FlagProvenance() + ")" : reasons[i]);
    } else {
      const std::string& note = m.note();
      const size_t at = note.rfind("decided ");
      j.reasons.push_back(Who(m) + ": " + (at == std::string::npos ? note : note.substr(at)));
    }
  }
  // Judge's reasons beyond those of the judged measurements: the events a
  // QUALIFIER_ONLY stationarity scan found.
  for (size_t r = next; r < simple.reasons.size(); ++r) j.reasons.push_back(simple.reasons[r]);
  j.verdict = VerdictOf(*measurements);
  return j;
}

}  // namespace imuqual::judge
