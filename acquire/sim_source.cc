#include "acquire/sim_source.h"

#include <algorithm>
#include <cmath>

#include "common/clock.h"
#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {

Result<std::unique_ptr<SimSource>> SimSource::Create(const sim::LotProfile& profile,
                                                     uint64_t lot_seed, int index, double rate_hz,
                                                     double duration_s, const SimOutput& output) {
  const double rate = rate_hz > 0 ? rate_hz : profile.nominal_rate_hz;
  const double actual = output.actual_rate_hz > 0 ? output.actual_rate_hz : rate;
  if (output.lsb < 0 || !std::isfinite(output.lsb) || output.adc_bits < 2 || output.adc_bits > 32) {
    return Status::InvalidArgument("ADC: lsb must be >= 0 and bits 2..32");
  }
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
  if (!output.quantize) {
    for (pb::AxisTruth& a : *truth.mutable_axes()) a.set_quantization(0);
  }
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
  info.planned_s = static_cast<double>(total) / rate;
  info.description = "sim:profile=" + profile.name + ",unit=" + std::to_string(index) +
                     ",seed=" + std::to_string(truth.seed());
  info.truth = truth.SerializeAsString();
  return std::unique_ptr<SimSource>(
      new SimSource(std::move(*simulator), std::move(info), total, /*start_utime=*/0, actual, output));
}

SimSource::~SimSource() { Stop(); }

void SimSource::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (generator_.joinable()) generator_.join();
  std::lock_guard<std::mutex> lock(mu_);
  ready_.clear();
}

void SimSource::Generate(int max_samples, SampleBlock* block) {
  const int64_t left = total_ - sim_.sample_counter();
  const int n = static_cast<int>(std::min<int64_t>(max_samples, left));
  block->first_sample = sim_.sample_counter();
  block->flags.clear();
  block->samples.assign(info_.axes.size(), {});
  block->temperature_c = static_cast<float>(sim_.temperature_c());
  if (n <= 0) return;
  for (auto& axis : block->samples) axis.reserve(n);
  sim_.Generate(n, block->samples);
  if (output_.lsb > 0) {
    // The ADC: whole LSBs, clipped (and flagged) at full scale. The archived
    // truth leaves out the ADC's own rounding (white, lsb^2/12 per sample).
    const double full = std::ldexp(1.0, output_.adc_bits - 1) - 1;
    for (size_t a = 0; a < block->samples.size(); ++a) {
      for (int i = 0; i < n; ++i) {
        float& v = block->samples[a][static_cast<size_t>(i)];
        double k = std::nearbyint(static_cast<double>(v) / output_.lsb);
        if (std::abs(k) > full) {
          k = std::copysign(full, k);
          block->flags.push_back({i, static_cast<int>(a), imuqual::rate_batch_t::FLAG_SATURATED});
        }
        v = static_cast<float>(k * output_.lsb);
      }
    }
  }
}

void SimSource::GenerateAhead(int block_samples) {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [&] { return stop_ || ready_.size() < kBlocksAhead; });
      if (stop_) return;
    }
    SampleBlock block;
    Generate(block_samples, &block);
    const bool end = block.size() == 0;
    {
      std::lock_guard<std::mutex> lock(mu_);
      ready_.push_back(std::move(block));
    }
    cv_.notify_all();
    if (end) return;
  }
}

Result<int> SimSource::Read(int max_samples, SampleBlock* block) {
  if (max_samples < 1) return Status::InvalidArgument("max_samples must be >= 1");
  if (!generator_.joinable()) {
    generator_ = std::thread([this, max_samples] { GenerateAhead(max_samples); });
  }
  if (current_offset_ >= current_.size() && !ended_) {
    {
      std::unique_lock<std::mutex> lock(mu_);
      // At most one block's generation away: the thread keeps kBlocksAhead ready.
      cv_.wait(lock, [&] { return !ready_.empty(); });
      current_ = std::move(ready_.front());
      ready_.pop_front();
    }
    cv_.notify_all();
    current_offset_ = 0;
    ended_ = current_.size() == 0;
  }
  if (start_utime_ == 0) {
    // The simulated clock starts with the first block read, its newest
    // sample taken now (in real time that is when a device would send it).
    start_utime_ = NowUtime() - std::llround(static_cast<double>(std::max(0, current_.size() - 1)) /
                                             actual_rate_hz_ * 1e6);
  }
  block->first_sample = current_.first_sample + current_offset_;
  // Simulated arrival: the device's own clock read by a perfect host clock.
  block->first_sample_utime =
      start_utime_ + std::llround(static_cast<double>(block->first_sample) / actual_rate_hz_ * 1e6);
  block->temperature_c = current_.temperature_c;
  block->flags.clear();
  block->samples.assign(info_.axes.size(), {});
  const int n = std::min(max_samples, current_.size() - current_offset_);
  if (n <= 0) return 0;  // the end
  if (current_offset_ == 0 && n == current_.size()) {
    // The whole block as generated (the usual case): moved, not copied.
    block->samples = std::move(current_.samples);
    block->flags = std::move(current_.flags);
    current_ = SampleBlock();
    current_offset_ = 0;
    return n;
  }
  for (size_t a = 0; a < current_.samples.size(); ++a) {
    const auto from = current_.samples[a].begin() + current_offset_;
    block->samples[a].assign(from, from + n);
  }
  for (const SampleFlagEntry& f : current_.flags) {
    if (f.sample >= current_offset_ && f.sample < current_offset_ + n) {
      block->flags.push_back({f.sample - current_offset_, f.axis, f.bits});
    }
  }
  current_offset_ += n;
  return n;
}

}  // namespace imuqual::acquire
