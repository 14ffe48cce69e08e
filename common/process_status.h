// status_t publishing: every process reports its counters (received,
// dropped, gaps, queue depth, ...) about once a second on IMUQUAL1_STATUS,
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

Status PublishStatus(LcmBus& bus, const std::string& process, bool healthy,
                     const std::string& message, const Counters& counters);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_PROCESS_STATUS_H_
