#include "common/process_status.h"

#include <unistd.h>

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
  msg.num_counters = static_cast<int16_t>(counters.size());
  for (const auto& [name, value] : counters) {
    msg.counter_names.push_back(name);
    msg.counter_values.push_back(value);
  }
  return bus.Publish(channels::kStatus, msg);
}

}  // namespace imuqual
