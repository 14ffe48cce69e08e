// Where a unit's samples come from: a simulator, a file replay or a serial
// device. A source yields consecutive samples with the device's own sample
// counter; acquire batches and publishes them.
#ifndef IMUQUAL_ACQUIRE_SOURCE_H_
#define IMUQUAL_ACQUIRE_SOURCE_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::acquire {

struct SourceInfo {
  std::vector<pb::Axis> axes;   // output order
  double nominal_rate_hz = 0;   // the device's nominal output data rate
  std::string description;      // e.g. "sim:profile=vg700,unit=3"
  std::string truth;            // serialized pb::SimTruth for simulated units, else ""
  bool paced_by_device = false; // true: samples arrive in real time (serial); false: as fast as read
  // Device seconds the source is planned to give (a soak's duration, a
  // recording's length at the nominal rate); 0: not known before it ends.
  double planned_s = 0;
};

struct SampleFlagEntry {
  int sample = 0;  // index in the block
  int axis = 0;
  int bits = 0;    // rate_batch_t FLAG_* bits
};

struct SampleBlock {
  int64_t first_sample = 0;                  // device counter of samples[*][0]
  int64_t first_sample_utime = 0;            // host arrival time of samples[*][0], us (0: none)
  std::vector<std::vector<float>> samples;   // [axis][i]; gyro deg/s, accel m/s^2
  std::vector<SampleFlagEntry> flags;
  std::optional<float> temperature_c;
  int size() const { return samples.empty() ? 0 : static_cast<int>(samples[0].size()); }
};

// Read()'s answer when a real-time source has no block ready yet.
inline constexpr int kNoSamplesYet = -1;

class SampleSource {
 public:
  virtual ~SampleSource() = default;
  virtual const SourceInfo& info() const = 0;
  // Reads up to `max_samples` next consecutive samples into *block (cleared
  // first; samples sized to the axes). Returns how many: 0 means the source
  // has ended, kNoSamplesYet (only sources paced by their device) that the
  // next block is not complete yet. A device counter that jumps between
  // blocks is a gap. Never blocks for long: the caller serves other units.
  virtual Result<int> Read(int max_samples, SampleBlock* block) = 0;
  // Adds this source's health counters (frames, checksum errors,
  // reconnects...) to `counters` (summed over the process's units).
  virtual void AddCounters(std::map<std::string, int64_t>* counters) const { (void)counters; }
  // True while the source's device is gone (or was just reopened and has
  // sent no frame since): its unit waits for a reconnection, not for data.
  virtual bool Reconnecting() const { return false; }
  // Ends the source early (its unit was decided: the run needs no more
  // samples): releases what it holds (the device, its threads, its file)
  // at once rather than when it is destroyed. Read() is not called after.
  // Idempotent; info() and AddCounters() stay valid.
  virtual void Stop() {}
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SOURCE_H_
