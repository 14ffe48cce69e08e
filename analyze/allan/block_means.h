// Block means of a rate record in bounded memory: what the long-tau
// estimators of a streaming analysis work on (theo_hybrid.h), where the
// streaming engine (streaming.h) keeps no record.
//
// Rate samples y_0, y_1, ... are cut into blocks of B samples aligned to
// sample 0 (block j holds y_{jB}..y_{jB+B-1}). B starts at 1; when
// `capacity` complete blocks are held, neighbouring pairs are merged and B
// doubles, so a record of M samples is held as between capacity/2 and
// capacity blocks (once M >= capacity) of B = 2^ceil(log2(M / capacity))
// samples. The means of complete blocks are a rate record at interval
// B tau0 whose phase is the exact phase x_{jB} of the full record, sampled
// every B points (x_{(j+1)B} - x_{jB} = B tau0 mean_j); estimators on it see
// the full record's phase at those points, i.e. their terms taken every B
// samples at averaging factors that are multiples of B.
//
// Gaps: a block's mean is the mean of its valid samples (not flagged, finite);
// a block with fewer than half its samples valid is invalid (a gap of the
// block record). A few invalid samples inside a block are thus bridged by the
// mean of the others: at averaging times of many blocks (the long taus this
// serves) that changes a term by a fraction of a block's worth of noise,
// while invalidating the block would cut the record's longest gap-free span
// at every isolated bad sample.
//
// Determinism: every sum runs in sample order, so the blocks are the same
// bits whatever the batch boundaries. Thread-compatible.
#ifndef IMUQUAL_ANALYZE_ALLAN_BLOCK_MEANS_H_
#define IMUQUAL_ANALYZE_ALLAN_BLOCK_MEANS_H_

#include <cstdint>
#include <span>
#include <vector>

#include "analyze/allan/phase.h"

namespace imuqual::allan {

class BlockMeans {
 public:
  static constexpr int64_t kDefaultCapacity = 4096;

  // tau0_s > 0; capacity a power of two >= 4 (asserted).
  explicit BlockMeans(double tau0_s, int64_t capacity = kDefaultCapacity);

  // Appends consecutive rate samples (any unit); `invalid` empty or one flag
  // per sample (non-zero: invalid). NaN and +-Inf are invalid too.
  void Append(std::span<const float> rate, std::span<const uint8_t> invalid = {});
  // Appends `count` >= 0 samples that never arrived (invalid).
  void AppendMissing(int64_t count);

  // Samples appended so far (M).
  int64_t samples() const { return samples_; }
  // Samples per block now (B).
  int64_t block_samples() const { return block_; }
  // Complete blocks held.
  int64_t blocks() const { return static_cast<int64_t>(sum_.size()); }
  double tau0_s() const { return tau0_s_; }

  // The complete blocks as a rate record at interval B tau0 turned into
  // phase (PhaseFromRate): block means, invalid blocks flagged. Samples of
  // the incomplete last block are left out.
  PhaseRecord Phase() const;

 private:
  void Add(double value, bool valid);
  void CloseBlock();

  double tau0_s_;
  int64_t capacity_;
  int64_t block_ = 1;
  int64_t samples_ = 0;
  std::vector<double> sum_;     // per complete block: sum of its valid samples
  std::vector<int64_t> valid_;  // per complete block: its valid samples
  double open_sum_ = 0;
  int64_t open_valid_ = 0;
  int64_t open_count_ = 0;
};

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_BLOCK_MEANS_H_
