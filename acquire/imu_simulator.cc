#include "acquire/imu_simulator.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>

namespace imuqual::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kSectionsPerDecade = 2.0;
// Lowest frequency that follows 1/f: ~116 days, far beyond any soak, so the
// flicker floor holds over every tau a record can show.
constexpr double kFlickerLowHz = 1e-7;
constexpr double kAmbientC = 25.0;

uint64_t AxisSeed(uint64_t unit_seed, int axis) {
  uint64_t s = unit_seed ^ (0xa0761d6478bd642fULL * static_cast<uint64_t>(axis + 1));
  return SplitMix64(&s);
}

bool NonNegative(double v) { return v >= 0 && std::isfinite(v); }

std::string FormatHz(double hz) {
  char text[32];
  std::snprintf(text, sizeof text, "%g Hz", hz);
  return text;
}

// The fields real MEMS parts add (sim.proto 11-16); the message names the
// field, the caller prefixes the axis.
Status ValidateMemsTerms(const pb::AxisTruth& a, double rate_hz) {
  const double nyquist_hz = 0.5 * rate_hz;
  const std::string below_nyquist =
      " must be below the Nyquist frequency (" + FormatHz(nyquist_hz) + ")";
  for (auto [name, v] : {std::pair{"white_bandwidth_hz", a.white_bandwidth_hz()},
                         {"rate_lsb", a.rate_lsb()},
                         {"spike_rate_hz", a.spike_rate_hz()},
                         {"spike_amplitude", a.spike_amplitude()}}) {
    if (!NonNegative(v)) {
      return Status::InvalidArgument(std::string(name) + " must be finite and >= 0");
    }
  }
  if (a.white_bandwidth_hz() >= nyquist_hz) {
    return Status::InvalidArgument("white_bandwidth_hz" + below_nyquist);
  }
  if (a.spike_rate_hz() / rate_hz > 1) {
    return Status::InvalidArgument("spike_rate_hz must be at most the sample rate (" +
                                   FormatHz(rate_hz) + "): spike_rate_hz * tau0 <= 1");
  }
  for (int j = 0; j < a.gauss_markov_size(); ++j) {
    const pb::GaussMarkov& g = a.gauss_markov(j);
    const std::string name = "gauss_markov[" + std::to_string(j) + "].";
    if (!NonNegative(g.sigma())) {
      return Status::InvalidArgument(name + "sigma must be finite and >= 0");
    }
    if (!(g.correlation_time_s() > 0) || !std::isfinite(g.correlation_time_s())) {
      return Status::InvalidArgument(name + "correlation_time_s must be finite and > 0");
    }
  }
  for (int i = 0; i < a.sinusoids_size(); ++i) {
    const pb::Sinusoid& line = a.sinusoids(i);
    const std::string name = "sinusoids[" + std::to_string(i) + "].";
    if (!NonNegative(line.amplitude())) {
      return Status::InvalidArgument(name + "amplitude must be finite and >= 0");
    }
    if (!NonNegative(line.frequency_hz())) {
      return Status::InvalidArgument(name + "frequency_hz must be finite and >= 0");
    }
    if (line.frequency_hz() >= nyquist_hz) {
      return Status::InvalidArgument(name + "frequency_hz" + below_nyquist);
    }
  }
  return Status::Ok();
}

}  // namespace

// Each section H_i(z) = (1 - z_i z^-1) / (1 - p_i z^-1) is a matched-z pole at
// f_p and zero at f_z = f_p sqrt(r) (r = 10^(1/2)): -20 dB/decade over half
// of every interval, -10 dB/decade on average, i.e. |H|^2 ~ c / f. The gain g
// is set from the geometric mean of |H(f)|^2 f over the band so that
// 2 tau0 g^2 |H|^2 = B^2 / (pi f) (unit white input has one-sided PSD 2 tau0).
FlickerNoise::FlickerNoise(double bias_instability, double tau0_s, double f_low_hz,
                           double f_high_hz)
    : tau0_s_(tau0_s) {
  const double r = std::pow(10.0, 1.0 / kSectionsPerDecade);
  for (double fp = f_low_hz; fp * std::sqrt(r) <= f_high_hz; fp *= r) {
    const double fz = fp * std::sqrt(r);
    sections_.push_back({std::exp(-2 * kPi * fp * tau0_s), std::exp(-2 * kPi * fz * tau0_s)});
  }
  if (sections_.empty() || bias_instability <= 0) {
    sections_.clear();
    gain_ = 0;
    return;
  }
  // Geometric mean of |H|^2 f over the interior of the band (one section
  // interval in from each edge), 64 points per decade.
  const double f_top = -std::log(sections_.back().zero) / (2 * kPi * tau0_s);
  const double f_from = f_low_hz * r;
  const double f_to = std::max(f_top / r, f_from * r);
  const int points = std::max(8, static_cast<int>(64 * std::log10(f_to / f_from)));
  double sum_log = 0;
  for (int i = 0; i < points; ++i) {
    const double f = f_from * std::pow(f_to / f_from, (i + 0.5) / points);
    sum_log += std::log(ResponseSquared(f) * f);
  }
  const double c = std::exp(sum_log / points);
  gain_ = bias_instability / std::sqrt(2 * kPi * tau0_s * c);
}

double FlickerNoise::ResponseSquared(double f_hz) const {
  const std::complex<double> zinv = std::polar(1.0, -2 * kPi * f_hz * tau0_s_);
  std::complex<double> h = 1.0;
  for (const Section& s : sections_) h *= (1.0 - s.zero * zinv) / (1.0 - s.pole * zinv);
  return std::norm(h);
}

double FlickerNoise::Psd(double f_hz) const {
  return 2 * tau0_s_ * gain_ * gain_ * ResponseSquared(f_hz);
}

namespace {

// One section's recursion, y_k = x_k - zero x_{k-1} + pole y_{k-1}, its state
// held in registers while a block runs.
struct SectionState {
  double zero, pole, x_prev, y_prev;
  double Step(double x) {
    const double y = x - zero * x_prev + pole * y_prev;
    x_prev = x;
    y_prev = y;
    return y;
  }
};

// Sections first .. first + G - 1 over x, in place. Section j runs sample
// k - j at step k: it reads what section j - 1 wrote a step before, and the
// G recursions (each a multiply and an add deep per sample) overlap.
template <int G, typename Section>
void CascadeSkewed(Section* first, double* x, std::ptrdiff_t n) {
  SectionState lane[G];
  for (int j = 0; j < G; ++j)
    lane[j] = {first[j].zero, first[j].pole, first[j].x_prev, first[j].y_prev};
  const auto step_edge = [&](std::ptrdiff_t k) {
    for (int j = 0; j < G; ++j) {
      const std::ptrdiff_t i = k - j;
      if (i >= 0 && i < n) x[i] = lane[j].Step(x[i]);
    }
  };
  std::ptrdiff_t k = 0;
  for (; k < std::min<std::ptrdiff_t>(G - 1, n); ++k) step_edge(k);
  for (; k < n; ++k) {
    for (int j = 0; j < G; ++j) x[k - j] = lane[j].Step(x[k - j]);
  }
  for (; k < n + G - 1; ++k) step_edge(k);
  for (int j = 0; j < G; ++j) {
    first[j].x_prev = lane[j].x_prev;
    first[j].y_prev = lane[j].y_prev;
  }
}

}  // namespace

void FlickerNoise::Filter(std::span<double> x) {
  if (sections_.empty()) {
    std::fill(x.begin(), x.end(), 0.0);
    return;
  }
  const auto n = static_cast<std::ptrdiff_t>(x.size());
  size_t s = 0;
  for (; s + 4 <= sections_.size(); s += 4) CascadeSkewed<4>(&sections_[s], x.data(), n);
  for (; s < sections_.size(); ++s) CascadeSkewed<1>(&sections_[s], x.data(), n);
  for (double& v : x) v *= gain_;
}

ImuSimulator::ImuSimulator(const pb::SimTruth& truth)
    : truth_(truth), tau0_s_(1.0 / truth.actual_rate_hz()) {}

Result<ImuSimulator> ImuSimulator::Create(const pb::SimTruth& truth) {
  if (!(truth.actual_rate_hz() > 0) || !std::isfinite(truth.actual_rate_hz())) {
    return Status::InvalidArgument("sim truth: actual_rate_hz must be positive");
  }
  if (truth.axes_size() == 0) return Status::InvalidArgument("sim truth: no axes");
  for (const pb::AxisTruth& a : truth.axes()) {
    const std::string where = "sim truth axis '" + a.axis() + "': ";
    for (auto [name, v] : {std::pair{"quantization", a.quantization()},
                           {"random_walk", a.random_walk()},
                           {"bias_instability", a.bias_instability()},
                           {"rate_random_walk", a.rate_random_walk()},
                           {"sine_frequency_hz", a.sine_frequency_hz()}}) {
      if (!(v >= 0) || !std::isfinite(v)) {
        return Status::InvalidArgument(where + name + " must be finite and >= 0");
      }
    }
    for (double v : {a.bias(), a.rate_ramp(), a.sine_amplitude(), a.temp_coefficient()}) {
      if (!std::isfinite(v)) return Status::InvalidArgument(where + "parameters must be finite");
    }
    if (Status s = ValidateMemsTerms(a, truth.actual_rate_hz()); !s.ok()) {
      return Status::InvalidArgument(where + s.message());
    }
  }
  ImuSimulator sim(truth);
  const double f_high = 0.25 / sim.tau0_s_;  // half of Nyquist: keeps matched-z zeros accurate
  for (int i = 0; i < truth.axes_size(); ++i) {
    const pb::AxisTruth& a = truth.axes(i);
    Random rng(AxisSeed(truth.seed(), i));
    const double phase = 2 * kPi * rng.Uniform();
    AxisState s{a,
                rng,
                FlickerNoise(a.bias_instability(), sim.tau0_s_, kFlickerLowHz, f_high),
                a.random_walk() / std::sqrt(sim.tau0_s_),
                a.rate_random_walk() * std::sqrt(sim.tau0_s_),
                0.0,
                a.quantization() * std::sqrt(12.0),
                0.0,
                phase};
    // MEMS terms. 1 - phi and 1 - phi^2 by expm1: no cancellation when the
    // correlation time is many samples.
    if (a.white_bandwidth_hz() > 0) {
      const double x = 2 * kPi * a.white_bandwidth_hz() * sim.tau0_s_;
      const double one_minus_phi = -std::expm1(-x);
      const double phi = std::exp(-x);
      s.white_lowpass.emplace(phi, one_minus_phi * s.white_scale,
                              s.white_scale * std::sqrt(one_minus_phi / (1 + phi)));
    }
    for (const pb::GaussMarkov& g : a.gauss_markov()) {
      const double x = sim.tau0_s_ / g.correlation_time_s();
      s.gauss_markov.emplace_back(std::exp(-x), g.sigma() * std::sqrt(-std::expm1(-2 * x)),
                                  g.sigma());
    }
    for (const pb::Sinusoid& line : a.sinusoids()) {
      s.lines.push_back({line.amplitude(), line.frequency_hz(), 2 * kPi * s.rng.Uniform()});
    }
    s.spike_probability = a.spike_rate_hz() * sim.tau0_s_;
    s.rate_lsb = a.rate_lsb();
    sim.axes_.push_back(std::move(s));
  }
  return sim;
}

// Warm-up from ambient to 35 C (15 min time constant) with a 0.5 C, 1 h
// chamber cycle on top.
double ImuSimulator::TemperatureAt(int64_t k) const {
  const double t = static_cast<double>(k) * tau0_s_;
  return kAmbientC + 10.0 * (1.0 - std::exp(-t / 900.0)) + 0.5 * std::sin(2 * kPi * t / 3600.0);
}

double ImuSimulator::temperature_c() const { return TemperatureAt(k_); }

// Axis by axis (each draws from its own generator) in blocks: a block's
// deviates first, in the order the model draws them per sample, then the
// flicker cascade over the whole block, then each sample's sum in the
// model's order. The samples are those of stepping every term one sample at
// a time, bit for bit (ImuSimulatorTest's recorded hashes).
void ImuSimulator::Generate(int count, std::vector<std::vector<float>>& samples) {
  constexpr int kBlock = 4096;
  // The chamber temperature (an exp and a sin per sample) only where an axis
  // reads it.
  const bool any_temp = std::any_of(axes_.begin(), axes_.end(), [](const AxisState& s) {
    return s.truth.temp_coefficient() != 0;
  });
  std::vector<double> temp_offsets;
  for (int done = 0; done < count;) {
    const int n = std::min(kBlock, count - done);
    temp_offsets.clear();
    for (int i = 0; any_temp && i < n; ++i)
      temp_offsets.push_back(TemperatureAt(k_ + i) - kAmbientC);
    for (size_t a = 0; a < axes_.size(); ++a) GenerateAxis(axes_[a], n, temp_offsets, samples[a]);
    k_ += n;
    done += n;
  }
}

void ImuSimulator::GenerateAxis(AxisState& s, int n, const std::vector<double>& temp_offsets,
                                std::vector<float>& out) {
  const pb::AxisTruth& p = s.truth;
  const bool white = s.white_scale > 0;
  const bool walk = s.walk_step > 0;
  const bool spike = s.spike_probability > 0;
  const size_t gm = s.gauss_markov.size();
  Deviates& d = deviates_;
  d.white.resize(n);
  d.flicker.resize(n);
  d.walk.resize(n);
  d.gauss_markov.resize(n * gm);
  d.spike.resize(n);
  // Per sample the IEEE terms draw first (white, flicker, walk), then each
  // Gauss-Markov term, then the spike lottery.
  for (int i = 0; i < n; ++i) {
    if (white) d.white[i] = s.rng.Gaussian();
    if (!s.flicker.empty()) d.flicker[i] = s.rng.Gaussian();
    if (walk) d.walk[i] = s.rng.Gaussian();
    for (size_t j = 0; j < gm; ++j) d.gauss_markov[i * gm + j] = s.rng.Gaussian();
    if (spike) d.spike[i] = s.rng.Uniform();
  }
  s.flicker.Filter(std::span<double>(d.flicker.data(), n));
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(k_ + i) * tau0_s_;
    double y = p.bias() + p.rate_ramp() * t;
    if (p.temp_coefficient() != 0) y += p.temp_coefficient() * temp_offsets[i];
    if (white) {
      const double e = d.white[i];
      y += s.white_lowpass ? s.white_lowpass->Next(e) : s.white_scale * e;
    }
    y += d.flicker[i];
    if (walk) {
      y += s.walk;
      s.walk += s.walk_step * d.walk[i];
    }
    if (p.sine_amplitude() != 0) {
      y += p.sine_amplitude() * std::sin(2 * kPi * p.sine_frequency_hz() * t + s.sine_phase);
    }
    for (size_t j = 0; j < gm; ++j) y += s.gauss_markov[j].Next(d.gauss_markov[i * gm + j]);
    for (const AxisState::Line& line : s.lines) {
      y += line.amplitude * std::sin(2 * kPi * line.frequency_hz * t + line.phase);
    }
    if (spike) {
      // One uniform deviate u decides both: a spike when u < spike_probability,
      // downwards when u is in the lower half of that interval.
      const double u = d.spike[i];
      if (u < s.spike_probability) {
        y += u < 0.5 * s.spike_probability ? -p.spike_amplitude() : p.spike_amplitude();
      }
    }
    if (s.quantum > 0) {
      // Output whole quanta of accumulated angle; carry the remainder.
      s.residual += y * tau0_s_;
      const double quanta = std::floor(s.residual / s.quantum);
      s.residual -= quanta * s.quantum;
      y = quanta * s.quantum / tau0_s_;
    }
    if (s.rate_lsb > 0) y = s.rate_lsb * std::round(y / s.rate_lsb);
    out.push_back(static_cast<float>(y));
  }
}

}  // namespace imuqual::sim
