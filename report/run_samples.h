// A run's archived samples in device-counter order, as the analysis takes
// them: chunks whose axes differ from the run's, whose counter went back, or
// that jump more than a day of samples ahead are left out (counted), and the
// counters between two archived chunks are reported as missing. Used by
// `export --format samples` and by the time-series plot.
#ifndef IMUQUAL_REPORT_RUN_SAMPLES_H_
#define IMUQUAL_REPORT_RUN_SAMPLES_H_

#include <cstdint>
#include <functional>
#include <string>

#include "common/status.h"
#include "store/archive.h"
#include "store/chunk_codec.h"

namespace imuqual::report {

struct RunSampleVisitor {
  // Counters [from, from + count) that no archived chunk holds. `first` is
  // the run's first archived counter (device time 0).
  std::function<Status(int64_t first, int64_t from, int64_t count)> missing;
  // One archived chunk, its samples at counters c.first_sample + i.
  std::function<Status(int64_t first, const store::ChunkRecord& c, const store::ChunkData& d)>
      chunk;
};

struct RunSampleWalk {
  int64_t first = -1;   // first archived counter, -1: no sample
  int64_t end = -1;     // one past the last counter walked
  int64_t skipped = 0;  // chunks left out (see above)
};

// A counter jump beyond this many seconds of samples is a corrupt counter:
// the analysis refuses that chunk (and, its expected counter unchanged, every
// later one), and so does this walk.
inline constexpr double kLongestFilledGapS = 86400.0;

// Walks `info`'s chunks (run key `run_key`). Errors name the run and the
// chunk's seq for an undecodable chunk, and pass on a visitor's error.
Result<RunSampleWalk> WalkRunSamples(store::Archive& archive, int64_t run_key,
                                     const store::RunInfo& info, const RunSampleVisitor& visitor);

// A stored run whose samples can be put on a time axis: its key and its
// info. NotFound names the run; InvalidArgument when its sample rate is not
// a positive number (no time axis).
struct RunWithRate {
  int64_t key = 0;
  store::RunInfo info;
};
Result<RunWithRate> FindRunWithRate(store::Archive& archive, const std::string& run_id);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_RUN_SAMPLES_H_
