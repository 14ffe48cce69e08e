// Deterministic random numbers for the simulator: xoshiro256++ seeded by
// splitmix64, Gaussian deviates by the Marsaglia polar method. Unlike
// std::normal_distribution the sequence is specified here, so a seed gives
// the same unit on every platform and library. Not thread-safe: one
// generator per axis.
#ifndef IMUQUAL_ACQUIRE_RANDOM_H_
#define IMUQUAL_ACQUIRE_RANDOM_H_

#include <cmath>
#include <cstdint>

namespace imuqual::sim {

// splitmix64 step: expands one 64-bit seed into well-mixed state words.
inline uint64_t SplitMix64(uint64_t* state) {
  uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class Random {
 public:
  explicit Random(uint64_t seed) {
    for (uint64_t& word : s_) word = SplitMix64(&seed);
  }

  // Uniform 64-bit word (xoshiro256++).
  uint64_t Next() {
    const uint64_t result = Rotl(s_[0] + s_[3], 23) + s_[0];
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }

  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

  // Standard normal deviate (mean 0, variance 1).
  double Gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * Uniform() - 1.0;
      v = 2.0 * Uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double scale = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * scale;
    has_spare_ = true;
    return u * scale;
  }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace imuqual::sim

#endif  // IMUQUAL_ACQUIRE_RANDOM_H_
