#include "analyze/allan/phase.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>

namespace imuqual::allan {
namespace {

// Sums are accumulated in blocks of this many samples and the block sums are
// added to the total, so the rounding error grows like sqrt(N / kBlock) blocks
// instead of N samples.
constexpr size_t kSumBlock = 4096;

template <typename T>
bool IsValidSample(std::span<const T> rate, std::span<const uint8_t> invalid, size_t k) {
  return std::isfinite(rate[k]) && (k >= invalid.size() || invalid[k] == 0);
}

template <typename T>
PhaseRecord PhaseFromRateImpl(std::span<const T> rate, double tau0_s,
                              std::span<const uint8_t> invalid) {
  PhaseRecord record;
  record.tau0_s = tau0_s;
  const size_t num_rate = rate.size();
  if (num_rate == 0) return record;
  assert(invalid.empty() || invalid.size() == num_rate);

  // yref = mean of the valid samples (0 if there are none).
  double total = 0.0;
  int64_t num_valid = 0;
  for (size_t begin = 0; begin < num_rate; begin += kSumBlock) {
    const size_t end = std::min(num_rate, begin + kSumBlock);
    double block = 0.0;
    for (size_t k = begin; k < end; ++k) {
      if (IsValidSample(rate, invalid, k)) {
        block += static_cast<double>(rate[k]);
        ++num_valid;
      }
    }
    total += block;
  }
  const double yref = num_valid > 0 ? total / static_cast<double>(num_valid) : 0.0;
  const bool has_gaps = num_valid != static_cast<int64_t>(num_rate);

  // x_{k+1} = tau0 * sum_{j<=k} (y_j - yref), gaps contributing 0.
  record.x.resize(num_rate + 1);
  if (has_gaps) record.invalid_prefix.resize(num_rate + 1);
  double running = 0.0;
  int64_t invalid_so_far = 0;
  record.x[0] = 0.0;
  for (size_t k = 0; k < num_rate; ++k) {
    if (IsValidSample(rate, invalid, k)) {
      running += static_cast<double>(rate[k]) - yref;
    } else {
      ++invalid_so_far;
    }
    record.x[k + 1] = running * tau0_s;
    if (has_gaps) record.invalid_prefix[k + 1] = invalid_so_far;
  }
  return record;
}

}  // namespace

PhaseRecord PhaseFromRate(std::span<const double> rate, double tau0_s,
                          std::span<const uint8_t> invalid) {
  return PhaseFromRateImpl(rate, tau0_s, invalid);
}

PhaseRecord PhaseFromRate(std::span<const float> rate, double tau0_s,
                          std::span<const uint8_t> invalid) {
  return PhaseFromRateImpl(rate, tau0_s, invalid);
}

PhaseRecord PhaseFromPhase(std::span<const double> phase, double tau0_s) {
  PhaseRecord record;
  record.tau0_s = tau0_s;
  record.x.assign(phase.begin(), phase.end());
  const size_t num_phase = phase.size();
  if (num_phase == 0) return record;

  // Rate sample y_k spans x_k..x_{k+1}: it is invalid when either end is.
  std::vector<uint8_t> rate_invalid(num_phase - 1, 0);
  bool has_gaps = false;
  for (size_t k = 0; k < num_phase; ++k) {
    if (std::isfinite(phase[k])) continue;
    has_gaps = true;
    if (k > 0) rate_invalid[k - 1] = 1;
    if (k + 1 < num_phase) rate_invalid[k] = 1;
  }
  if (!has_gaps) return record;

  // Replace each non-finite point by the nearest earlier finite one (the first
  // finite one for a leading run; 0 if there is none).
  double fill = 0.0;
  for (size_t k = 0; k < num_phase; ++k) {
    if (std::isfinite(phase[k])) {
      fill = phase[k];
      break;
    }
  }
  for (size_t k = 0; k < num_phase; ++k) {
    if (std::isfinite(phase[k])) {
      fill = phase[k];
    } else {
      record.x[k] = fill;
    }
  }

  record.invalid_prefix.resize(num_phase);
  record.invalid_prefix[0] = 0;
  for (size_t k = 0; k + 1 < num_phase; ++k) {
    record.invalid_prefix[k + 1] = record.invalid_prefix[k] + rate_invalid[k];
  }
  return record;
}

std::vector<int64_t> InvalidRateIndices(const PhaseRecord& phase) {
  std::vector<int64_t> indices;
  const std::vector<int64_t>& prefix = phase.invalid_prefix;
  if (prefix.empty()) return indices;
  indices.reserve(static_cast<size_t>(phase.invalid_count()));
  for (size_t k = 0; k + 1 < prefix.size(); ++k) {
    if (prefix[k + 1] != prefix[k]) indices.push_back(static_cast<int64_t>(k));
  }
  return indices;
}

PhaseSpan LongestValidSpan(const PhaseRecord& phase) {
  const int64_t num_phase = phase.size();
  if (phase.invalid_count() == 0) return {0, num_phase};
  // Valid phase runs lie between invalid rate samples: y_g invalid ends a run
  // at x_g (inclusive) and starts the next one at x_{g+1}.
  PhaseSpan best;
  int64_t begin = 0;
  for (int64_t g : InvalidRateIndices(phase)) {
    if (g + 1 - begin > best.size()) best = {begin, g + 1};
    begin = g + 1;
  }
  if (num_phase - begin > best.size()) best = {begin, num_phase};
  return best;
}

}  // namespace imuqual::allan
