// A simulated IMU: the IEEE Std 952 / 1293 noise model per axis, seeded, with
// known truth. Pure computation (no clock, no I/O); acquire wraps it as a
// source, tests use it to synthesize records from known parameters.
//
// Per axis, sample k (t = k / actual_rate_hz, tau0 = 1 / actual_rate_hz):
//   y_k = bias + white_k + flicker_k + walk_k + R t + A sin(2 pi f t + phi)
//         + tc (T(t) - 25 C), then quantized through the angle accumulator.
//  - white:   N / sqrt(tau0) * g_k           -> AVAR N^2 / tau
//  - walk:    w_{k+1} = w_k + K sqrt(tau0) g  -> AVAR K^2 tau / 3
//  - flicker: unit white noise through a cascade of first-order pole-zero
//    sections (poles and zeros alternating, two pairs per decade) whose gain
//    is scaled so the one-sided PSD is B^2 / (pi f) inside the band
//    -> AVAR (2 ln 2 / pi) B^2 (IEEE 952: two-sided S(f) = B^2 / (2 pi f)).
//  - quantization: the output is the difference of an angle accumulator
//    rounded to the quantum q = Q sqrt(12)    -> AVAR 3 Q^2 / tau^2.
// Not thread-safe; one simulator per unit.
#ifndef IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_
#define IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_

#include <cstdint>
#include <vector>

#include "acquire/random.h"
#include "common/status.h"
#include "imuqual/sim.pb.h"

namespace imuqual::sim {

// Flicker (1/f) noise generator: a pole-zero cascade driven by white noise.
class FlickerNoise {
 public:
  // Band [f_low_hz, f_high_hz] over which the PSD follows 1/f; f_high must be
  // below Nyquist. `bias_instability` is B (IEEE 952) in output units.
  FlickerNoise(double bias_instability, double tau0_s, double f_low_hz, double f_high_hz);
  double Next(Random& rng);
  // One-sided PSD of the output at f (for tests), output units^2 / Hz.
  double Psd(double f_hz) const;

 private:
  double ResponseSquared(double f_hz) const;  // |H(exp(j 2 pi f tau0))|^2
  struct Section {
    double pole;
    double zero;
    double x_prev = 0;
    double y_prev = 0;
  };
  std::vector<Section> sections_;
  double gain_ = 0;
  double tau0_s_;
};

class ImuSimulator {
 public:
  // Validates the truth (non-negative noise terms, positive rates, at least
  // one axis); the error names the field.
  static Result<ImuSimulator> Create(const pb::SimTruth& truth);

  // Appends the next `count` samples of every axis: samples[a] grows by count.
  // samples.size() must equal the number of axes.
  void Generate(int count, std::vector<std::vector<float>>& samples);

  int num_axes() const { return static_cast<int>(axes_.size()); }
  int64_t sample_counter() const { return k_; }
  // Unit temperature at the current sample, deg C.
  double temperature_c() const;
  const pb::SimTruth& truth() const { return truth_; }

 private:
  struct AxisState {
    pb::AxisTruth truth;
    Random rng;
    FlickerNoise flicker;
    double white_scale;   // N / sqrt(tau0)
    double walk_step;     // K sqrt(tau0)
    double walk = 0;
    double quantum = 0;   // q = Q sqrt(12); 0: no quantization
    double residual = 0;  // accumulated angle not yet output, < quantum
    double sine_phase;
  };
  explicit ImuSimulator(const pb::SimTruth& truth);

  pb::SimTruth truth_;
  double tau0_s_;
  int64_t k_ = 0;
  std::vector<AxisState> axes_;
};

}  // namespace imuqual::sim

#endif  // IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_
