// The simulator as a source: a unit of a lot profile with seeded truth,
// producing a fixed simulated duration as fast as it is read.
#ifndef IMUQUAL_ACQUIRE_SIM_SOURCE_H_
#define IMUQUAL_ACQUIRE_SIM_SOURCE_H_

#include <memory>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "acquire/source.h"

namespace imuqual::acquire {

class SimSource : public SampleSource {
 public:
  // Unit `index` of `profile` in the lot seeded by `lot_seed`, producing
  // duration_s seconds at the profile's nominal rate (or `rate_hz` if > 0).
  static Result<std::unique_ptr<SimSource>> Create(const sim::LotProfile& profile,
                                                   uint64_t lot_seed, int index, double rate_hz,
                                                   double duration_s);
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;

 private:
  SimSource(sim::ImuSimulator sim, SourceInfo info, int64_t total)
      : sim_(std::move(sim)), info_(std::move(info)), total_(total) {}
  sim::ImuSimulator sim_;
  SourceInfo info_;
  int64_t total_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SIM_SOURCE_H_
