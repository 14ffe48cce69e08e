// Replay of a recorded CSV (a header naming the columns): the chosen columns
// are the axes, optionally a column holds the device sample counter (rows
// then carry their own timeline and a jump is a gap); otherwise row k is
// sample k. Optionally a column holds each row's recording time in seconds
// (any origin): the blocks then carry arrival times; and one the unit's
// temperature (deg C). Values are in the axes' units (deg/s, m/s^2) after `scale`.
// Streams the file: any length. Not thread-safe.
#ifndef IMUQUAL_ACQUIRE_CSV_SOURCE_H_
#define IMUQUAL_ACQUIRE_CSV_SOURCE_H_

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "acquire/source.h"
#include "common/numeric_text.h"

namespace imuqual::acquire {

struct CsvSourceOptions {
  std::string path;
  double rate_hz = 0;             // nominal sample rate, > 0
  std::vector<pb::Axis> axes;     // columns by name, with their kinds; at least one
  std::string counter_column;     // "" = the row index is the counter
  std::string time_column;        // seconds: when the row was recorded ("" = none); gives
                                  // the device's measured rate and jitter
  double scale = 1.0;             // applied to every axis value without its own factor
  // Per axis, parallel to `axes` (empty, or "" / 0 for an axis: none): the
  // column it is read from (default: the axis's name) and the factor from
  // that column's values to the axis's unit (deg/s, m/s^2), which replaces
  // `scale` for it.
  std::vector<std::string> axis_columns;
  std::vector<double> axis_factors;
  std::string temperature_column; // deg C per row ("" = none); each block carries the mean
                                  // of its rows' finite values (an empty cell: none)
};

class CsvSource : public SampleSource {
 public:
  // Opens the file and reads its header and first row; errors name the
  // file, the line and the column. A file without a data row (empty, or a
  // header only) is an error.
  static Result<std::unique_ptr<CsvSource>> Open(const CsvSourceOptions& options);
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;
  // Closes the file.
  void Stop() override;

 private:
  CsvSource(CsvSourceOptions options, std::unique_ptr<std::ifstream> file);
  CsvSourceOptions options_;
  std::unique_ptr<std::ifstream> file_;
  std::unique_ptr<NumericRowReader> reader_;
  SourceInfo info_;
  std::vector<double> row_;
  bool row_pending_ = false;    // row_ read by Open (the first row), not yet looked at
  bool have_row_ = false;       // row_ read but not yet delivered (a counter jump ended a block)
  int64_t row_counter_ = 0;
  int64_t next_index_ = 0;      // counter of the next row without a counter column
  int64_t last_counter_ = -1;
  bool done_ = false;
  int time_index_ = -1;         // index of the time column in row_, -1: none
  int temperature_index_ = -1;  // index of the temperature column in row_, -1: none
  int64_t start_utime_ = 0;     // row times are placed after this
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_CSV_SOURCE_H_
