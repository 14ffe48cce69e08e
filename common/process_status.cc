#include "common/process_status.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "common/channels.h"
#include "common/clock.h"
#include "imuqual/status_t.hpp"

namespace imuqual {

std::string InstanceName() {
  char host[256] = {0};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  return std::string(host[0] ? host : "host") + ":" + std::to_string(::getpid());
}

Status PublishStatus(LcmBus& bus, const std::string& process, bool healthy,
                     const std::string& message, const Counters& counters) {
  imuqual::status_t msg;
  msg.host_utime = NowUtime();
  msg.process = process;
  msg.instance = InstanceName();
  msg.healthy = healthy ? 1 : 0;
  msg.message = message;
  // Every process says what its bus refused (README, "Trust").
  Counters all = counters;
  all.emplace_back("messages_damaged", static_cast<int64_t>(bus.damaged()));
  all.emplace_back("messages_unauthenticated", static_cast<int64_t>(bus.unauthenticated()));
  all.emplace_back("messages_replayed", static_cast<int64_t>(bus.replayed()));
  msg.num_counters = static_cast<int16_t>(all.size());
  for (const auto& [name, value] : all) {
    msg.counter_names.push_back(name);
    msg.counter_values.push_back(value);
  }
  return bus.Publish(channels::kStatus, msg);
}

double ProcessCpuSeconds() {
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) * 1e-6;
}

// Bucket 0 holds magnitudes up to 10 us; bucket b (1..kPerDecade*kDecades)
// holds (10 us * 10^((b-1)/kPerDecade), 10 us * 10^(b/kPerDecade)]; the
// last one everything beyond 1000 s.
int LatencyHistogram::BucketOf(int64_t magnitude_us) {
  if (magnitude_us <= 10) return 0;
  const double b = std::ceil(std::log10(static_cast<double>(magnitude_us) / 10.0) * kPerDecade - 1e-9);
  return static_cast<int>(std::clamp(b, 1.0, static_cast<double>(kBuckets - 1)));
}

double LatencyHistogram::UpperEdgeUs(int bucket) {
  return 10.0 * std::pow(10.0, static_cast<double>(bucket) / kPerDecade);
}

void LatencyHistogram::Add(int64_t micros) {
  max_us_ = count_ == 0 ? micros : std::max(max_us_, micros);
  ++count_;
  if (micros < 0) {
    ++negative_[BucketOf(-micros)];
  } else {
    ++positive_[BucketOf(micros)];
  }
}

int64_t LatencyHistogram::QuantileUs(double q) const {
  if (count_ == 0) return 0;
  const int64_t rank =
      std::clamp<int64_t>(static_cast<int64_t>(std::ceil(q * static_cast<double>(count_))), 1, count_);
  int64_t seen = 0;
  // From the most negative up: a negative bucket's edge nearer +infinity is
  // its smaller magnitude.
  for (int b = kBuckets - 1; b >= 0; --b) {
    seen += negative_[b];
    if (seen >= rank) {
      return std::min(b == 0 ? int64_t{0} : -static_cast<int64_t>(std::floor(UpperEdgeUs(b - 1))),
                      max_us_);
    }
  }
  for (int b = 0; b < kBuckets; ++b) {
    seen += positive_[b];
    if (seen >= rank) {
      // The overflow bucket has no upper edge; the maximum bounds every bucket.
      if (b == kBuckets - 1) return max_us_;
      return std::min(static_cast<int64_t>(std::ceil(UpperEdgeUs(b))), max_us_);
    }
  }
  return max_us_;
}

}  // namespace imuqual
