// `imuqual msa`: do the stations agree? Golden units soaked on every
// station, one study per judged measurement and axis (report/msa_view.h,
// the AIAG ANOVA method: analyze/judge/msa.h).
//   imuqual msa --db F --lot GOLDEN [--measurement M] [--axis A] [--trials N]
// Prints the studies, then each station's offset from the fleet with its
// 95 % interval. Exit 0 (every station agrees: no offset interval excludes
// 0, no study unacceptable), 3 a station differs or a study is unacceptable,
// 1 the archive could not be read, 2 usage or no study possible (named).
#ifndef IMUQUAL_CLI_MSA_COMMAND_H_
#define IMUQUAL_CLI_MSA_COMMAND_H_

#include <CLI/CLI.hpp>

#include <string>

#include "report/msa_view.h"
#include "report/table_writer.h"

namespace imuqual::cli {

struct MsaOptions {
  std::string db_path, lot, format = "table";
  std::string by = "station";  // the appraisers: station, operator, station-operator
  report::MsaSelection selection;
};

CLI::App* AddMsaCommand(CLI::App& app, MsaOptions* options);
int MsaCommand(const MsaOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_MSA_COMMAND_H_
