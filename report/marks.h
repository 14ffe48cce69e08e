// The marks that travel with a value into what people read: what kind of
// value it is (pb::Qualifier) and its uncertainty. One place for the text
// tables of `imuqual lot`, `unit`, the station's final table and its console.
//
//   upper bound            "≤ 0.68"
//   minimum not resolved   "22.1†"  (legend: the curve has not turned up)
//   model inadequate       "3.2‡"   (legend: the noise model failed its fit test)
//   not measurable         "n/m"    (the note, why, under the table)
//   with an uncertainty    "10.59 ± 0.81"
//
// The project writes UTF-8 throughout (reasons say "±"), so the marks are
// UTF-8 too.
#ifndef IMUQUAL_REPORT_MARKS_H_
#define IMUQUAL_REPORT_MARKS_H_

#include <array>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "imuqual/record.pb.h"
#include "store/query.h"

namespace imuqual::report {

inline constexpr char kUpperBoundMark[] = "\u2264 ";         // "≤ " before the value
inline constexpr char kMinimumNotResolvedMark[] = "\u2020";  // "†" after it
inline constexpr char kModelInadequateMark[] = "\u2021";     // "‡" after it
inline constexpr char kNotMeasurableText[] = "n/m";

// A value's qualifier as exports and the report write it: the qualifier's
// text (store::QualifierText), else "not_measurable" for a missing value
// (NaN: archived before qualifiers existed, or no measurement at all), else
// "measured".
std::string QualifierWord(pb::Qualifier qualifier, double value);

// A value and its 1-sigma uncertainty as a measurement is quoted (GUM
// 7.2.6): u to two significant digits and the value to the same decimal
// place ("410 ± 280", "10.20 ± 0.81", not "409.6 ± 2.8e+02"); in
// exponent form beyond 1e6 or below 1e-3; a value that would need more than
// kMaxQuotedDigits significant digits (u under ~1e-9 of it) to those digits,
// u in exponent form ("99.99999123", "2.4e-12"; trailing zeros dropped:
// "100", "2.4e-15"). Without a finite u > 0:
// the value to `digits` significant digits and u as "-" (or "0").
inline constexpr int kMaxQuotedDigits = 10;
std::pair<std::string, std::string> QuotedWithUncertainty(double value, double uncertainty,
                                                          int digits = 4);

// `value` to `digits` significant digits with its qualifier's mark, then
// " ± u" when `with_uncertainty` and u is finite (both then quoted as
// QuotedWithUncertainty says) (never after "n/m" or an upper bound); "-" for a value that is
// missing (NaN, not qualified not measurable).
std::string MarkedValue(double value, pb::Qualifier qualifier, double uncertainty, int digits,
                        bool with_uncertainty);
std::string MarkedValue(double value, const store::ValueMarks& marks, int digits,
                        bool with_uncertainty);

// The legend under a table: one line per mark used, and the reasons of the
// values not measurable, compactly: one line per reason and set of
// measurements, with the units and axes it holds for ("  no curve:
// bias_instability, tau_at_minimum of SN-1 x, y, z; SN-2 x").
class MarkLegend {
 public:
  // `who`: the unit (or run); `axis` and `name` the value's.
  void Add(const store::ValueMarks& marks, const std::string& who, const std::string& axis,
           const std::string& name, double value);
  bool empty() const { return used_.empty() && !uncertainty_; }
  std::string Render() const;  // "" when nothing is marked

 private:
  std::set<pb::Qualifier> used_;
  // Values not measurable, in order: (who, axis, name, note).
  std::vector<std::array<std::string, 4>> not_measurable_;
  bool uncertainty_ = false;
};

// The legend's text for one qualifier (without the mark), e.g. "minimum at the
// last point: the curve has not turned up; the true minimum may lie lower".
const char* QualifierExplanation(pb::Qualifier qualifier);

// Who soaked the units of `rows`, and where, for under a table people
// read: one line per station and operator, "station bench-A, operator ana:
// 12 runs" ("(not recorded)" for an empty one), in order of appearance.
std::string StationOperatorLines(const std::vector<store::AxisRow>& rows);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_MARKS_H_
