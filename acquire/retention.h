// The batches acquire keeps for resends, per run. Acknowledged batches are
// kept for a while (`keep`: the flow-control window plus retention_s of
// data); unacknowledged ones are kept until an awaited consumer (the store)
// has them, however long that takes (a full disk that is freed), bounded by
// memory: beyond max_bytes the oldest go, and every one that goes is data
// the consumer never confirmed: counted, and warned about loudly.
// Not thread-safe: acquire's loop owns it.
#ifndef IMUQUAL_ACQUIRE_RETENTION_H_
#define IMUQUAL_ACQUIRE_RETENTION_H_

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace imuqual::acquire {

struct RetainedBatch {
  int64_t seq = 0;
  double sent_s = 0;
  std::vector<uint8_t> bytes;  // the encoded rate_batch_t
  double resent_s = -1e300;    // last resend: consumers often ask for the same hole together
};

class Retention {
 public:
  // Batches arrive in seq order.
  void Add(RetainedBatch batch);
  // The retained batch `seq`, or nullptr.
  RetainedBatch* Find(int64_t seq);
  bool empty() const { return batches_.empty(); }
  size_t size() const { return batches_.size(); }
  int64_t first_seq() const { return batches_.empty() ? -1 : batches_.front().seq; }
  int64_t bytes() const { return bytes_; }

  struct Pruned {
    int64_t unacknowledged = 0;  // batches dropped that a consumer had not acknowledged
    int64_t first_seq = -1;      // their seq range (-1: none)
    int64_t last_seq = -1;
  };
  // Drops the oldest batches below `acknowledged` (every awaited consumer's
  // next seq) while more than `keep` are held, then the oldest of any kind
  // while more than `max_bytes` are held.
  Pruned Prune(size_t keep, int64_t acknowledged, int64_t max_bytes);

 private:
  std::deque<RetainedBatch> batches_;
  int64_t bytes_ = 0;
};

// The warning for batches dropped unacknowledged (status_t, console, log).
std::string RetentionExceededWarning(const std::string& run_id, const Retention::Pruned& pruned,
                                     int limit_mb);

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_RETENTION_H_
