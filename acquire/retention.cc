#include "acquire/retention.h"

#include <algorithm>

namespace imuqual::acquire {

void Retention::Add(RetainedBatch batch) {
  bytes_ += static_cast<int64_t>(batch.bytes.size());
  batches_.push_back(std::move(batch));
}

RetainedBatch* Retention::Find(int64_t seq) {
  auto it = std::lower_bound(batches_.begin(), batches_.end(), seq,
                             [](const RetainedBatch& r, int64_t s) { return r.seq < s; });
  return it == batches_.end() || it->seq != seq ? nullptr : &*it;
}

Retention::Pruned Retention::Prune(size_t keep, int64_t acknowledged, int64_t max_bytes) {
  Pruned out;
  auto drop_front = [&] {
    const RetainedBatch& b = batches_.front();
    if (b.seq >= acknowledged) {
      if (out.unacknowledged++ == 0) out.first_seq = b.seq;
      out.last_seq = b.seq;
    }
    bytes_ -= static_cast<int64_t>(b.bytes.size());
    batches_.pop_front();
  };
  while (batches_.size() > keep && batches_.front().seq < acknowledged) drop_front();
  while (!batches_.empty() && bytes_ > max_bytes) drop_front();
  return out;
}

std::string RetentionExceededWarning(const std::string& run_id, const Retention::Pruned& pruned,
                                     int limit_mb) {
  return "retention limit of " + std::to_string(limit_mb) + " MB exceeded: run " + run_id +
         " dropped " + std::to_string(pruned.unacknowledged) + " unacknowledged batches (seq " +
         std::to_string(pruned.first_seq) + ".." + std::to_string(pruned.last_seq) +
         "); unless a consumer archived them they are lost (raise --retention-mb)";
}

}  // namespace imuqual::acquire
