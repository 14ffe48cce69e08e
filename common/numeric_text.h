// Numeric series from text: one value per line, or CSV with a header whose
// columns are chosen by name. Used by `imuqual analyze FILE` and the CSV
// replay source. Parsing is pure (text in, values out) so it can be fuzzed;
// every error names the source, the line and, for CSV, the column.
//
// Both forms skip blank lines and lines starting with '#' or '%'. A value of
// "nan" (any case) or an empty CSV cell is NaN: a gap, never a zero.
#ifndef IMUQUAL_COMMON_NUMERIC_TEXT_H_
#define IMUQUAL_COMMON_NUMERIC_TEXT_H_

#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace imuqual {

struct NumericTable {
  std::vector<std::string> names;            // column names (CSV header), or {"value"}
  std::vector<std::vector<double>> columns;  // columns[c][row]
  size_t rows() const { return columns.empty() ? 0 : columns[0].size(); }
};

// Parses `text`. The form is detected: if the first data line has a comma, or
// is not a number, it is a CSV header. `wanted` selects columns by name (all
// when empty); an unknown name is an error that lists the columns there are.
Result<NumericTable> ParseNumericText(std::string_view text, std::string_view source_name,
                                      const std::vector<std::string>& wanted = {});

// One column: the only one, or the named one (required if there are several).
Result<std::vector<double>> ParseSeries(std::string_view text, std::string_view source_name,
                                        const std::string& column = "");

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_NUMERIC_TEXT_H_
