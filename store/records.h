// Conversions between bus messages and archive records, and the protobuf
// run record (what an MES receives) built from them.
#ifndef IMUQUAL_STORE_RECORDS_H_
#define IMUQUAL_STORE_RECORDS_H_

#include "imuqual/allan_curve_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/record.pb.h"
#include "imuqual/run_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "store/archive.h"
#include "store/run_record.h"

namespace imuqual::store {

RunInfo RunInfoFromMessage(const imuqual::run_t& run);
// `scales`: the run's per-axis quantization scales, carried from chunk to
// chunk (see EncodeChunkCompact).
ChunkRecord ChunkFromBatch(const imuqual::rate_batch_t& batch, std::vector<double>* scales = nullptr);
CurveRecord CurveFromMessage(const imuqual::allan_curve_t& msg);
ResultRecord ResultFromMessage(const imuqual::unit_result_t& msg);

// run_t.STATE_* <-> "running" / "complete" / "aborted" / "incomplete".
const char* StateName(int8_t run_state);
int8_t StateCode(const std::string& state);

// A run as the store re-announces it (announcer "store").
imuqual::run_t MessageFromRunInfo(const RunInfo& info);
// An archived chunk as the batch it was (for resends from the archive).
Result<imuqual::rate_batch_t> BatchFromChunk(const RunInfo& info, const ChunkRecord& chunk);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_RECORDS_H_
