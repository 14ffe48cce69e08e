#include "cli/report_command.h"

#include <cstdio>
#include <string>

#include "common/exit_codes.h"
#include "common/log.h"
#include "common/text_util.h"
#include "report/report.h"
#include "store/archive.h"

namespace imuqual::cli {
using report::BuildLotReportHtml;

int ReportCommand(const ReportOptions& options) {
  if (options.lot.empty() || options.output.empty() || options.db_path.empty()) {
    LogError("report: --db FILE, --lot LOT and -o FILE.html are required");
    return kExitUsage;
  }
  auto archive = store::Archive::Open(options.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto html = BuildLotReportHtml(**archive, options.lot, options.db_path);
  if (!html.ok()) {
    LogError(html.status().message());
    return kExitError;
  }
  if (options.output == "-") {  // standard output
    return std::fwrite(html->data(), 1, html->size(), stdout) == html->size() &&
                   std::fflush(stdout) == 0
               ? 0
               : kExitError;
  }
  const Status st = WriteStringToFile(options.output, *html);
  if (!st.ok()) {
    LogError(st.message());
    return kExitError;
  }
  return 0;
}

}  // namespace imuqual::cli
