// The simulator as a source: a unit of a lot profile with seeded truth,
// producing a fixed simulated duration as fast as it is read. Blocks carry
// simulated arrival times (sample k arrives k / actual_rate_hz after the
// start), so the station measures the simulated device's real rate.
#ifndef IMUQUAL_ACQUIRE_SIM_SOURCE_H_
#define IMUQUAL_ACQUIRE_SIM_SOURCE_H_

#include <memory>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "acquire/source.h"

namespace imuqual::acquire {

// How the simulated device outputs its samples.
struct SimOutput {
  double actual_rate_hz = 0;  // > 0: the device really samples at this rate (off nominal)
  bool quantize = true;       // false: no quantization term Q (float output, as a
                              // device that integrates internally would give)
  double lsb = 0;             // > 0: an ADC: whole LSBs, saturating at +-(2^(bits-1) - 1)
  int adc_bits = 16;
};

class SimSource : public SampleSource {
 public:
  // Unit `index` of `profile` in the lot seeded by `lot_seed`, producing
  // duration_s seconds at the profile's nominal rate (or `rate_hz` if > 0).
  static Result<std::unique_ptr<SimSource>> Create(const sim::LotProfile& profile,
                                                   uint64_t lot_seed, int index, double rate_hz,
                                                   double duration_s, const SimOutput& output = {});
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;

 private:
  SimSource(sim::ImuSimulator sim, SourceInfo info, int64_t total, int64_t start_utime,
            double actual_rate_hz, SimOutput output)
      : sim_(std::move(sim)), info_(std::move(info)), total_(total), start_utime_(start_utime),
        actual_rate_hz_(actual_rate_hz), output_(output) {}
  sim::ImuSimulator sim_;
  SourceInfo info_;
  int64_t total_;
  int64_t start_utime_;
  double actual_rate_hz_;
  SimOutput output_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SIM_SOURCE_H_
