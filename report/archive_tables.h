// The archive's listings as tables (report/table_writer.h), the same for
// the imuqual command's text, CSV and JSON and for the web pages: the lots,
// a lot's units per axis, and runs.
#ifndef IMUQUAL_REPORT_ARCHIVE_TABLES_H_
#define IMUQUAL_REPORT_ARCHIVE_TABLES_H_

#include <functional>
#include <string>
#include <vector>

#include "report/lot_statistics.h"
#include "report/table_writer.h"
#include "store/query.h"

namespace imuqual::report {

// Where a lot's, a run's or a unit's name links to in an HTML table (web
// pages); unset: no link.
struct TableLinks {
  std::function<std::string(const std::string& lot)> lot;
  std::function<std::string(const std::string& run_id)> run;
  std::function<std::string(const std::string& serial)> serial;
};

// Every lot with its counts by final run, first-pass and final yield,
// retests and first/last start. `for_people`: a yield that cannot be
// measured (no judged unit) reads "n/m" instead of an empty value.
TableWriter LotsTable(const std::vector<store::LotRow>& lots, bool for_people,
                      const TableLinks& links = {});

// A lot's units per axis, for programs: one column per quantity and unit
// (gyro and accelerometer rows never share a column), each value's
// uncertainty and qualifier, the verdicts, the decision time, station, slot
// and operator.
TableWriter LotAxisTable(const std::vector<store::AxisRow>& rows);

// Runs, one row each: run id, serial, lot, station, slot, start (ISO 8601
// UTC), state, verdict, the first reason, operator.
TableWriter RunsTable(const std::vector<store::RunRow>& rows, const TableLinks& links = {});

// Two lots compared per axis and measurement (report/lot_statistics.h):
// n, mean, sd and yield of each, the mean's change, the p-values and which
// differences are significant.
TableWriter ComparisonTable(const std::vector<Comparison>& rows);

// A lot's statistics per axis and measurement, each unit by its final run.
// NotFound names the lot.
Result<std::vector<MeasurementStats>> LotStatistics(store::Archive& archive,
                                                    const std::string& lot);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_ARCHIVE_TABLES_H_
