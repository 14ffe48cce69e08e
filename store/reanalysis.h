// Re-analysis of an archived run: the archived chunks, in seq order, through
// the same RunAnalyzer the analyze process used live, so the result is the
// live result bit for bit (whenever the live analysis saw the same batches).
#ifndef IMUQUAL_STORE_REANALYSIS_H_
#define IMUQUAL_STORE_REANALYSIS_H_

#include <string>

#include "analyze/service/run_analyzer.h"
#include "common/status.h"
#include "store/archive.h"

namespace imuqual::store {

// The run's description (axes, rate, plan) as archived.
Result<analyze::RunDescription> DescribeRun(const RunInfo& run);

Result<analyze::RunOutcome> ReanalyzeRun(Archive& archive, const std::string& run_id,
                                         const analyze::AnalyzerOptions& options = {});

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_REANALYSIS_H_
