#include "common/clock.h"

#include <ctime>

namespace imuqual {

std::string FormatUtimeIso(int64_t utime) {
  std::time_t secs = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace imuqual
