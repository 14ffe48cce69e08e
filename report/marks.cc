#include "report/marks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "store/outcome.h"

namespace imuqual::report {
namespace {

std::string Digits(double v, int digits) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace

std::string QualifierWord(pb::Qualifier qualifier, double value) {
  const std::string text = store::QualifierText(qualifier);
  if (!text.empty()) return text;
  return std::isnan(value) ? store::QualifierText(pb::NOT_MEASURABLE) : "measured";
}

const char* QualifierExplanation(pb::Qualifier qualifier) {
  switch (qualifier) {
    case pb::UPPER_BOUND:
      return "upper bound: the true value lies at or below it";
    case pb::MINIMUM_NOT_RESOLVED:
      return "minimum at the last point: the curve has not turned up; the true minimum may lie "
             "lower";
    case pb::MODEL_INADEQUATE:
      return "from a noise model that failed its fit test";
    case pb::NOT_MEASURABLE:
      return "not measurable";
    default:
      return "measured";
  }
}

std::string MarkedValue(double value, pb::Qualifier qualifier, double uncertainty, int digits,
                        bool with_uncertainty) {
  if (qualifier == pb::NOT_MEASURABLE) return kNotMeasurableText;
  if (!std::isfinite(value)) return "-";
  // With its uncertainty the value is rounded to u's last digit.
  const bool with_u =
      with_uncertainty && qualifier != pb::UPPER_BOUND && std::isfinite(uncertainty);
  const auto [number, u] = with_u ? QuotedWithUncertainty(value, uncertainty, digits)
                                  : std::pair{Digits(value, digits), std::string()};
  std::string out;
  if (qualifier == pb::UPPER_BOUND) out += kUpperBoundMark;
  out += number;
  if (qualifier == pb::MINIMUM_NOT_RESOLVED) out += kMinimumNotResolvedMark;
  if (qualifier == pb::MODEL_INADEQUATE) out += kModelInadequateMark;
  if (with_u) out += " \u00B1 " + u;
  return out;
}

std::string MarkedValue(double value, const store::ValueMarks& marks, int digits,
                        bool with_uncertainty) {
  return MarkedValue(value, marks.qualifier, marks.uncertainty, digits, with_uncertainty);
}

std::pair<std::string, std::string> QuotedWithUncertainty(double value, double uncertainty,
                                                          int digits) {
  if (!std::isfinite(value) || !std::isfinite(uncertainty) || !(uncertainty > 0)) {
    return {Digits(value, digits), std::isfinite(uncertainty) ? Digits(uncertainty, 2) : "-"};
  }
  // 10^place: the decimal place of u's second significant digit (u rounded
  // up to a new decade, 0.996 -> 1.0, moves it one place left).
  int place = static_cast<int>(std::floor(std::log10(uncertainty))) - 1;
  double u = std::round(uncertainty / std::pow(10.0, place)) * std::pow(10.0, place);
  if (u >= std::pow(10.0, place + 2)) {
    ++place;
    u = std::round(uncertainty / std::pow(10.0, place)) * std::pow(10.0, place);
  }
  char vb[64], ub[64];
  // A u many orders under the value (a clock's rate known to 1e-15) would
  // need a value of 15 digits: the value to kMaxQuotedDigits, u in exponent form.
  if (value != 0 && std::floor(std::log10(std::abs(value))) - place + 1 > kMaxQuotedDigits) {
    std::snprintf(vb, sizeof vb, "%.*g", kMaxQuotedDigits, value);
    std::snprintf(ub, sizeof ub, "%.1e", u);
    return {vb, ub};
  }
  const double v = std::round(value / std::pow(10.0, place)) * std::pow(10.0, place);
  const double big = std::max(std::abs(v), u);
  if (big >= 1e6 || big < 1e-3) {
    const int ve = v == 0 ? place : static_cast<int>(std::floor(std::log10(std::abs(v))));
    std::snprintf(vb, sizeof vb, "%.*e", std::max(0, ve - place), v);
    std::snprintf(ub, sizeof ub, "%.1e", u);
  } else {
    const int decimals = std::max(0, -place);
    std::snprintf(vb, sizeof vb, "%.*f", decimals, v);
    std::snprintf(ub, sizeof ub, "%.*f", decimals, u);
  }
  return {vb, ub};
}

void MarkLegend::Add(const store::ValueMarks& marks, const std::string& who,
                     const std::string& axis, const std::string& name, double value) {
  const pb::Qualifier q = marks.qualifier;
  if (q == pb::NOT_MEASURABLE) {
    used_.insert(q);
    not_measurable_.push_back(
        {who, axis, name, marks.note.empty() ? "no reason recorded" : marks.note});
    return;
  }
  if (!std::isfinite(value)) return;
  if (q != pb::QUALIFIER_NONE) used_.insert(q);
  if (std::isfinite(marks.uncertainty) && q != pb::UPPER_BOUND) uncertainty_ = true;
}

std::string MarkLegend::Render() const {
  std::string out;
  if (uncertainty_) out += "\u00B1 u: the value's 1-sigma uncertainty\n";
  if (used_.count(pb::UPPER_BOUND)) {
    out += std::string(kUpperBoundMark) + QualifierExplanation(pb::UPPER_BOUND) + "\n";
  }
  if (used_.count(pb::MINIMUM_NOT_RESOLVED)) {
    out += std::string(kMinimumNotResolvedMark) + " " +
           QualifierExplanation(pb::MINIMUM_NOT_RESOLVED) + "\n";
  }
  if (used_.count(pb::MODEL_INADEQUATE)) {
    out +=
        std::string(kModelInadequateMark) + " " + QualifierExplanation(pb::MODEL_INADEQUATE) + "\n";
  }
  if (used_.count(pb::NOT_MEASURABLE)) {
    out += std::string(kNotMeasurableText) + ": not measurable:\n";
    // Per unit and axis, its names by reason; then the units and axes that
    // share a reason and the same names on one line.
    std::vector<std::pair<std::string, std::string>> places;  // who, axis, in order
    std::map<std::pair<std::string, std::string>, std::map<std::string, std::string>> names;
    for (const auto& [who, axis, name, note] : not_measurable_) {
      auto& by_note = names[{who, axis}];
      if (by_note.empty()) places.emplace_back(who, axis);
      std::string& list = by_note[note];
      list += (list.empty() ? "" : ", ") + name;
    }
    std::map<std::string, std::map<std::string, std::vector<std::string>>>
        axes_of;  // key -> who -> axes
    std::vector<std::string> order;
    for (const auto& [who, axis] : places) {
      for (const auto& [note, list] : names[{who, axis}]) {
        const std::string key = note + ": " + list;
        auto& units = axes_of[key];
        if (units.empty()) order.push_back(key);
        units[who].push_back(axis);
      }
    }
    for (const std::string& key : order) {
      std::string line = "  " + key;
      std::string where;
      for (const auto& [who, axes] : axes_of[key]) {
        where += (where.empty() ? "" : "; ") + who;
        bool first = true;
        for (const std::string& axis : axes) {
          if (axis.empty()) continue;
          where += (first ? " " : ", ") + axis;
          first = false;
        }
      }
      out += line + " of " + where + "\n";
    }
  }
  return out;
}

std::string StationOperatorLines(const std::vector<store::AxisRow>& rows) {
  std::vector<std::pair<std::string, std::string>> who;
  std::vector<int> runs;
  std::string last_run;
  for (const store::AxisRow& r : rows) {
    if (r.run_id == last_run) continue;  // a run's axes are adjacent
    last_run = r.run_id;
    const std::pair<std::string, std::string> key{r.station, r.operator_name};
    const auto it = std::find(who.begin(), who.end(), key);
    if (it == who.end()) {
      who.push_back(key);
      runs.push_back(1);
    } else {
      ++runs[it - who.begin()];
    }
  }
  auto shown = [](const std::string& s) { return s.empty() ? std::string("(not recorded)") : s; };
  std::string out;
  for (size_t i = 0; i < who.size(); ++i) {
    out += "station " + shown(who[i].first) + ", operator " + shown(who[i].second) + ": " +
           std::to_string(runs[i]) + (runs[i] == 1 ? " run\n" : " runs\n");
  }
  return out;
}

}  // namespace imuqual::report
