// Numeric series from text: one value per line, or CSV with a header whose
// columns are chosen by name. Used by `imuqual analyze FILE` and the CSV
// replay source. Parsing is pure (text in, values out) so it can be fuzzed;
// every error names the source, the line and, for CSV, the column.
//
// Both forms skip blank lines and lines starting with '#' or '%'. A value of
// "nan" (any case) or an empty CSV cell is NaN: a gap, never a zero.
#ifndef IMUQUAL_COMMON_NUMERIC_TEXT_H_
#define IMUQUAL_COMMON_NUMERIC_TEXT_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
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
// With `invalid_warnings`, a cell of a chosen column that is not a number is
// NaN, an invalid sample (NumericRowReader::ReadNonNumbersAsInvalid), and
// the first such cell of each column is named there; without, it is an error.
Result<NumericTable> ParseNumericText(std::string_view text, std::string_view source_name,
                                      const std::vector<std::string>& wanted = {},
                                      std::vector<std::string>* invalid_warnings = nullptr);

// One column: the only one, or the named one (required if there are several).
Result<std::vector<double>> ParseSeries(std::string_view text, std::string_view source_name,
                                        const std::string& column = "",
                                        std::vector<std::string>* invalid_warnings = nullptr);

// The same format read row by row, for inputs too long to hold (a replayed
// recording): `next_line` returns the next line without its newline, or
// nullopt at the end. Not thread-safe.
class NumericRowReader {
 public:
  using LineSource = std::function<std::optional<std::string>()>;
  NumericRowReader(LineSource next_line, std::string source_name,
                   std::vector<std::string> wanted = {});

  // Reads up to the first data row (header detection and column choice).
  // Must be called first; fails as ParseNumericText does.
  Status Start();
  // Selected column names, in `wanted` order (all columns when none wanted).
  const std::vector<std::string>& names() const { return names_; }
  // The next data row into *values (one per selected column): true, or
  // false at the end. A malformed row is an error naming its line.
  Result<bool> Next(std::vector<double>* values);
  // Line number of the row last returned (1-based, counting every line).
  size_t line() const { return line_no_; }

  // A cell of one of the first `columns` selected columns that is not a
  // number (text, a stray character) is then read as NaN, an invalid
  // sample like "nan" or an empty cell, instead of failing the row: one rule
  // for every bad sample of a measured axis. The other columns (a counter, a
  // time stamp) still fail. Each such column's first bad cell leaves a
  // warning (TakeWarnings); every one is counted (invalid_cells).
  void ReadNonNumbersAsInvalid(size_t columns) { lenient_columns_ = columns; }
  int64_t invalid_cells() const { return invalid_cells_; }
  // The warnings since the last call, oldest first.
  std::vector<std::string> TakeWarnings() { return std::exchange(warnings_, {}); }

 private:
  Result<bool> ParseRow(std::string_view line, std::vector<double>* values);
  LineSource next_line_;
  std::string source_;
  std::vector<std::string> wanted_;
  std::vector<std::string> names_;
  std::vector<int> pick_;
  std::optional<std::string> pending_;  // a first data line seen while looking for a header
  size_t line_no_ = 0;
  size_t pending_line_ = 0;
  std::vector<std::string> fields_;
  size_t lenient_columns_ = 0;
  int64_t invalid_cells_ = 0;
  std::vector<bool> warned_;
  std::vector<std::string> warnings_;
};

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_NUMERIC_TEXT_H_
