// `imuqual chart`: a control chart of one judged measurement across the
// archive's lots, weeks or months (report/control_chart_view.h).
//   imuqual chart --db F --measurement M --axis A [--by lot|week|month] [--station S]
// Prints the centre line and sigma, then a row per subgroup with its limits
// and the run rules it completes. Exit 0 in control, 3 a rule flagged, 1
// the archive could not be read, 2 usage or too little data (named).
#ifndef IMUQUAL_CLI_CHART_COMMAND_H_
#define IMUQUAL_CLI_CHART_COMMAND_H_

#include <CLI/CLI.hpp>

#include <string>

namespace imuqual::cli {

struct ChartOptions {
  std::string db_path, measurement, axis, by = "lot", station, format = "table";
  int baseline = 0;  // limits from the first N subgroups (0: all)
  std::string plan;  // name or digest prefix; "" the newest run's plan
};

CLI::App* AddChartCommand(CLI::App& app, ChartOptions* options);
int ChartCommand(const ChartOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_CHART_COMMAND_H_
