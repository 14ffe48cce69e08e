// status_t publishing: every process reports its counters (received,
// dropped, gaps, queue depth, ...) about once a second on IMUQUAL5_STATUS,
// so drops are visible, not silent.
#ifndef IMUQUAL_COMMON_PROCESS_STATUS_H_
#define IMUQUAL_COMMON_PROCESS_STATUS_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/lcm_bus.h"

namespace imuqual {

// "host:pid", unique per running process.
std::string InstanceName();

using Counters = std::vector<std::pair<std::string, int64_t>>;

// Publishes `counters` and the bus's refusals: messages_damaged,
// messages_unauthenticated, messages_replayed.
Status PublishStatus(LcmBus& bus, const std::string& process, bool healthy,
                     const std::string& message, const Counters& counters);

// CPU seconds (user + system, every thread) this process has used so far:
// with the work done, what a process costs per sample.
double ProcessCpuSeconds();

// A latency distribution in bounded memory, for status counters and exit
// summaries: log-spaced buckets (20 per decade, about 12 % wide) of the
// magnitude from 10 us to 1000 s, one set per sign (a latency between two
// clocks can come out negative, and should show as such). A quantile is
// the bucket edge nearer +infinity, so it is never understated; the
// maximum is exact. Not thread-safe: one owner thread.
class LatencyHistogram {
 public:
  void Add(int64_t micros);
  int64_t count() const { return count_; }
  int64_t max_us() const { return max_us_; }
  // The q-quantile (0 < q <= 1) in microseconds; 0 when empty.
  int64_t QuantileUs(double q) const;

 private:
  static constexpr int kPerDecade = 20;
  static constexpr int kDecades = 8;  // 10 us .. 1000 s
  static constexpr int kBuckets = kPerDecade * kDecades + 2;  // + up to 10 us, + beyond 1000 s
  static int BucketOf(int64_t magnitude_us);
  static double UpperEdgeUs(int bucket);
  int64_t positive_[kBuckets] = {};  // latencies >= 0, by magnitude
  int64_t negative_[kBuckets] = {};  // latencies < 0, by magnitude
  int64_t count_ = 0;
  int64_t max_us_ = 0;
};

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_PROCESS_STATUS_H_
