// `imuqual yields`: first-pass and final yields per week, month, station or
// lot across the archive, each with its 95 % interval
// (report/yield_trend.h).
//   imuqual yields --db F [--by week|month|station|lot] [--format]
// Exit 0, 1 the archive could not be read, 2 usage or an empty archive.
#ifndef IMUQUAL_CLI_YIELDS_COMMAND_H_
#define IMUQUAL_CLI_YIELDS_COMMAND_H_

#include <CLI/CLI.hpp>

#include <string>

namespace imuqual::cli {

struct YieldsOptions {
  std::string db_path, by = "week", format = "table";
};

CLI::App* AddYieldsCommand(CLI::App& app, YieldsOptions* options);
int YieldsCommand(const YieldsOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_YIELDS_COMMAND_H_
