#include "acquire/lot_profile.h"

#include <cmath>

#include "acquire/random.h"

namespace imuqual::sim {
namespace {

constexpr double kDegPerHour = 1.0 / 3600.0;          // deg/h -> deg/s
constexpr double kDegPerRootHour = 1.0 / 60.0;        // deg/sqrt(h) -> deg/sqrt(s)
constexpr double kDegPerHourRootHour = 1.0 / 216000;  // deg/h/sqrt(h) -> deg/s/sqrt(s)
constexpr double kMicroG = 9.80665e-6;                // ug -> m/s^2
constexpr double kStandardGravity = 9.80665;

pb::AxisTruth Gyro(double q_deg, double arw_deg_rt_h, double b_deg_h, double rrw_deg_h_rt_h,
                   double bias_spread_deg_s) {
  pb::AxisTruth t;
  t.set_quantization(q_deg);
  t.set_random_walk(arw_deg_rt_h * kDegPerRootHour);
  t.set_bias_instability(b_deg_h * kDegPerHour);
  t.set_rate_random_walk(rrw_deg_h_rt_h * kDegPerHourRootHour);
  t.set_bias(bias_spread_deg_s);
  return t;
}

pb::AxisTruth Accel(double q_m_s, double vrw_m_s_rt_h, double b_ug, double k_ug_rt_s,
                    double bias_spread_m_s2) {
  pb::AxisTruth t;
  t.set_quantization(q_m_s);
  t.set_random_walk(vrw_m_s_rt_h / 60.0);
  t.set_bias_instability(b_ug * kMicroG);
  t.set_rate_random_walk(k_ug_rt_s * kMicroG);
  t.set_bias(bias_spread_m_s2);
  return t;
}

LotProfile Vg700() {
  // The seed note's VG700CA: ~0.38 deg/s peak-to-peak rate noise at 100 Hz
  // (white sd ~0.06 deg/s, N = 0.006 deg/sqrt(s) = 0.36 deg/sqrt(h)) and a
  // bias stability well under 20 deg/h at 10-15 s. The rate random walk is
  // set so that sqrt(3) N / K puts the minimum near 12 s; the flicker floor
  // (B = 8 deg/h) and that knee give a curve minimum of ~10 deg/h.
  LotProfile p;
  p.name = "vg700";
  p.description = "VG700CA-like rate-grade vertical gyro, 3 gyro axes, 100 Hz";
  p.nominal_rate_hz = 100;
  for (const char* axis : {"x", "y", "z"}) {
    p.axes.push_back({axis, pb::GYRO, Gyro(5e-5, 0.36, 8.0, 187.0, 0.2)});
  }
  return p;
}

LotProfile Tactical() {
  LotProfile p;
  p.name = "tactical";
  p.description = "tactical-grade MEMS IMU, 3 gyro + 3 accel axes, 200 Hz";
  p.nominal_rate_hz = 200;
  for (const char* axis : {"gx", "gy", "gz"}) {
    p.axes.push_back({axis, pb::GYRO, Gyro(1e-6, 0.15, 1.0, 3.0, 0.05)});
  }
  for (const char* axis : {"ax", "ay", "az"}) {
    p.axes.push_back({axis, pb::ACCEL, Accel(1e-6, 0.05, 20.0, 2.0, 0.02)});
  }
  return p;
}

LotProfile Fog() {
  LotProfile p;
  p.name = "fog";
  p.description = "navigation-grade fibre-optic gyro, 1 axis, 100 Hz";
  p.nominal_rate_hz = 100;
  p.axes.push_back({"z", pb::GYRO, Gyro(1e-7, 0.002, 0.005, 0.002, 0.001)});
  return p;
}

// A consumer-grade MEMS IMU (delta-angle / delta-velocity outputs) soaked on
// an open lab bench instead of a chamber, so that every effect the simulator
// has shows on some axis, each where the Allan curve can tell it apart:
//  - every axis: quantization Q, a quarter of the white AVAR at tau0
//    (3 Q^2 / tau0^2 = N^2 / (4 tau0)), gone above ~0.05 s; and a 12.5 Hz line
//    from the bench's fan at 3 % of the white noise's sd, too weak to bend
//    the fit (at 10 % it lifts N by ~0.5 % and lowers Q and B), which a
//    lock-in on the raw samples of a two-hour soak finds to ~6 %;
//  - x: a rate ramp R (thermal gradient, ageing) taking over from the flicker
//    floor at ~2 min;
//  - y: rate random walk K, crossing the flicker floor at ~100 s;
//  - z: the out-of-plane sense elements' bias follows the unit's temperature
//    (uncompensated), through the simulator's warm-up and chamber cycle.
// R and K sit on different axes because the rising end of a two-hour soak's
// curve spans too few octaves to separate a ramp from a random walk; the
// temperature coefficient sits on z alone because its warm-up tail and 1 h
// cycle bend the long-tau end of the curve.
LotProfile MemsLab() {
  constexpr double kGyroQDeg = 1.5e-4, kGyroArwDegRtH = 0.3, kGyroBDegH = 10;
  constexpr double kAccelQMs = 3e-5, kAccelVrwMsRtH = 0.06, kAccelBUg = 50;
  constexpr double kFanHz = 12.5;
  LotProfile p;
  p.name = "mems-lab";
  p.description =
      "consumer MEMS IMU on an open bench, 3 gyro + 3 accel, 100 Hz: Q and a 12.5 Hz line on "
      "every axis, rate ramp on x, rate random walk on y, temperature coefficient on z";
  p.nominal_rate_hz = 100;
  for (const char* axis : {"gx", "gy", "gz"}) {
    pb::AxisTruth t = Gyro(kGyroQDeg, kGyroArwDegRtH, kGyroBDegH, 0, 0.5);
    t.set_sine_amplitude(0.0015);  // deg/s; white sd N / sqrt(tau0) = 0.05 deg/s
    t.set_sine_frequency_hz(kFanHz);
    if (axis[1] == 'x') t.set_rate_ramp(250.0 / (3600.0 * 3600.0));  // 250 deg/h^2
    if (axis[1] == 'y') t.set_rate_random_walk(70 * kDegPerHourRootHour);
    if (axis[1] == 'z') t.set_temp_coefficient(0.02);  // deg/s per deg C
    p.axes.push_back({axis, pb::GYRO, t});
  }
  for (const char* axis : {"ax", "ay", "az"}) {
    pb::AxisTruth t = Accel(kAccelQMs, kAccelVrwMsRtH, kAccelBUg, 0, 0.05);
    t.set_sine_amplitude(30 * kMicroG);  // white sd 0.01 m/s^2 (~1000 ug)
    t.set_sine_frequency_hz(kFanHz);
    if (axis[1] == 'x') t.set_rate_ramp(0.4 * kMicroG);         // 0.4 ug/s = 1440 ug/h
    if (axis[1] == 'y') t.set_rate_random_walk(6 * kMicroG);    // 6 ug/sqrt(s)
    if (axis[1] == 'z') t.set_temp_coefficient(300 * kMicroG);  // 300 ug per deg C
    p.axes.push_back({axis, pb::ACCEL, t});
  }
  return p;
}

// An ADIS16405-class consumer MEMS IMU read at 100 Hz, as its output
// registers give it: the noise is not the ideal IEEE model but what such a
// part really shows.
//  - gyro: white N = 0.033 deg/sqrt(s) (ARW 2 deg/sqrt(h)) through the part's
//    ~15 Hz filter (the sd at tau0 drops to 0.66 of N / sqrt(tau0), the ARW
//    stays), flicker B = 0.004 deg/s (14.4 deg/h), a Gauss-Markov term of
//    the same size (sigma 0.004 deg/s, T = 200 s) bending the curve near its
//    minimum, a small rate random walk K = 3e-5 deg/s/sqrt(s), a 0.05 deg/s
//    LSB (about a quarter of the filtered white sd), one-sample spikes of
//    1 deg/s about every 17 min (spike_rate_hz 0.001), and on z a 24.7 Hz
//    line of 0.05 deg/s (a structural mode);
//  - accel: white N = 0.0033 m/s/sqrt(s) (VRW 0.2 m/s/sqrt(h)), unfiltered,
//    B = 0.2 mg, a Gauss-Markov term (sigma 1 mg, T = 100 s) and a
//    0.0327 m/s^2 (3.33 mg) LSB, about one white sd, so the LSB shows;
//  - z axes: the temperature coefficients of mems-lab.
// No angle-accumulator quantization: the part outputs rates. Constant
// offsets spread over +/-3 deg/s and +/-50 mg, the order of the part's
// initial bias error.
LotProfile MemsReal() {
  constexpr double kGyroArwDegRtH = 2.0, kGyroBDegH = 14.4;     // B = 0.004 deg/s
  constexpr double kGyroKDegHRtH = 3e-5 / kDegPerHourRootHour;  // 3e-5 deg/s/sqrt(s)
  constexpr double kAccelVrwMsRtH = 0.2, kAccelBUg = 200;       // 0.2 mg
  LotProfile p;
  p.name = "mems-real";
  p.description =
      "ADIS16405-class consumer MEMS IMU as read at 100 Hz, 3 gyro + 3 accel: band-limited "
      "white, flicker, Gauss-Markov, rate LSB on every axis, rate random walk and rare spikes on "
      "the gyros, a 24.7 Hz line on gz, temperature coefficient on z";
  p.nominal_rate_hz = 100;
  for (const char* axis : {"gx", "gy", "gz"}) {
    pb::AxisTruth t = Gyro(0, kGyroArwDegRtH, kGyroBDegH, kGyroKDegHRtH, 3.0);
    t.set_white_bandwidth_hz(15);
    pb::GaussMarkov* gm = t.add_gauss_markov();
    gm->set_sigma(0.004);  // deg/s
    gm->set_correlation_time_s(200);
    t.set_rate_lsb(0.05);  // deg/s
    t.set_spike_rate_hz(0.001);
    t.set_spike_amplitude(1.0);  // deg/s
    if (axis[1] == 'z') {
      pb::Sinusoid* line = t.add_sinusoids();
      line->set_amplitude(0.05);  // deg/s
      line->set_frequency_hz(24.7);
      t.set_temp_coefficient(0.02);  // deg/s per deg C
    }
    p.axes.push_back({axis, pb::GYRO, t});
  }
  for (const char* axis : {"ax", "ay", "az"}) {
    pb::AxisTruth t = Accel(0, kAccelVrwMsRtH, kAccelBUg, 0, 50e3 * kMicroG);
    pb::GaussMarkov* gm = t.add_gauss_markov();
    gm->set_sigma(1e-3);  // m/s^2
    gm->set_correlation_time_s(100);
    t.set_rate_lsb(0.0327);                                     // m/s^2
    if (axis[1] == 'z') t.set_temp_coefficient(300 * kMicroG);  // 300 ug per deg C
    p.axes.push_back({axis, pb::ACCEL, t});
  }
  return p;
}

}  // namespace

std::vector<std::string> LotProfileNames() {
  return {"vg700", "tactical", "fog", "mems-lab", "mems-real"};
}

Result<LotProfile> LotProfileByName(std::string_view name) {
  if (name == "vg700") return Vg700();
  if (name == "tactical") return Tactical();
  if (name == "fog") return Fog();
  if (name == "mems-lab") return MemsLab();
  if (name == "mems-real") return MemsReal();
  return Status::InvalidArgument("unknown lot profile '" + std::string(name) +
                                 "' (known: vg700, tactical, fog, mems-lab, mems-real)");
}

uint64_t SeedFromName(std::string_view name) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : name) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

pb::SimTruth MakeUnitTruth(const LotProfile& profile, uint64_t lot_seed, int index,
                           double rate_hz) {
  uint64_t mix = lot_seed ^ (0x9e3779b97f4a7c15ULL * static_cast<uint64_t>(index + 1));
  Random rng(SplitMix64(&mix));
  const bool planted_fail =
      profile.planted_fail_every > 0 && (index + 1) % profile.planted_fail_every == 0;

  pb::SimTruth truth;
  truth.set_seed(rng.Next());
  truth.set_actual_rate_hz(rate_hz);
  truth.set_profile(profile.name + (planted_fail ? "/planted-fail" : "/typical"));
  for (const AxisProfile& axis : profile.axes) {
    const pb::AxisTruth& typ = axis.typical;
    auto spread = [&](double v) { return v * std::exp(profile.spread * rng.Gaussian()); };
    pb::AxisTruth* t = truth.add_axes();
    t->set_axis(axis.name);
    t->set_quantization(spread(typ.quantization()));
    t->set_random_walk(spread(typ.random_walk()));
    t->set_bias_instability(spread(typ.bias_instability()) *
                            (planted_fail ? profile.fail_bias_instability_factor : 1.0));
    t->set_rate_random_walk(spread(typ.rate_random_walk()) *
                            (planted_fail ? profile.fail_rate_random_walk_factor : 1.0));
    // The disturbances spread like the noise terms, but draw only when the
    // profile has them, so profiles without them keep their units' truth.
    auto spread_if_set = [&](double v) { return v == 0 ? 0.0 : spread(v); };
    t->set_rate_ramp(spread_if_set(typ.rate_ramp()));
    t->set_sine_amplitude(spread_if_set(typ.sine_amplitude()));
    t->set_sine_frequency_hz(typ.sine_frequency_hz());  // one line on the bench: no spread
    t->set_temp_coefficient(spread_if_set(typ.temp_coefficient()));
    // The MEMS terms: sigmas, amplitudes and correlation times spread; the
    // part's design (filter cutoff, LSB, line frequency, spike rate) does
    // not. Draws only for terms the profile has, as above.
    for (const pb::GaussMarkov& gm : typ.gauss_markov()) {
      pb::GaussMarkov* u = t->add_gauss_markov();
      u->set_sigma(spread(gm.sigma()));
      u->set_correlation_time_s(spread(gm.correlation_time_s()));
    }
    t->set_white_bandwidth_hz(typ.white_bandwidth_hz());
    t->set_rate_lsb(typ.rate_lsb());
    t->set_spike_rate_hz(typ.spike_rate_hz());
    t->set_spike_amplitude(spread_if_set(typ.spike_amplitude()));
    for (const pb::Sinusoid& line : typ.sinusoids()) {
      pb::Sinusoid* u = t->add_sinusoids();
      u->set_amplitude(spread(line.amplitude()));
      u->set_frequency_hz(line.frequency_hz());
    }
    // Constant offset uniform in +/- the profile's spread; accelerometer z
    // axes see gravity (unit level, z up).
    double bias = typ.bias() * (2 * rng.Uniform() - 1);
    if (axis.kind == pb::ACCEL && axis.name.back() == 'z') bias += kStandardGravity;
    t->set_bias(bias);
  }
  return truth;
}

}  // namespace imuqual::sim
