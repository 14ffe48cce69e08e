// Acknowledgements for flow control (ack_t): consumers tell acquire how far
// each run has been durably handled. AckPacer decides when a run's
// acknowledgement is due: soon after progress (but not per batch), and
// periodically anyway because an ack can be lost like any datagram. A
// consumer gathers its due acknowledgements in an AckBatch and sends them
// together (several runs per message).
#ifndef IMUQUAL_COMMON_ACK_H_
#define IMUQUAL_COMMON_ACK_H_

#include <cstdint>
#include <string>

#include "common/lcm_bus.h"
#include "imuqual/ack_t.hpp"

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
  // Whether the ack Due() allowed cannot wait for its batch's next flush
  // (AckBatch::FlushIfDue): a run newly done, or progress of a flow-control
  // window's quarter (a time-warped source waits on it).
  bool Urgent(int64_t next_seq, bool done) const {
    return (done && !last_done_) || next_seq - last_seq_ >= kProgressBatches;
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

// The run entries of one ack_t message fill at most this many encoded
// bytes (a run id's length word, its bytes and NUL, next_seq, run_done), so
// that the message, its seal and signature included, goes in one 1400-byte
// datagram (a station LAN loses a fragmented message whole if any fragment
// is lost): about 20 runs of the usual 30-byte ids, 5 of the longest (160).
inline constexpr size_t kAckEntryBytes = 900;
// A consumer's acknowledgements go out together at most this often, except
// urgent ones (AckPacer::Urgent: a run newly done, or a time-warped run's
// progress that its flow-control window waits on): every message is signed
// and every listener verifies it, so in a paced soak one message carries the
// runs that progressed in 200 ms, not one message per run per batch (at 64
// runs and 50 ms the acknowledgements were still most of the signatures
// every listener checked).
inline constexpr double kAckFlushPeriodS = 0.2;

// A consumer's acknowledgements of several runs, sent as one or a few
// ack_t messages. Not thread-safe: one owner thread.
class AckBatch {
 public:
  AckBatch(std::string role, std::string instance)
      : role_(std::move(role)), instance_(std::move(instance)) {}
  // A run added twice before a flush keeps the furthest word (the higher
  // next_seq; done if either said so). `urgent`: the next FlushIfDue sends
  // at once (AckPacer::Urgent).
  void Add(const std::string& run_id, int64_t next_seq, bool run_done, bool urgent = false);
  bool empty() const { return run_ids_.empty(); }
  size_t size() const { return run_ids_.size(); }
  // Publishes what was added (as many runs per message as kAckEntryBytes
  // holds) and clears it; the first publish error, if any (the rest is
  // still sent).
  Status Flush(LcmBus& bus);
  // Flush when kAckFlushPeriodS has passed since the last flush, or at once
  // when something urgent was added; otherwise keeps what was added for a
  // later call.
  // `now_s`: a monotonic clock.
  Status FlushIfDue(LcmBus& bus, double now_s);

 private:
  std::string role_, instance_;
  std::vector<std::string> run_ids_;
  std::vector<int64_t> next_seq_;
  std::vector<bool> run_done_;
  bool urgent_ = false;
  double last_flush_s_ = -1e9;
};

// Publishes one ack_t of one run on IMUQUAL5_ACK.
Status PublishAck(LcmBus& bus, const std::string& role, const std::string& instance,
                  const std::string& run_id, int64_t next_seq, bool run_done);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_ACK_H_
