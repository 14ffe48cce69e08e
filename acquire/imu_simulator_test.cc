#include "acquire/imu_simulator.h"

#include <gtest/gtest.h>

#include <cmath>
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

}  // namespace
}  // namespace imuqual::sim
