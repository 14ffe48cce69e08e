#include "acquire/sim_source.h"

#include <algorithm>
#include <cmath>

#include "common/clock.h"

namespace imuqual::acquire {

Result<std::unique_ptr<SimSource>> SimSource::Create(const sim::LotProfile& profile,
                                                     uint64_t lot_seed, int index, double rate_hz,
                                                     double duration_s, double actual_rate_hz) {
  const double rate = rate_hz > 0 ? rate_hz : profile.nominal_rate_hz;
  const double actual = actual_rate_hz > 0 ? actual_rate_hz : rate;
  if (!std::isfinite(actual) || std::abs(actual / rate - 1.0) > 0.5) {
    return Status::InvalidArgument("actual rate must be within 50% of the nominal rate");
  }
  if (!(duration_s > 0) || !std::isfinite(duration_s)) {
    return Status::InvalidArgument("simulated duration must be > 0 s");
  }
  if (!(rate > 0) || !std::isfinite(rate)) return Status::InvalidArgument("rate must be > 0 Hz");
  const int64_t total = std::llround(duration_s * rate);
  if (total < 1) return Status::InvalidArgument("simulated duration is shorter than one sample");
  pb::SimTruth truth = sim::MakeUnitTruth(profile, lot_seed, index, rate);
  truth.set_actual_rate_hz(actual);
  auto simulator = sim::ImuSimulator::Create(truth);
  if (!simulator.ok()) return simulator.status();
  SourceInfo info;
  for (const sim::AxisProfile& a : profile.axes) {
    pb::Axis axis;
    axis.set_name(a.name);
    axis.set_kind(a.kind);
    info.axes.push_back(axis);
  }
  info.nominal_rate_hz = rate;
  info.description = "sim:profile=" + profile.name + ",unit=" + std::to_string(index) +
                     ",seed=" + std::to_string(truth.seed());
  info.truth = truth.SerializeAsString();
  return std::unique_ptr<SimSource>(
      new SimSource(std::move(*simulator), std::move(info), total, NowUtime(), actual));
}

Result<int> SimSource::Read(int max_samples, SampleBlock* block) {
  const int64_t left = total_ - sim_.sample_counter();
  const int n = static_cast<int>(std::min<int64_t>(max_samples, left));
  block->first_sample = sim_.sample_counter();
  // Simulated arrival: the device's own clock read by a perfect host clock.
  block->first_sample_utime =
      start_utime_ + std::llround(static_cast<double>(block->first_sample) / actual_rate_hz_ * 1e6);
  block->flags.clear();
  block->samples.assign(info_.axes.size(), {});
  block->temperature_c = static_cast<float>(sim_.temperature_c());
  if (n <= 0) return 0;
  for (auto& axis : block->samples) axis.reserve(n);
  sim_.Generate(n, block->samples);
  return n;
}

}  // namespace imuqual::acquire
