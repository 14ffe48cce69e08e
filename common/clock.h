// Host wall clock, for stamping messages and records only. Nothing in the
// analysis depends on it: analysis runs on the device sample counter.
#ifndef IMUQUAL_COMMON_CLOCK_H_
#define IMUQUAL_COMMON_CLOCK_H_

#include <chrono>
#include <ctime>
#include <cstdint>
#include <string>

namespace imuqual {

// Microseconds since the Unix epoch.
inline int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Monotonic seconds, for timeouts and rates.
inline double MonotonicSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// "2026-11-21T11:05:00Z" (UTC, second resolution).
inline std::string FormatUtimeIso(int64_t utime) {
  std::time_t secs = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_CLOCK_H_
