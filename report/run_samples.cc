#include "report/run_samples.h"

#include <cmath>
#include <string>
#include <utility>

#include "common/strings.h"

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

Result<RunWithRate> FindRunWithRate(store::Archive& archive, const std::string& run_id) {
  auto key = archive.FindRunKey(run_id);
  if (!key.ok()) return key.status();
  if (!key->has_value()) return Status::NotFound("no run '" + run_id + "' in " + archive.path());
  auto info = archive.LoadRun(run_id);
  if (!info.ok()) return info.status();
  if (!(info->nominal_rate_hz > 0) || !std::isfinite(info->nominal_rate_hz)) {
    return Status::InvalidArgument("run '" + run_id + "' has no usable sample rate (" +
                                   ShortestReal(info->nominal_rate_hz) + " Hz): no time axis");
  }
  return RunWithRate{**key, std::move(*info)};
}

}  // namespace imuqual::report
