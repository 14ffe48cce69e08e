// ResendBudget: how much a requester may have resent, a token bucket per
// requester (the stations key it by the requesting role its request's seal
// names, not by a name it writes itself, nor by its instance, which a flooder
// could renew at will), so that one process asking again and again (a bug,
// or a compromised host flooding the bus) cannot make a station resend
// faster than the bus should carry, while a process catching up after a
// restart gets the full rate. Bytes, not requests, are counted: a resent batch costs its
// size. Requesters idle longest are forgotten beyond `max_requesters`.
//
// Time is passed in (monotonic seconds). Not thread-safe: one owner thread.
#ifndef IMUQUAL_COMMON_RESEND_BUDGET_H_
#define IMUQUAL_COMMON_RESEND_BUDGET_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <unordered_map>

namespace imuqual {

class ResendBudget {
 public:
  // Each requester may take `bytes_per_s` on average, `burst_bytes` at once.
  ResendBudget(double bytes_per_s, double burst_bytes, size_t max_requesters = 256)
      : rate_(bytes_per_s), burst_(burst_bytes), max_requesters_(max_requesters) {}

  // Takes `bytes` from `requester`'s budget at `now_s`; false (nothing
  // taken) when it does not hold that much now.
  bool Take(uint64_t requester, double bytes, double now_s) {
    auto it = buckets_.find(requester);
    if (it == buckets_.end()) {
      if (buckets_.size() >= max_requesters_) {
        auto idle = std::min_element(
            buckets_.begin(), buckets_.end(),
            [](const auto& a, const auto& b) { return a.second.last_s < b.second.last_s; });
        buckets_.erase(idle);
      }
      it = buckets_.emplace(requester, Bucket{burst_, now_s}).first;
    }
    Bucket& b = it->second;
    b.tokens = std::min(burst_, b.tokens + std::max(0.0, now_s - b.last_s) * rate_);
    b.last_s = now_s;
    if (b.tokens < bytes) return false;
    b.tokens -= bytes;
    return true;
  }
  size_t requesters() const { return buckets_.size(); }

 private:
  struct Bucket {
    double tokens;
    double last_s;
  };
  double rate_, burst_;
  size_t max_requesters_;
  std::unordered_map<uint64_t, Bucket> buckets_;
};

// The budget per requester of a station's resends: on one host (ttl=0)
// 64 MB/s (a restarted analyze catches up at about its analysis speed),
// beyond it 4 MB/s (a 100 Mbit/s line's third), each with 2 s of burst.
inline constexpr double kLocalResendBytesPerS = 64e6;
inline constexpr double kLanResendBytesPerS = 4e6;

// The budget per requester in bytes/s: `configured_mb_per_s` when > 0, else
// the default for a bus of that ttl.
inline double ResendBytesPerS(double configured_mb_per_s, int bus_ttl) {
  if (configured_mb_per_s > 0) return configured_mb_per_s * 1e6;
  return bus_ttl > 0 ? kLanResendBytesPerS : kLocalResendBytesPerS;
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_RESEND_BUDGET_H_
