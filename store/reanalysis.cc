#include "store/reanalysis.h"

#include <cmath>

#include "analyze/judge/plan.h"
#include "store/chunk_codec.h"

namespace imuqual::store {

Result<analyze::RunDescription> DescribeRun(const RunInfo& run) {
  analyze::RunDescription d;
  d.run_id = run.run_id;
  d.serial = run.serial;
  d.nominal_rate_hz = run.nominal_rate_hz;
  for (const AxisInfo& a : run.axes) d.axes.push_back({a.name, a.kind});
  if (!d.plan.ParseFromString(run.plan)) {
    return Status::Corruption("run " + run.run_id + ": the archived plan does not decode");
  }
  IMUQUAL_RETURN_IF_ERROR(judge::ValidatePlan(d.plan).WithContext("run " + run.run_id + " plan"));
  return d;
}

Result<analyze::RunOutcome> ReanalyzeRun(Archive& archive, const std::string& run_id,
                                         const analyze::AnalyzerOptions& options) {
  auto run = archive.LoadRun(run_id);
  if (!run.ok()) return run.status();
  auto key = archive.FindRunKey(run_id);
  if (!key.ok()) return key.status();
  auto desc = DescribeRun(*run);
  if (!desc.ok()) return desc.status();
  auto analyzer = analyze::RunAnalyzer::Create(std::move(*desc), options);
  if (!analyzer.ok()) return analyzer.status();
  Status st = archive.ForEachChunk(**key, [&](const ChunkRecord& c) -> Status {
    auto chunk = DecodeChunk(c.data, c.codec);
    if (!chunk.ok())
      return chunk.status().WithContext("run " + run_id + " seq " + std::to_string(c.seq));
    analyze::BatchView view;
    view.seq = c.seq;
    view.first_sample = c.first_sample;
    view.sample_utime = c.sample_utime;
    view.nominal_rate_hz = run->nominal_rate_hz;
    view.temperature_c = c.temperature_c;
    for (int a = 0; a < chunk->num_axes; ++a) {
      view.samples.emplace_back(chunk->samples.data() + static_cast<size_t>(a) * chunk->num_samples,
                                static_cast<size_t>(chunk->num_samples));
    }
    for (const SampleFlag& f : chunk->flags) view.flags.push_back({f.sample, f.axis, f.bits});
    // A batch the live analysis rejected is rejected here too, for the same reason.
    (void)analyzer->AddBatch(view);
    return Status::Ok();
  });
  if (!st.ok()) return st;
  analyzer->Finish(run->first_sample, run->end_sample);
  return analyzer->Outcome(true, analyze::FailureForRunState(run->state, run->end_reason));
}

Result<RunSamples> LoadRunSamples(Archive& archive, const std::string& run_id) {
  RunSamples out;
  auto run = archive.LoadRun(run_id);
  if (!run.ok()) return run.status();
  out.info = std::move(*run);
  auto key = archive.FindRunKey(run_id);
  if (!key.ok()) return key.status();
  const size_t axes = out.info.axes.size();
  out.samples.assign(axes, {});
  out.invalid.assign(axes, {});
  pb::TestPlan plan;  // a run without a decodable plan has no sensor range
  if (!plan.ParseFromString(out.info.plan)) plan.Clear();
  std::vector<double> out_of_range_at;
  for (const AxisInfo& a : out.info.axes) {
    out_of_range_at.push_back(judge::OutOfRangeAt(plan, a.kind));
  }
  int64_t next = -1;
  Status st = archive.ForEachChunk(**key, [&](const ChunkRecord& c) -> Status {
    auto chunk = DecodeChunk(c.data, c.codec);
    if (!chunk.ok())
      return chunk.status().WithContext("run " + run_id + " seq " + std::to_string(c.seq));
    if (static_cast<size_t>(chunk->num_axes) != axes || (next >= 0 && c.first_sample < next)) {
      ++out.skipped_chunks;
      return Status::Ok();
    }
    if (next < 0) {
      out.first_counter = c.first_sample;
      next = c.first_sample;
    }
    const int64_t missing = c.first_sample - next;
    for (size_t a = 0; a < axes; ++a) {
      out.samples[a].insert(out.samples[a].end(), static_cast<size_t>(missing), std::nanf(""));
      out.invalid[a].insert(out.invalid[a].end(), static_cast<size_t>(missing), 1);
      const size_t at = out.samples[a].size();
      for (int i = 0; i < chunk->num_samples; ++i)
        out.samples[a].push_back(chunk->at(static_cast<int>(a), i));
      out.invalid[a].resize(at + chunk->num_samples, 0);
    }
    for (const SampleFlag& f : chunk->flags) {
      if (f.bits & (1 | 2)) {  // saturated or invalid
        out.invalid[f.axis][out.samples[f.axis].size() - chunk->num_samples + f.sample] = 1;
      }
    }
    // Beyond the plan's sensor range, as the analysis reads them.
    for (size_t a = 0; a < axes; ++a) {
      if (!std::isfinite(out_of_range_at[a])) continue;
      const size_t from = out.samples[a].size() - static_cast<size_t>(chunk->num_samples);
      for (size_t k = from; k < out.samples[a].size(); ++k) {
        if (judge::OutOfRange(out.samples[a][k], out_of_range_at[a])) out.invalid[a][k] = 1;
      }
    }
    next = c.first_sample + chunk->num_samples;
    return Status::Ok();
  });
  if (!st.ok()) return st;
  return out;
}

}  // namespace imuqual::store
