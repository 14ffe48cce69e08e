#include "common/ack.h"

#include "common/channels.h"
#include "common/clock.h"
#include "imuqual/ack_t.hpp"

namespace imuqual {

Status PublishAck(LcmBus& bus, const std::string& role, const std::string& instance,
                  const std::string& run_id, int64_t next_seq, bool run_done) {
  imuqual::ack_t ack;
  ack.host_utime = NowUtime();
  ack.process = role;
  ack.instance = instance;
  ack.run_id = run_id;
  ack.next_seq = next_seq;
  ack.run_done = run_done;
  return bus.Publish(channels::kAck, ack);
}

}  // namespace imuqual
