// Acknowledgements for flow control (ack_t): consumers tell acquire how far
// each run has been durably handled. AckPacer decides when to send: soon
// after progress (but not per batch), and periodically anyway because an ack
// can be lost like any datagram.
#ifndef IMUQUAL_COMMON_ACK_H_
#define IMUQUAL_COMMON_ACK_H_

#include <cstdint>
#include <string>

#include "common/lcm_bus.h"

namespace imuqual {

class AckPacer {
 public:
  // Whether to send an ack for `next_seq` now (`force`: always).
  bool Due(int64_t next_seq, bool done, double now_s, bool force) const {
    if (force) return true;
    const double since = now_s - last_s_;
    const bool progressed = next_seq != last_seq_ || done != last_done_;
    if (progressed && (since >= kProgressPeriodS || next_seq - last_seq_ >= kProgressBatches)) {
      return true;
    }
    return since >= (done ? kDoneRepeatS : kRepeatS);
  }
  void Sent(int64_t next_seq, bool done, double now_s) {
    last_seq_ = next_seq;
    last_done_ = done;
    last_s_ = now_s;
  }

 private:
  static constexpr double kProgressPeriodS = 0.02;
  static constexpr int64_t kProgressBatches = 16;
  static constexpr double kRepeatS = 0.5;
  static constexpr double kDoneRepeatS = 1.0;
  int64_t last_seq_ = -1;
  bool last_done_ = false;
  double last_s_ = -1e9;
};

// Publishes one ack_t on IMUQUAL5_ACK.
Status PublishAck(LcmBus& bus, const std::string& role, const std::string& instance,
                  const std::string& run_id, int64_t next_seq, bool run_done);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_ACK_H_
