#include "report/run_samples.h"

#include <string>

namespace imuqual::report {

Result<RunSampleWalk> WalkRunSamples(store::Archive& archive, int64_t run_key,
                                     const store::RunInfo& info, const RunSampleVisitor& visitor) {
  RunSampleWalk walk;
  const double rate = info.nominal_rate_hz;
  const size_t axes = info.axes.size();
  int64_t next = -1;
  const Status st = archive.ForEachChunk(run_key, [&](const store::ChunkRecord& c) -> Status {
    auto chunk = store::DecodeChunk(c.data, c.codec);
    if (!chunk.ok())
      return chunk.status().WithContext("run " + info.run_id + " seq " + std::to_string(c.seq));
    if (static_cast<size_t>(chunk->num_axes) != axes || (next >= 0 && c.first_sample < next)) {
      ++walk.skipped;  // as the analysis rejects it: wrong axes or the counter went back
      return Status::Ok();
    }
    if (walk.first < 0) walk.first = next = c.first_sample;
    if (rate > 0 && static_cast<double>(c.first_sample - next) / rate > kLongestFilledGapS) {
      ++walk.skipped;
      return Status::Ok();
    }
    if (c.first_sample > next && visitor.missing) {
      const Status m = visitor.missing(walk.first, next, c.first_sample - next);
      if (!m.ok()) return m;
    }
    if (visitor.chunk) {
      const Status v = visitor.chunk(walk.first, c, *chunk);
      if (!v.ok()) return v;
    }
    next = c.first_sample + chunk->num_samples;
    return Status::Ok();
  });
  if (!st.ok()) return st;
  walk.end = next;
  return walk;
}

}  // namespace imuqual::report
