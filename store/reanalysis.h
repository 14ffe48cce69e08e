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

// A run's archived samples as one record per axis, for exact (batch)
// analysis: samples[a][k] is device counter first_counter + k. Missing
// samples between archived chunks (a counter jump or a seq gap) are NaN and
// marked invalid, as are samples flagged saturated or invalid and samples
// out of the run's plan's sensor_range (judge::OutOfRange); chunks whose
// counter goes backwards are skipped (as the live analysis rejects them).
struct RunSamples {
  RunInfo info;
  int64_t first_counter = 0;
  std::vector<std::vector<float>> samples;
  std::vector<std::vector<uint8_t>> invalid;
  int64_t skipped_chunks = 0;
};
Result<RunSamples> LoadRunSamples(Archive& archive, const std::string& run_id);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_REANALYSIS_H_
