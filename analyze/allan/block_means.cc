#include "analyze/allan/block_means.h"

#include <cassert>
#include <cmath>

namespace imuqual::allan {

BlockMeans::BlockMeans(double tau0_s, int64_t capacity) : tau0_s_(tau0_s), capacity_(capacity) {
  assert(tau0_s > 0 && std::isfinite(tau0_s));
  assert(capacity >= 4 && (capacity & (capacity - 1)) == 0);
  sum_.reserve(static_cast<size_t>(capacity));
  valid_.reserve(static_cast<size_t>(capacity));
}

void BlockMeans::Add(double value, bool valid) {
  if (valid) {
    open_sum_ += value;
    ++open_valid_;
  }
  ++samples_;
  if (++open_count_ == block_) CloseBlock();
}

void BlockMeans::CloseBlock() {
  sum_.push_back(open_sum_);
  valid_.push_back(open_valid_);
  open_sum_ = 0;
  open_valid_ = 0;
  open_count_ = 0;
  if (static_cast<int64_t>(sum_.size()) < capacity_) return;
  // Full: merge neighbouring pairs (block j of the new size is blocks 2j and
  // 2j+1 of the old one, both aligned to sample 0 since capacity is even).
  const size_t half = sum_.size() / 2;
  for (size_t j = 0; j < half; ++j) {
    sum_[j] = sum_[2 * j] + sum_[2 * j + 1];
    valid_[j] = valid_[2 * j] + valid_[2 * j + 1];
  }
  sum_.resize(half);
  valid_.resize(half);
  block_ *= 2;
}

void BlockMeans::Append(std::span<const float> rate, std::span<const uint8_t> invalid) {
  assert(invalid.empty() || invalid.size() == rate.size());
  for (size_t i = 0; i < rate.size(); ++i) {
    const bool valid = std::isfinite(rate[i]) && (invalid.empty() || invalid[i] == 0);
    Add(valid ? static_cast<double>(rate[i]) : 0.0, valid);
  }
}

void BlockMeans::AppendMissing(int64_t count) {
  // Whole missing blocks at once (a long gap costs per block, not per sample).
  while (count > 0) {
    if (open_count_ == 0 && count >= block_) {
      const int64_t n = block_;
      open_count_ = n;
      samples_ += n;
      count -= n;
      CloseBlock();
      continue;
    }
    Add(0.0, false);
    --count;
  }
}

PhaseRecord BlockMeans::Phase() const {
  std::vector<double> means(sum_.size());
  std::vector<uint8_t> invalid(sum_.size(), 0);
  for (size_t j = 0; j < sum_.size(); ++j) {
    // Valid when at least half its samples are (2 valid >= B).
    if (valid_[j] > 0 && 2 * valid_[j] >= block_) {
      means[j] = sum_[j] / static_cast<double>(valid_[j]);
    } else {
      invalid[j] = 1;
    }
  }
  return PhaseFromRate(std::span<const double>(means), tau0_s_ * static_cast<double>(block_),
                       invalid);
}

}  // namespace imuqual::allan
