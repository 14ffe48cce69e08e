// `imuqual report`: a lot's HTML qualification report (report/report.h)
// written to a file or standard output.
#ifndef IMUQUAL_CLI_REPORT_COMMAND_H_
#define IMUQUAL_CLI_REPORT_COMMAND_H_

#include <string>

namespace imuqual::cli {

// Command-line fields of `imuqual report`.
struct ReportOptions {
  std::string db_path;  // --db: the archive (required)
  std::string lot;      // --lot: the lot to report (required)
  std::string output;   // -o: the HTML file to write (required; replaced atomically)
};

// Writes the report. Returns 0, 1 on an error (unknown lot, unreadable
// archive, unwritable output file: one line on stderr), 2 on a usage error.
int ReportCommand(const ReportOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_REPORT_COMMAND_H_
