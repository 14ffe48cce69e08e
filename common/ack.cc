#include "common/ack.h"

#include <algorithm>

#include "common/channels.h"
#include "common/clock.h"

namespace imuqual {

void AckBatch::Add(const std::string& run_id, int64_t next_seq, bool run_done, bool urgent) {
  urgent_ = urgent_ || urgent;
  for (size_t i = 0; i < run_ids_.size(); ++i) {
    if (run_ids_[i] == run_id) {  // said twice before a flush: the furthest word
      next_seq_[i] = std::max(next_seq_[i], next_seq);
      run_done_[i] = run_done_[i] || run_done;
      return;
    }
  }
  run_ids_.push_back(run_id);
  next_seq_.push_back(next_seq);
  run_done_.push_back(run_done);
}

Status AckBatch::Flush(LcmBus& bus) {
  Status first_error;
  for (size_t at = 0; at < run_ids_.size();) {
    // As many runs as fit kAckEntryBytes (at least one).
    size_t end = at, bytes = 0;
    while (end < run_ids_.size()) {
      const size_t entry = 4 + run_ids_[end].size() + 1 + 8 + 1;
      if (end > at && bytes + entry > kAckEntryBytes) break;
      bytes += entry;
      ++end;
    }
    imuqual::ack_t ack;
    ack.host_utime = NowUtime();
    ack.process = role_;
    ack.instance = instance_;
    ack.num_runs = static_cast<int16_t>(end - at);
    ack.run_ids.assign(run_ids_.begin() + static_cast<long>(at),
                       run_ids_.begin() + static_cast<long>(end));
    ack.next_seq.assign(next_seq_.begin() + static_cast<long>(at),
                        next_seq_.begin() + static_cast<long>(end));
    ack.run_done.assign(run_done_.begin() + static_cast<long>(at),
                        run_done_.begin() + static_cast<long>(end));
    Status st = bus.Publish(channels::kAck, ack);
    if (!st.ok() && first_error.ok()) first_error = st;
    at = end;
  }
  run_ids_.clear();
  next_seq_.clear();
  run_done_.clear();
  urgent_ = false;
  return first_error;
}

Status AckBatch::FlushIfDue(LcmBus& bus, double now_s) {
  if (run_ids_.empty()) return Status::Ok();
  if (!urgent_ && now_s - last_flush_s_ < kAckFlushPeriodS) return Status::Ok();
  last_flush_s_ = now_s;
  return Flush(bus);
}

Status PublishAck(LcmBus& bus, const std::string& role, const std::string& instance,
                  const std::string& run_id, int64_t next_seq, bool run_done) {
  AckBatch batch(role, instance);
  batch.Add(run_id, next_seq, run_done);
  return batch.Flush(bus);
}

}  // namespace imuqual
