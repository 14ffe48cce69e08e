#include "acquire/imu_simulator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <numeric>

#include "acquire/lot_profile.h"

namespace imuqual::sim {
namespace {

constexpr double kPi = std::numbers::pi;

pb::SimTruth OneAxis(double rate_hz, uint64_t seed) {
  pb::SimTruth truth;
  truth.set_seed(seed);
  truth.set_actual_rate_hz(rate_hz);
  truth.add_axes()->set_axis("x");
  return truth;
}

std::vector<float> Simulate(const pb::SimTruth& truth, int n) {
  auto sim = ImuSimulator::Create(truth);
  EXPECT_TRUE(sim.ok()) << sim.status().ToString();
  std::vector<std::vector<float>> out(1);
  sim->Generate(n, out);
  return out[0];
}

// FNV-1a over the float32 bit patterns of every sample of every axis.
uint64_t SampleHash(const std::vector<std::vector<float>>& samples) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (const std::vector<float>& axis : samples) {
    for (float v : axis) {
      uint32_t bits;
      std::memcpy(&bits, &v, sizeof bits);
      for (int i = 0; i < 4; ++i) {
        h ^= (bits >> (8 * i)) & 0xff;
        h *= 0x100000001b3ULL;
      }
    }
  }
  return h;
}

std::vector<std::vector<float>> SimulateAll(const pb::SimTruth& truth, int n) {
  auto sim = ImuSimulator::Create(truth);
  EXPECT_TRUE(sim.ok()) << sim.status().ToString();
  std::vector<std::vector<float>> out(truth.axes_size());
  sim->Generate(n, out);
  return out;
}

// Every pre-existing term on some axis.
pb::SimTruth OldFieldsTruth() {
  pb::SimTruth truth;
  truth.set_seed(20240612);
  truth.set_actual_rate_hz(100);
  pb::AxisTruth* a = truth.add_axes();
  a->set_axis("a");
  a->set_bias(0.3);
  a->set_quantization(2e-4);
  a->set_random_walk(0.01);
  a->set_bias_instability(2e-3);
  a->set_rate_random_walk(1e-4);
  a->set_rate_ramp(1e-5);
  a->set_sine_amplitude(0.02);
  a->set_sine_frequency_hz(7.5);
  a->set_temp_coefficient(0.01);
  pb::AxisTruth* b = truth.add_axes();
  b->set_axis("b");
  b->set_random_walk(0.02);
  pb::AxisTruth* c = truth.add_axes();
  c->set_axis("c");
  c->set_bias_instability(1e-3);
  c->set_rate_random_walk(3e-4);
  return truth;
}

double Mean(const std::vector<float>& y) {
  return std::accumulate(y.begin(), y.end(), 0.0) / static_cast<double>(y.size());
}

// Sample variance about the sample mean.
double Variance(const std::vector<float>& y) {
  const double mean = Mean(y);
  double sum = 0;
  for (float v : y) sum += (v - mean) * (v - mean);
  return sum / static_cast<double>(y.size() - 1);
}

// r_1 = sum (y_k - m)(y_{k+1} - m) / sum (y_k - m)^2.
double Lag1Autocorrelation(const std::vector<float>& y) {
  const double mean = Mean(y);
  double num = 0, den = 0;
  for (size_t k = 0; k < y.size(); ++k) {
    den += (y[k] - mean) * (y[k] - mean);
    if (k + 1 < y.size()) num += (y[k] - mean) * (y[k + 1] - mean);
  }
  return num / den;
}

// Variance of the means of consecutive blocks of `block` samples.
double BlockMeanVariance(const std::vector<float>& y, size_t block) {
  std::vector<float> means;
  for (size_t start = 0; start + block <= y.size(); start += block) {
    double sum = 0;
    for (size_t k = start; k < start + block; ++k) sum += y[k];
    means.push_back(static_cast<float>(sum / static_cast<double>(block)));
  }
  return Variance(means);
}

// Lock-in: amplitude of the line at f_hz, 2/n |sum_k y_k exp(-j 2 pi f k tau0)|.
double LockInAmplitude(const std::vector<float>& y, double f_hz, double rate_hz) {
  std::complex<double> sum = 0;
  for (size_t k = 0; k < y.size(); ++k) {
    sum += static_cast<double>(y[k]) *
           std::polar(1.0, -2 * kPi * f_hz * static_cast<double>(k) / rate_hz);
  }
  return 2 * std::abs(sum) / static_cast<double>(y.size());
}

TEST(FlickerNoiseTest, PsdFollowsOneOverFInsideTheBand) {
  // GIVEN B = 1e-3 at 100 Hz, band 1e-7 .. 25 Hz.
  const double b = 1e-3, tau0 = 0.01;
  FlickerNoise flicker(b, tau0, 1e-7, 25.0);
  // THEN the one-sided PSD is B^2 / (pi f) to within the cascade's ripple.
  // Two pole-zero pairs per decade ripple by about +/-0.2 dB; 0.35 dB leaves
  // room for the discrete-time mapping near the top of the band.
  const double kRippleDb = 0.35;
  for (double f = 1e-6; f < 5.0; f *= 1.37) {
    const double want = b * b / (kPi * f);
    const double db = 10 * std::log10(flicker.Psd(f) / want);
    EXPECT_LT(std::abs(db), kRippleDb) << "f = " << f;
  }
}

TEST(ImuSimulatorTest, SameSeedSameSamples) {
  pb::SimTruth truth = OneAxis(100, 42);
  truth.mutable_axes(0)->set_random_walk(0.01);
  truth.mutable_axes(0)->set_bias_instability(1e-3);
  truth.mutable_axes(0)->set_rate_random_walk(1e-4);
  EXPECT_EQ(Simulate(truth, 1000), Simulate(truth, 1000));
  pb::SimTruth other = truth;
  other.set_seed(43);
  EXPECT_NE(Simulate(truth, 1000), Simulate(other, 1000));
}

TEST(ImuSimulatorTest, GenerateInPiecesEqualsGenerateAtOnce) {
  pb::SimTruth truth = OneAxis(100, 7);
  truth.mutable_axes(0)->set_random_walk(0.01);
  truth.mutable_axes(0)->set_quantization(1e-4);
  auto sim = ImuSimulator::Create(truth);
  ASSERT_TRUE(sim.ok());
  std::vector<std::vector<float>> pieces(1);
  for (int n : {1, 7, 100, 892}) sim->Generate(n, pieces);
  EXPECT_EQ(pieces[0], Simulate(truth, 1000));
}

TEST(ImuSimulatorTest, WhiteRateNoiseHasVarianceNSquaredOverTau0) {
  // GIVEN only angle random walk N at 200 Hz.
  const double n_arw = 0.005, rate = 200;
  pb::SimTruth truth = OneAxis(rate, 3);
  truth.mutable_axes(0)->set_random_walk(n_arw);
  const std::vector<float> y = Simulate(truth, 400000);
  // THEN var(y) = N^2 / tau0. With 4e5 samples the sample variance has a
  // relative sd of sqrt(2/4e5) = 0.22%; 1% is > 4 sigma.
  double mean = std::accumulate(y.begin(), y.end(), 0.0) / y.size();
  double var = 0;
  for (float v : y) var += (v - mean) * (v - mean);
  var /= (y.size() - 1);
  EXPECT_NEAR(var / (n_arw * n_arw * rate), 1.0, 0.01);
}

TEST(ImuSimulatorTest, QuantizationOutputsWholeQuantaAndKeepsTheMean) {
  // GIVEN a constant rate that is not a multiple of the quantum.
  const double q_noise = 1e-3, rate = 100;  // Q, deg
  pb::SimTruth truth = OneAxis(rate, 5);
  truth.mutable_axes(0)->set_quantization(q_noise);
  truth.mutable_axes(0)->set_bias(0.123456);
  const std::vector<float> y = Simulate(truth, 10000);
  const double quantum_rate = q_noise * std::sqrt(12.0) * rate;
  double sum = 0;
  for (float v : y) {
    const double k = v / quantum_rate;
    // float32 output: relative rounding 6e-8 of values up to ~1e2 quanta.
    EXPECT_NEAR(k, std::round(k), 1e-4);
    sum += v;
  }
  // THEN the accumulated angle is within one quantum of the true angle.
  EXPECT_NEAR(sum / rate, 0.123456 * y.size() / rate, q_noise * std::sqrt(12.0) * 1.0001);
}

TEST(ImuSimulatorTest, RejectsNegativeNoiseTerms) {
  pb::SimTruth truth = OneAxis(100, 1);
  truth.mutable_axes(0)->set_random_walk(-1);
  auto sim = ImuSimulator::Create(truth);
  ASSERT_FALSE(sim.ok());
  EXPECT_NE(sim.status().message().find("random_walk"), std::string::npos);
  EXPECT_FALSE(ImuSimulator::Create(OneAxis(0, 1)).ok());
}

// Hashes of the samples the simulator made before the Gauss-Markov,
// band-limit, LSB, spike and extra-line terms existed (main at 6de5232,
// GCC/glibc x86-64, 20000 samples per axis): with those fields unset it must
// stay bit-identical, because seeded station tests elsewhere depend on the
// exact samples of these truths.
TEST(ImuSimulatorTest, TruthWithoutNewTermsIsBitIdenticalToBefore) {
  EXPECT_EQ(SampleHash(SimulateAll(OldFieldsTruth(), 20000)), 0x54cdcb1da97e945fULL);
  // No axis with a temperature coefficient: the chamber temperature is not
  // computed at all (recorded at 0a4971a, before that shortcut).
  pb::SimTruth no_temp = OldFieldsTruth();
  no_temp.mutable_axes(0)->clear_temp_coefficient();
  EXPECT_EQ(SampleHash(SimulateAll(no_temp, 20000)), 0x2faa9e5b02d2d863ULL);
  const struct {
    const char* profile;
    int index;
    uint64_t hash;
  } kRecorded[] = {
      {"vg700", 0, 0xa238fcc0ae2335ebULL},    {"vg700", 7, 0x135b94c3d7c4d130ULL},
      {"tactical", 0, 0x9e1c9e0ad0704f86ULL}, {"tactical", 7, 0x27bd0cfbd0e70432ULL},
      {"fog", 0, 0xc862d1374a1d6384ULL},      {"fog", 7, 0x7927ab6932c2fae3ULL},
      {"mems-lab", 0, 0x810892d90227dcdeULL}, {"mems-lab", 7, 0xbb9df52c5fb3af79ULL},
  };
  for (const auto& r : kRecorded) {
    auto profile = LotProfileByName(r.profile);
    ASSERT_TRUE(profile.ok());
    const pb::SimTruth truth =
        MakeUnitTruth(*profile, SeedFromName("LOT-GOLD"), r.index, profile->nominal_rate_hz);
    EXPECT_EQ(SampleHash(SimulateAll(truth, 20000)), r.hash) << r.profile << " unit " << r.index;
  }
}

TEST(ImuSimulatorTest, GaussMarkovTermsRecoverSigmaAndPhi) {
  // GIVEN one Gauss-Markov term alone: sigma 0.02 deg/s, T = 0.5 s at 100 Hz.
  const double rate = 100, sigma = 0.02, corr_s = 0.5;
  const double phi = std::exp(-1 / (rate * corr_s));  // 0.9802
  pb::SimTruth truth = OneAxis(rate, 11);
  pb::GaussMarkov* gm = truth.mutable_axes(0)->add_gauss_markov();
  gm->set_sigma(sigma);
  gm->set_correlation_time_s(corr_s);
  const int n = 2000000;  // 20000 s = 40000 correlation times
  const std::vector<float> y = Simulate(truth, n);
  // THEN the sample variance is sigma^2 and the lag-1 autocorrelation is phi.
  // For an AR(1) the sample variance has a relative sd of
  // sqrt(2 (1 + phi^2) / (1 - phi^2) / n) = 0.71 %; 4 % is > 5 sigma.
  const double kVarianceRelTol = 0.04;
  // r_1 has an sd of sqrt((1 - phi^2) / n) = 1.4e-4; 7e-4 is 5 sigma.
  const double kLag1Tol = 7e-4;
  const double var = Variance(y), r1 = Lag1Autocorrelation(y);
  std::printf("  GM: var / sigma^2 = %.4f, r1 = %.5f (phi %.5f)\n", var / (sigma * sigma), r1, phi);
  EXPECT_NEAR(var / (sigma * sigma), 1.0, kVarianceRelTol);
  EXPECT_NEAR(r1, phi, kLag1Tol);

  // AND with a second, faster term (0.01 deg/s, T = 0.05 s) the variances add
  // and r_1 is the variance-weighted mean of the two phis.
  const double sigma2 = 0.01, corr2_s = 0.05, phi2 = std::exp(-1 / (rate * corr2_s));
  pb::GaussMarkov* gm2 = truth.mutable_axes(0)->add_gauss_markov();
  gm2->set_sigma(sigma2);
  gm2->set_correlation_time_s(corr2_s);
  const std::vector<float> y2 = Simulate(truth, n);
  const double var_sum = sigma * sigma + sigma2 * sigma2;
  const double r1_want = (sigma * sigma * phi + sigma2 * sigma2 * phi2) / var_sum;
  const double var2 = Variance(y2), r1_2 = Lag1Autocorrelation(y2);
  std::printf("  two GM: var / sum sigma^2 = %.4f, r1 = %.5f (want %.5f)\n", var2 / var_sum, r1_2,
              r1_want);
  // The slow term dominates both statistics: the same tolerances hold.
  EXPECT_NEAR(var2 / var_sum, 1.0, kVarianceRelTol);
  EXPECT_NEAR(r1_2, r1_want, kLag1Tol);
}

TEST(ImuSimulatorTest, GaussMarkovStartsFromItsStationaryDistribution) {
  // GIVEN a slow term (T = 100 s at 100 Hz: started from 0 its first sample
  // would have a variance of (1 - phi^2) sigma^2 = 2e-4 sigma^2).
  const double sigma = 0.01;
  const int kUnits = 4000;
  std::vector<float> first;
  for (int seed = 0; seed < kUnits; ++seed) {
    pb::SimTruth truth = OneAxis(100, 1000 + seed);
    pb::GaussMarkov* gm = truth.mutable_axes(0)->add_gauss_markov();
    gm->set_sigma(sigma);
    gm->set_correlation_time_s(100);
    first.push_back(Simulate(truth, 1)[0]);
  }
  // THEN across units the first sample already has variance sigma^2. With
  // 4000 units the sample variance has a relative sd of sqrt(2 / 4000) =
  // 2.2 %; 11 % is 5 sigma.
  const double kRelTol = 0.11;
  const double ratio = Variance(first) / (sigma * sigma);
  std::printf("  GM g_0 over %d seeds: var / sigma^2 = %.4f\n", kUnits, ratio);
  EXPECT_NEAR(ratio, 1.0, kRelTol);
}

TEST(ImuSimulatorTest, BandLimitedWhiteIsTheDocumentedAr1AndKeepsTheArw) {
  // GIVEN white noise N = 0.01 deg/sqrt(s) at 100 Hz through a 15 Hz low-pass.
  const double rate = 100, n_arw = 0.01, f_c = 15;
  const double phi = std::exp(-2 * kPi * f_c / rate);  // 0.390
  pb::SimTruth ideal = OneAxis(rate, 21);
  ideal.mutable_axes(0)->set_random_walk(n_arw);
  pb::SimTruth limited = ideal;
  limited.mutable_axes(0)->set_white_bandwidth_hz(f_c);
  const int n = 4000000;
  const std::vector<float> y_ideal = Simulate(ideal, n);
  const std::vector<float> y = Simulate(limited, n);

  // THEN its variance is (1 - phi) / (1 + phi) N^2 / tau0 and r_1 is phi.
  // Relative sd of the AR(1) sample variance: sqrt(2 (1 + phi^2) /
  // (1 - phi^2) / n) = 0.08 %; 0.5 % is 6 sigma.
  const double kVarianceRelTol = 0.005;
  // r_1 sd sqrt((1 - phi^2) / n) = 4.6e-4; 2.5e-3 is 5 sigma.
  const double kLag1Tol = 2.5e-3;
  const double var_want = (1 - phi) / (1 + phi) * n_arw * n_arw * rate;
  const double var = Variance(y), r1 = Lag1Autocorrelation(y);
  std::printf("  band-limited white: var / want = %.4f, r1 = %.4f (phi %.4f)\n", var / var_want, r1,
              phi);
  EXPECT_NEAR(var / var_want, 1.0, kVarianceRelTol);
  EXPECT_NEAR(r1, phi, kLag1Tol);

  // AND means over 10 s blocks (~940 filter time constants) vary as ideal
  // white's do, N^2 / tau: the ARW is unchanged.
  const size_t kBlock = 1000;
  const double tau_s = kBlock / rate;
  const double block_ideal = BlockMeanVariance(y_ideal, kBlock);
  const double block_limited = BlockMeanVariance(y, kBlock);
  std::printf("  10 s block-mean variance: ideal / (N^2/tau) = %.4f, band-limited / ideal = %.5f\n",
              block_ideal / (n_arw * n_arw / tau_s), block_limited / block_ideal);
  // Both are driven by the same deviates (the band limit draws nothing), so
  // their block sums differ only by the filter's edge terms, of variance
  // ~2 phi^2 / (1 - phi^2) = 0.36 samples against 1000: the ratio is
  // 1 - ~0.1 % (the exact AR(1) block-mean deficit) +- 0.06 %; 0.5 % bounds it.
  const double kPairedRelTol = 0.005;
  EXPECT_NEAR(block_limited / block_ideal, 1.0, kPairedRelTol);
  // And against theory: 4000 block means, relative sd sqrt(2 / 4000) = 2.2 %;
  // 11 % is 5 sigma.
  const double kBlockRelTol = 0.11;
  EXPECT_NEAR(block_ideal / (n_arw * n_arw / tau_s), 1.0, kBlockRelTol);
  EXPECT_NEAR(block_limited / (n_arw * n_arw / tau_s), 1.0, kBlockRelTol);
}

TEST(ImuSimulatorTest, RateLsbPutsEveryOutputOnTheGridLastOfAll) {
  // GIVEN noise (sd 0.3 deg/s = 6 LSB), flicker, a Gauss-Markov term and an
  // offset, with a 0.05 deg/s rate LSB, first alone and then after the angle
  // accumulator; and each unit without the LSB (which draws nothing, so it
  // sees the same deviates).
  const double lsb = 0.05;
  const int n = 200000;
  for (double q : {0.0, 1e-4}) {
    pb::SimTruth truth = OneAxis(100, 31);
    pb::AxisTruth* a = truth.mutable_axes(0);
    a->set_bias(0.1234);
    a->set_random_walk(0.03);
    a->set_bias_instability(0.004);
    a->set_quantization(q);
    pb::GaussMarkov* gm = a->add_gauss_markov();
    gm->set_sigma(0.004);
    gm->set_correlation_time_s(20);
    const pb::SimTruth unrounded = truth;
    a->set_rate_lsb(lsb);
    const std::vector<float> y = Simulate(truth, n);
    const std::vector<float> ref = Simulate(unrounded, n);
    // THEN every output is exactly float(m * lsb) for an integer m, and it is
    // the nearest such value to the unrounded output (float32 rounding of the
    // reference, ~1e-7 of ~1 deg/s, is the only slack).
    const double kFloatSlack = 1e-6;
    int off_grid = 0, not_nearest = 0;
    std::vector<float> error(n);
    for (int k = 0; k < n; ++k) {
      const double m = std::round(y[k] / lsb);
      if (static_cast<float>(lsb * m) != y[k]) ++off_grid;
      if (std::abs(static_cast<double>(y[k]) - ref[k]) > 0.5 * lsb + kFloatSlack) ++not_nearest;
      error[k] = y[k] - ref[k];
    }
    EXPECT_EQ(off_grid, 0) << "Q " << q;
    EXPECT_EQ(not_nearest, 0) << "Q " << q;
    if (q > 0) continue;
    // AND without the accumulator, dithered by the noise, the rounding error
    // is uniform: mean 0, variance lsb^2 / 12. Its mean has an sd of
    // lsb / sqrt(12 n) = 3.2e-5 (5 sigma: 1.6e-4); its variance a relative
    // sd of sqrt(0.8 / n) = 0.2 % (5 sigma: 1 %). (After the accumulator the
    // input already lies on the grid q sqrt(12) / tau0 = 0.0346 deg/s, nearly
    // commensurate with the LSB (13 : 9), and one grid rounded onto another
    // is not dithered: its error is not uniform, so it is not checked.)
    const double kMeanTol = 1.6e-4, kVarianceRelTol = 0.01;
    std::printf("  rate LSB: rounding error mean %.2e deg/s, var / (lsb^2/12) = %.4f\n",
                Mean(error), Variance(error) / (lsb * lsb / 12));
    EXPECT_NEAR(Mean(error), 0.0, kMeanTol);
    EXPECT_NEAR(Variance(error) / (lsb * lsb / 12), 1.0, kVarianceRelTol);
  }
}

TEST(ImuSimulatorTest, SpikesAreSingleSamplesAtTheDeclaredRate) {
  // GIVEN only spikes: 0.5 per second of +/-2.5 deg/s at 100 Hz (p = 0.005).
  const double rate = 100, spike_hz = 0.5, amplitude = 2.5;
  pb::SimTruth truth = OneAxis(rate, 41);
  truth.mutable_axes(0)->set_spike_rate_hz(spike_hz);
  truth.mutable_axes(0)->set_spike_amplitude(amplitude);
  const int n = 1000000;
  const std::vector<float> y = Simulate(truth, n);
  int up = 0, down = 0, other = 0;
  for (float v : y) {
    if (v == static_cast<float>(amplitude)) {
      ++up;
    } else if (v == static_cast<float>(-amplitude)) {
      ++down;
    } else if (v != 0) {
      ++other;
    }
  }
  // THEN each outlier is exactly +/-amplitude on its one sample, their count
  // is binomial(n, p): mean 5000, sd sqrt(n p (1 - p)) = 70.5, and the signs
  // split binomially (sd sqrt(count / 4) = 35). 5 sigma each.
  const double p = spike_hz / rate;
  const double kCountTol = 5 * std::sqrt(n * p * (1 - p));
  const int count = up + down;
  const double kSignTol = 5 * std::sqrt(count / 4.0);
  std::printf("  spikes: %d (expected %.0f +- %.1f), %d up / %d down\n", count, n * p,
              std::sqrt(n * p * (1 - p)), up, down);
  EXPECT_EQ(other, 0);
  EXPECT_NEAR(count, n * p, kCountTol);
  EXPECT_NEAR(up - 0.5 * count, 0.0, kSignTol);

  // AND at the limit spike_rate_hz * tau0 = 1 every sample is an outlier.
  truth.mutable_axes(0)->set_spike_rate_hz(rate);
  for (float v : Simulate(truth, 1000)) EXPECT_EQ(std::abs(v), static_cast<float>(amplitude));
}

TEST(ImuSimulatorTest, SinusoidsAppearAtTheirFrequencies) {
  // GIVEN white noise (sd 0.1 deg/s) and two lines, 0.02 deg/s at 3.7 Hz and
  // 0.05 deg/s at 24.7 Hz, for one hour at 100 Hz.
  const double rate = 100;
  pb::SimTruth truth = OneAxis(rate, 51);
  truth.mutable_axes(0)->set_random_walk(0.01);
  const std::pair<double, double> kLines[] = {{0.02, 3.7}, {0.05, 24.7}};
  for (auto [amplitude, f_hz] : kLines) {
    pb::Sinusoid* line = truth.mutable_axes(0)->add_sinusoids();
    line->set_amplitude(amplitude);
    line->set_frequency_hz(f_hz);
  }
  const int n = 360000;
  const std::vector<float> y = Simulate(truth, n);
  // THEN a lock-in finds each amplitude at its frequency and nothing off the
  // lines. The noise puts an sd of 0.1 sqrt(2 / n) = 2.4e-4 deg/s on each
  // quadrature; 1.2e-3 is 5 sigma.
  const double kAmplitudeTol = 1.2e-3;
  for (auto [amplitude, f_hz] : kLines) {
    const double found = LockInAmplitude(y, f_hz, rate);
    const double off = LockInAmplitude(y, 0.9 * f_hz, rate);
    std::printf("  line %.1f Hz: amplitude %.5f (truth %.3f), at 0.9 f: %.5f\n", f_hz, found,
                amplitude, off);
    EXPECT_NEAR(found, amplitude, kAmplitudeTol);
    EXPECT_LT(off, kAmplitudeTol);
  }
}

TEST(ImuSimulatorTest, MemsTermsAreSeededAndGenerateInPiecesEqualsAtOnce) {
  pb::SimTruth truth = OldFieldsTruth();
  pb::AxisTruth* a = truth.mutable_axes(0);
  pb::GaussMarkov* gm = a->add_gauss_markov();
  gm->set_sigma(0.01);
  gm->set_correlation_time_s(3);
  a->set_white_bandwidth_hz(20);
  a->set_rate_lsb(0.01);
  a->set_spike_rate_hz(1);
  a->set_spike_amplitude(1);
  pb::Sinusoid* line = truth.mutable_axes(2)->add_sinusoids();
  line->set_amplitude(0.1);
  line->set_frequency_hz(11);
  const auto whole = SimulateAll(truth, 5000);
  EXPECT_EQ(whole, SimulateAll(truth, 5000));
  EXPECT_NE(whole, SimulateAll(OldFieldsTruth(), 5000));
  auto sim = ImuSimulator::Create(truth);
  ASSERT_TRUE(sim.ok());
  std::vector<std::vector<float>> pieces(truth.axes_size());
  for (int n : {1, 13, 986, 4000}) sim->Generate(n, pieces);
  EXPECT_EQ(pieces, whole);
}

TEST(ImuSimulatorTest, RejectsInvalidMemsTermsNamingTheField) {
  // At 100 Hz: Nyquist 50 Hz, spike_rate_hz at most 100.
  const struct {
    const char* field;
    void (*set)(pb::AxisTruth*);
  } kCases[] = {
      {"gauss_markov[0].correlation_time_s",
       [](pb::AxisTruth* a) { a->add_gauss_markov()->set_sigma(1); }},
      {"gauss_markov[1].sigma",
       [](pb::AxisTruth* a) {
         a->add_gauss_markov()->set_correlation_time_s(1);
         pb::GaussMarkov* g = a->add_gauss_markov();
         g->set_sigma(-1);
         g->set_correlation_time_s(1);
       }},
      {"gauss_markov[0].correlation_time_s",
       [](pb::AxisTruth* a) { a->add_gauss_markov()->set_correlation_time_s(INFINITY); }},
      {"white_bandwidth_hz", [](pb::AxisTruth* a) { a->set_white_bandwidth_hz(50); }},
      {"white_bandwidth_hz", [](pb::AxisTruth* a) { a->set_white_bandwidth_hz(NAN); }},
      {"rate_lsb", [](pb::AxisTruth* a) { a->set_rate_lsb(-0.05); }},
      {"spike_rate_hz", [](pb::AxisTruth* a) { a->set_spike_rate_hz(100.5); }},
      {"spike_rate_hz", [](pb::AxisTruth* a) { a->set_spike_rate_hz(-1); }},
      {"spike_amplitude", [](pb::AxisTruth* a) { a->set_spike_amplitude(INFINITY); }},
      {"sinusoids[0].amplitude", [](pb::AxisTruth* a) { a->add_sinusoids()->set_amplitude(-1); }},
      {"sinusoids[0].frequency_hz",
       [](pb::AxisTruth* a) { a->add_sinusoids()->set_frequency_hz(60); }},
      {"sinusoids[0].frequency_hz",
       [](pb::AxisTruth* a) { a->add_sinusoids()->set_frequency_hz(-1); }},
  };
  for (const auto& c : kCases) {
    pb::SimTruth truth = OneAxis(100, 1);
    c.set(truth.mutable_axes(0));
    auto sim = ImuSimulator::Create(truth);
    ASSERT_FALSE(sim.ok()) << c.field;
    EXPECT_NE(sim.status().message().find(c.field), std::string::npos)
        << c.field << ": " << sim.status().message();
  }
  // The limits themselves are accepted.
  pb::SimTruth edge = OneAxis(100, 1);
  edge.mutable_axes(0)->set_spike_rate_hz(100);
  edge.mutable_axes(0)->set_white_bandwidth_hz(49.9);
  edge.mutable_axes(0)->add_sinusoids()->set_frequency_hz(49.9);
  EXPECT_TRUE(ImuSimulator::Create(edge).ok());
}

TEST(LotProfileTest, UnitsDifferAndPlantedFailuresAreWorse) {
  auto profile = LotProfileByName("vg700");
  ASSERT_TRUE(profile.ok());
  const uint64_t seed = SeedFromName("LOT-A");
  pb::SimTruth u0 = MakeUnitTruth(*profile, seed, 0, 100);
  pb::SimTruth u1 = MakeUnitTruth(*profile, seed, 1, 100);
  pb::SimTruth u7 = MakeUnitTruth(*profile, seed, 7, 100);
  EXPECT_NE(u0.axes(0).random_walk(), u1.axes(0).random_walk());
  EXPECT_NE(u0.seed(), u1.seed());
  EXPECT_EQ(u7.profile(), "vg700/planted-fail");
  EXPECT_EQ(u0.profile(), "vg700/typical");
  EXPECT_GT(u7.axes(0).bias_instability(), 2 * profile->axes[0].typical.bias_instability());
  // Reproducible from the lot name.
  EXPECT_EQ(MakeUnitTruth(*profile, seed, 1, 100).SerializeAsString(), u1.SerializeAsString());
  EXPECT_FALSE(LotProfileByName("nope").ok());
}

TEST(LotProfileTest, MemsRealUnitsAreFiniteOnEveryAxisAndOnTheLsbGrid) {
  const std::vector<std::string> names = LotProfileNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "mems-real"), names.end());
  auto profile = LotProfileByName("mems-real");
  ASSERT_TRUE(profile.ok()) << profile.status().ToString();
  ASSERT_EQ(profile->axes.size(), 6u);
  const uint64_t seed = SeedFromName("LOT-REAL");
  const pb::SimTruth u0 = MakeUnitTruth(*profile, seed, 0, profile->nominal_rate_hz);
  const pb::SimTruth u1 = MakeUnitTruth(*profile, seed, 1, profile->nominal_rate_hz);
  // Unit-to-unit spread reaches the new terms; the part's design does not.
  EXPECT_NE(u0.axes(0).gauss_markov(0).sigma(), u1.axes(0).gauss_markov(0).sigma());
  EXPECT_NE(u0.axes(0).gauss_markov(0).correlation_time_s(),
            u1.axes(0).gauss_markov(0).correlation_time_s());
  EXPECT_NE(u0.axes(0).spike_amplitude(), u1.axes(0).spike_amplitude());
  EXPECT_NE(u0.axes(2).sinusoids(0).amplitude(), u1.axes(2).sinusoids(0).amplitude());
  EXPECT_EQ(u0.axes(2).sinusoids(0).frequency_hz(), 24.7);
  EXPECT_EQ(u0.axes(0).white_bandwidth_hz(), 15);
  EXPECT_EQ(u0.axes(0).rate_lsb(), 0.05);
  EXPECT_EQ(u0.axes(3).rate_lsb(), 0.0327);
  for (int index : {0, 7}) {  // a typical unit and a planted failure
    const pb::SimTruth truth = MakeUnitTruth(*profile, seed, index, profile->nominal_rate_hz);
    const auto y = SimulateAll(truth, 60000);  // 10 min
    ASSERT_EQ(y.size(), 6u);
    for (int a = 0; a < 6; ++a) {
      const double lsb = truth.axes(a).rate_lsb();
      int bad = 0;
      for (float v : y[a]) {
        if (!std::isfinite(v) || static_cast<float>(lsb * std::round(v / lsb)) != v) ++bad;
      }
      EXPECT_EQ(bad, 0) << truth.profile() << " " << truth.axes(a).axis();
    }
    // The z accelerometer sees gravity.
    EXPECT_NEAR(Mean(y[5]), 9.80665, 1.0);
  }
}

}  // namespace
}  // namespace imuqual::sim
