// The run record (imuqual.pb.RunRecord): what an MES receives about a run,
// built from what the archive holds about it.
#ifndef IMUQUAL_STORE_RUN_RECORD_H_
#define IMUQUAL_STORE_RUN_RECORD_H_

#include "imuqual/record.pb.h"
#include "store/archive.h"

namespace imuqual::store {

// Run identity, plan, measurements, verdict with reasons, gap statistics.
pb::RunRecord BuildRunRecord(const RunInfo& run, const ResultRecord& result, int64_t gap_ranges);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_RUN_RECORD_H_
