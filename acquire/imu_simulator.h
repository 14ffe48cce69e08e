// A simulated IMU: the IEEE Std 952 / 1293 noise model per axis, seeded, with
// known truth, plus what real MEMS parts add to it. Pure computation (no
// clock, no I/O); acquire wraps it as a source, tests use it to synthesize
// records from known parameters.
//
// Per axis, sample k (t = k / actual_rate_hz, tau0 = 1 / actual_rate_hz):
//   y_k = bias + white_k + flicker_k + walk_k + R t + A sin(2 pi f t + phi)
//         + tc (T(t) - 25 C) + sum_j gm_j,k + sum_i A_i sin(2 pi f_i t + phi_i)
//         + spike_k, then quantized through the angle accumulator, then
//         rounded to the rate LSB.
//  - white:   N / sqrt(tau0) * e_k            -> AVAR N^2 / tau
//    band-limited (white_bandwidth_hz = f_c > 0), as a MEMS part's internal
//    filter does: a first-order low-pass with unit DC gain driven by the same
//    deviates, w_k = phi w_{k-1} + (1 - phi) (N / sqrt(tau0)) e_k,
//    phi = exp(-2 pi f_c tau0), w_0 from the stationary distribution. This is
//    exactly an AR(1) (a Gauss-Markov process) with T = -tau0 / ln(phi) and
//    stationary variance (1 - phi) / (1 + phi) N^2 / tau0, lag-1
//    autocorrelation phi; for tau >> T its AVAR is still N^2 / tau (unit DC
//    gain: the ARW is unchanged, only the variance at tau0 drops).
//  - walk:    w_{k+1} = w_k + K sqrt(tau0) e_k -> AVAR K^2 tau / 3
//  - flicker: unit white noise through a cascade of first-order pole-zero
//    sections (poles and zeros alternating, two pairs per decade) whose gain
//    is scaled so the one-sided PSD is B^2 / (pi f) inside the band
//    -> AVAR (2 ln 2 / pi) B^2 (IEEE 952: two-sided S(f) = B^2 / (2 pi f)).
//  - Gauss-Markov (each term j, sigma and T): exactly the discrete AR(1)
//    g_k = phi g_{k-1} + sigma sqrt(1 - phi^2) e_k, phi = exp(-tau0 / T),
//    g_0 ~ N(0, sigma^2): stationary variance sigma^2 at every k, lag-1
//    autocorrelation phi.
//  - extra lines (sinusoids): amplitude A_i at f_i with a random phase.
//  - spikes: at each sample, with probability p = spike_rate_hz tau0, one
//    outlier of +/- spike_amplitude (sign even odds) on that sample alone,
//    unflagged, as a real part's outliers are.
//  - quantization: the output is the difference of an angle accumulator
//    rounded to the quantum q = Q sqrt(12)    -> AVAR 3 Q^2 / tau^2.
//  - rate LSB (rate_lsb > 0): last of all, each output rate is rounded to the
//    nearest multiple of the LSB, as a part with a rate register does.
// e_k are standard normal deviates from the axis's own generator. Per sample
// the IEEE terms draw first (white, flicker, walk), then each Gauss-Markov
// term, then the spike lottery (one uniform deviate); the extra lines draw
// their phases once, at creation, after the existing line's phase. A term
// that is absent (0 or empty field) draws nothing, so a truth without the
// MEMS fields gives exactly the samples it gave before they existed.
// Not thread-safe; one simulator per unit.
#ifndef IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_
#define IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_

#include <cstdint>
#include <optional>
#include <span>
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
  bool empty() const { return sections_.empty(); }
  // The next x.size() outputs, in place: x holds the standard normal
  // deviates that drive them, one per sample in order, and is overwritten
  // with the outputs (all 0 when the generator is empty). The sections run
  // four at a time, skewed by a sample each, so their recursions overlap;
  // every output is the same double as stepping the cascade one sample at
  // a time.
  void Filter(std::span<double> x);
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

// First-order autoregressive (Gauss-Markov) process
//   x_k = phi x_{k-1} + drive e_k,  e_k standard normal,  0 <= phi < 1,
// started from its stationary distribution x_0 = stationary_sd e_0, where
// stationary_sd^2 = drive^2 / (1 - phi^2) (the caller passes it, computed
// without cancellation). The caller supplies the deviates, so one generator
// can feed several processes in a fixed order.
class Ar1Process {
 public:
  Ar1Process(double phi, double drive, double stationary_sd)
      : phi_(phi), drive_(drive), stationary_sd_(stationary_sd) {}
  // x_k for the standard normal deviate e_k.
  double Next(double e) {
    x_ = started_ ? phi_ * x_ + drive_ * e : stationary_sd_ * e;
    started_ = true;
    return x_;
  }

 private:
  double phi_;
  double drive_;
  double stationary_sd_;
  double x_ = 0;
  bool started_ = false;
};

class ImuSimulator {
 public:
  // Validates the truth (non-negative noise terms, positive rates, at least
  // one axis; Gauss-Markov correlation times > 0, band-limit and line
  // frequencies below Nyquist, spike_rate_hz * tau0 <= 1); the error names
  // the field.
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
    double white_scale;  // N / sqrt(tau0)
    double walk_step;    // K sqrt(tau0)
    double walk = 0;
    double quantum = 0;   // q = Q sqrt(12); 0: no quantization
    double residual = 0;  // accumulated angle not yet output, < quantum
    double sine_phase;
    // The MEMS terms; each empty / 0 when the truth does not have it.
    std::optional<Ar1Process> white_lowpass = std::nullopt;  // band-limited white
    std::vector<Ar1Process> gauss_markov = {};
    struct Line {
      double amplitude;
      double frequency_hz;
      double phase;
    };
    std::vector<Line> lines = {};
    double spike_probability = 0;  // per sample: spike_rate_hz tau0
    double rate_lsb = 0;
  };
  // A block's deviates of one axis, drawn ahead in the model's order.
  struct Deviates {
    std::vector<double> white, flicker, walk, gauss_markov, spike;
  };
  explicit ImuSimulator(const pb::SimTruth& truth);
  double TemperatureAt(int64_t k) const;
  // Samples k_ .. k_ + n - 1 of one axis onto `out`; `temp_offsets` holds
  // T - 25 C per sample where the axis has a temperature coefficient.
  void GenerateAxis(AxisState& s, int n, const std::vector<double>& temp_offsets,
                    std::vector<float>& out);

  pb::SimTruth truth_;
  double tau0_s_;
  int64_t k_ = 0;
  std::vector<AxisState> axes_;
  Deviates deviates_;  // scratch, reused block to block
};

}  // namespace imuqual::sim

#endif  // IMUQUAL_ACQUIRE_IMU_SIMULATOR_H_
