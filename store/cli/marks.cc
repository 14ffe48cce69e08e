#include "store/cli/marks.h"

#include <cmath>
#include <cstdio>

namespace imuqual::cli {
namespace {

std::string Digits(double v, int digits) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace

const char* QualifierExplanation(pb::Qualifier qualifier) {
  switch (qualifier) {
    case pb::UPPER_BOUND: return "upper bound: the true value lies at or below it";
    case pb::MINIMUM_NOT_RESOLVED:
      return "minimum at the last point: the curve has not turned up; the true minimum may lie "
             "lower";
    case pb::MODEL_INADEQUATE: return "from a noise model that failed its fit test";
    case pb::NOT_MEASURABLE: return "not measurable";
    default: return "measured";
  }
}

std::string MarkedValue(double value, pb::Qualifier qualifier, double uncertainty, int digits,
                        bool with_uncertainty) {
  if (qualifier == pb::NOT_MEASURABLE) return kNotMeasurableText;
  if (!std::isfinite(value)) return "-";
  std::string out;
  if (qualifier == pb::UPPER_BOUND) out += kUpperBoundMark;
  out += Digits(value, digits);
  if (qualifier == pb::MINIMUM_NOT_RESOLVED) out += kMinimumNotResolvedMark;
  if (qualifier == pb::MODEL_INADEQUATE) out += kModelInadequateMark;
  if (with_uncertainty && qualifier != pb::UPPER_BOUND && std::isfinite(uncertainty)) {
    out += " \u00B1 " + Digits(uncertainty, 2);
  }
  return out;
}

std::string MarkedValue(double value, const store::ValueMarks& marks, int digits,
                        bool with_uncertainty) {
  return MarkedValue(value, marks.qualifier, marks.uncertainty, digits, with_uncertainty);
}

void MarkLegend::Add(const store::ValueMarks& marks, const std::string& who, double value) {
  AddQualifier(marks.qualifier, who, marks.note, value);
  if (std::isfinite(marks.uncertainty) && marks.qualifier != pb::UPPER_BOUND &&
      marks.qualifier != pb::NOT_MEASURABLE && std::isfinite(value)) {
    uncertainty_ = true;
  }
}

void MarkLegend::AddQualifier(pb::Qualifier qualifier, const std::string& who,
                              const std::string& note, double value) {
  if (qualifier == pb::QUALIFIER_NONE) return;
  if (qualifier != pb::NOT_MEASURABLE && !std::isfinite(value)) return;
  used_.insert(qualifier);
  if (qualifier == pb::NOT_MEASURABLE) {
    not_measurable_.push_back("  " + who + ": " + (note.empty() ? "no reason recorded" : note));
  }
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
    out += std::string(kModelInadequateMark) + " " + QualifierExplanation(pb::MODEL_INADEQUATE) +
           "\n";
  }
  if (used_.count(pb::NOT_MEASURABLE)) {
    out += std::string(kNotMeasurableText) + ": not measurable:\n";
    for (const std::string& line : not_measurable_) out += line + "\n";
  }
  return out;
}

}  // namespace imuqual::cli
