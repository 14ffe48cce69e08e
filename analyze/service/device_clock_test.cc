// The device clock fit: an exact line, a fast crystal seen through a host
// that delivers late and in bursts, and the conditions for a usable fit.
#include "analyze/service/device_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace imuqual::analyze {
namespace {

// A part running at `actual_hz` for `samples` counts, in batches of `batch`:
// each batch arrives at host second `arrival(emitted, latency)`, latency a
// fresh uniform draw in [lo, hi] seconds, after host time `origin_us`.
template <typename Arrival>
void Feed(DeviceClockFit* fit, double actual_hz, int64_t samples, int64_t batch, unsigned seed,
          double lo, double hi, int64_t origin_us, Arrival arrival) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> latency(lo, hi);
  for (int64_t c = 0; c < samples; c += batch) {
    const double emitted = static_cast<double>(c) / actual_hz;
    fit->Add(c, origin_us + std::llround(arrival(emitted, latency(rng)) * 1e6));
  }
}

TEST(DeviceClockFitTest, ExactArrivalsGiveTheRateAndNoJitter) {
  DeviceClockFit fit(200);
  // 201.5 Hz real, batches of 50 samples, arrivals exactly on time.
  for (int64_t c = 1000; c < 1000 + 200 * 60; c += 50) {
    fit.Add(c, 1'700'000'000'000'000 + std::llround((c - 1000) / 201.5 * 1e6));
  }
  ASSERT_TRUE(fit.Usable(400));
  EXPECT_NEAR(fit.RateHz(), 201.5, 201.5 * 1e-8);
  EXPECT_LT(fit.JitterRmsS(), 1e-6);  // microsecond rounding only
  EXPECT_LT(fit.RateSigmaHz(), 1e-4);
}

TEST(DeviceClockFitTest, LateAndBurstyArrivalsDoNotTiltTheClock) {
  // A 2000 Hz part running 5000 ppm fast; the host sees each batch 0.2-3 ms
  // late, and for 300 ms of every 10 s it is busy: those batches arrive
  // together at the end of the busy spell.
  DeviceClockFit fit(2000);
  Feed(&fit, 2010, 2000 * 120, 48, 5, 0.2e-3, 3e-3, 0, [](double emitted, double late) {
    const double in_spell = std::fmod(emitted, 10.0);
    return in_spell > 4.0 && in_spell < 4.3 ? emitted - in_spell + 4.3 + late : emitted + late;
  });
  ASSERT_TRUE(fit.Usable(2000 * 2));
  const double ppm = (fit.RateHz() / 2000 - 1) * 1e6;
  EXPECT_NEAR(ppm, 5000, 20) << fit.RateHz();
  // The lateness scatter: the uniform latency's spread plus the bursts.
  EXPECT_GT(fit.JitterRmsS(), 0.5e-3);
  EXPECT_LT(fit.JitterRmsS(), 0.1);
}

TEST(DeviceClockFitTest, AStarvationLongerThanAWindowDoesNotTiltTheClock) {
  // A 10 s run of a 2010 Hz part (nominal 2000) on a starved host: from 3 s
  // to 6.5 s of device time nothing is delivered, then the backlog arrives
  // over 0.5 s. Every window inside the spell has only late arrivals, so a
  // line through per-window minima tilts by thousands of ppm; the line under
  // the arrivals rests on the on-time ones either side.
  DeviceClockFit fit(2000);
  Feed(&fit, 2010, 2010 * 10, 20, 11, 0.1e-3, 2e-3, 1'000'000'000, [](double emitted, double late) {
    return emitted > 3.0 && emitted < 6.5 ? 6.5 + (emitted - 3.0) / 7.0 + late : emitted + late;
  });
  ASSERT_TRUE(fit.Usable(2000 * 2));
  const double ppm = (fit.RateHz() / 2000 - 1) * 1e6;
  EXPECT_NEAR(ppm, 5000, 50) << fit.RateHz();
  // The spell shows in the jitter, and neither in the line nor in its
  // standard error (the spell's windows lie far above the line).
  EXPECT_GT(fit.RateSigmaHz(), 0);
  EXPECT_LT(fit.RateSigmaHz() / 2000 * 1e6, 50) << fit.RateSigmaHz();
  EXPECT_GT(fit.JitterRmsS(), 0.01);
}

TEST(DeviceClockFitTest, TooFewWindowsOrTooShortASpanIsNotUsable) {
  DeviceClockFit fit(100);
  fit.Add(0, 1'000'000);
  fit.Add(100, 2'000'000);
  EXPECT_FALSE(fit.Usable(10));  // two windows
  fit.Add(200, 3'000'000);
  EXPECT_TRUE(fit.Usable(150));
  EXPECT_FALSE(fit.Usable(500));  // spans 200 samples only
  EXPECT_NEAR(fit.RateHz(), 100, 1e-9);
  // Time running backwards against the counter is no clock.
  DeviceClockFit backwards(100);
  for (int i = 0; i < 5; ++i) backwards.Add(i * 100, 10'000'000 - i * 1'000'000);
  EXPECT_FALSE(backwards.Usable(1));
}

}  // namespace
}  // namespace imuqual::analyze
