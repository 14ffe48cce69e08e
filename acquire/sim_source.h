// The simulator as a source: a unit of a lot profile with seeded truth,
// producing a fixed simulated duration as fast as it is read. Blocks carry
// simulated arrival times (sample k arrives k / actual_rate_hz after the
// start), so the station measures the simulated device's real rate.
//
// The simulation runs a block or two ahead on a thread of its own: in a
// time-warped soak it is most of acquire's work, and acquire's publishing
// loop (one thread for every unit) would otherwise hold the whole station
// to one core. The samples are the simulator's sequence whichever thread
// draws them. Blocks are generated in the size of the first Read(); a later,
// smaller request is served from the current block (carrying that block's
// temperature).
#ifndef IMUQUAL_ACQUIRE_SIM_SOURCE_H_
#define IMUQUAL_ACQUIRE_SIM_SOURCE_H_

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

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
  ~SimSource() override;
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;
  // Ends the generating thread (joined) and drops the blocks it made ahead.
  void Stop() override;

 private:
  SimSource(sim::ImuSimulator sim, SourceInfo info, int64_t total, int64_t start_utime,
            double actual_rate_hz, SimOutput output)
      : sim_(std::move(sim)), info_(std::move(info)), total_(total), start_utime_(start_utime),
        actual_rate_hz_(actual_rate_hz), output_(output) {}
  // The simulator's next block of up to max_samples samples (the
  // generating thread only, once it runs).
  void Generate(int max_samples, SampleBlock* block);
  // The generating thread: keeps kBlocksAhead blocks ready, then the end.
  void GenerateAhead(int block_samples);

  sim::ImuSimulator sim_;  // the generating thread's once it runs
  SourceInfo info_;
  int64_t total_;
  int64_t start_utime_;
  double actual_rate_hz_;
  SimOutput output_;

  static constexpr size_t kBlocksAhead = 2;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<SampleBlock> ready_;  // generated, not yet read; an empty block: the end
  bool stop_ = false;
  std::thread generator_;
  SampleBlock current_;            // the block being read (empty once read whole)
  int current_offset_ = 0;         // samples of it already read (smaller requests)
  bool ended_ = false;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SIM_SOURCE_H_
