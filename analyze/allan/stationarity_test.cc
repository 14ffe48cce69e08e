#include "analyze/allan/stationarity.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>

namespace imuqual::allan {
namespace {

constexpr double kTau0 = 0.01;  // 100 Hz

CompositeModel White(double n) { return {{{TermKind::kWhite, n}}}; }

std::vector<double> WhiteRecord(double n, int samples, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, n / std::sqrt(kTau0));
  std::vector<double> y(samples);
  for (double& v : y) v = g(rng);
  return y;
}

// Each term's structure function reproduces its AVAR:
// AVAR(tau) = (4 D(tau) - D(2 tau)) / (2 tau^2) (composite_model.h's closed
// forms, continuous time: tau >> tau0 for the terms whose discrete AVAR has
// a 1/m correction).
TEST(PhaseStructureFunctionTest, ReproducesEachTermsAvar) {
  const double tau0 = 0.01;
  const std::vector<ModelTerm> terms = {
      {TermKind::kQuantization, 2e-4},      {TermKind::kWhite, 3e-3},
      {TermKind::kFlicker, 1e-3},           {TermKind::kRandomWalk, 5e-5},
      {TermKind::kGaussMarkov, 2e-3, 30.0}, {TermKind::kSinusoid, 1e-3, 0, 0.0371}};
  for (const ModelTerm& t : terms) {
    const CompositeModel model{{t}};
    for (double tau : {10.0, 100.0, 1000.0}) {
      const double d1 = PhaseStructureFunction(model, tau0, tau);
      const double d2 = PhaseStructureFunction(model, tau0, 2 * tau);
      const double avar = (4 * d1 - d2) / (2 * tau * tau);
      const double expected = TermAvar(t, tau / tau0, tau0);
      // The random walk's discrete AVAR has a (2 m^2 + 1)/(2 m^2) factor;
      // at m >= 1000 it is within 1e-6.
      EXPECT_NEAR(avar / expected, 1.0, 1e-5) << TermKindName(t.kind) << " tau " << tau;
    }
  }
}

TEST(BinMeansTest, MeansOfFiniteSamplesAndHalfEmptyBinsAreNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> y = {1, 3, nan, 4, nan, nan, 5, 7, 9};
  // Bins of 2: {1,3} {nan,4} {nan,nan} {5,7}; the 9 left over is no bin.
  const std::vector<double> m = BinMeans(y, 2, 4);
  ASSERT_EQ(m.size(), 4u);
  EXPECT_EQ(m[0], 2.0);
  EXPECT_EQ(m[1], 4.0);  // one of two finite: half is enough
  EXPECT_TRUE(std::isnan(m[2]));
  EXPECT_EQ(m[3], 6.0);
  // A bin past the end of the record is NaN, not read out of bounds.
  const std::vector<double> past = BinMeans(y, 4, 3);
  EXPECT_EQ(past[0], 8.0 / 3.0);
  EXPECT_TRUE(std::isnan(past[2]));
}

TEST(BinAccumulatorTest, MeansPhaseIsEveryBaseBinsPointOfThePhase) {
  // GIVEN 1000 samples in base bins of 10, appended in uneven batches, with
  // one invalid sample in bin 37, 15 missing samples from 500 and a partial
  // last bin,
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  std::vector<float> y(1003);
  for (float& v : y) v = static_cast<float>(3.0 + g(rng));
  std::vector<uint8_t> invalid(y.size(), 0);
  invalid[374] = 1;
  BinAccumulator acc(10);
  size_t i = 0;
  while (i < y.size()) {
    if (i == 500) {
      acc.AppendMissing(15);
      i += 15;
      continue;
    }
    const size_t n = std::min<size_t>({y.size() - i, 1 + rng() % 37, i < 500 ? 500 - i : 9999});
    acc.Append(std::span<const float>(y).subspan(i, n),
               std::span<const uint8_t>(invalid).subspan(i, n));
    i += n;
  }
  std::vector<uint8_t> flags = invalid;
  for (size_t k = 500; k < 515; ++k) flags[k] = 1;
  const PhaseRecord samples = PhaseFromRate(std::span<const float>(y).first(1000), 0.01,
                                            std::span<const uint8_t>(flags).first(1000));
  // WHEN the means' phase is taken, THEN it has a point every 10 samples
  // (interval 0.1 s) over the whole bins; bins 37, 50 and 51 are gaps; and
  // away from them its second differences are the samples' phase's at every
  // 10th point (the phases differ by their reference slope only).
  const PhaseRecord means = acc.MeansPhase(0.01);
  EXPECT_DOUBLE_EQ(means.tau0_s, 0.1);
  ASSERT_EQ(means.size(), 101);
  EXPECT_EQ(InvalidRateIndices(means), (std::vector<int64_t>{37, 50, 51}));
  for (int64_t j = 1; j + 1 < means.size(); ++j) {
    if (j >= 37 && j <= 38) continue;
    if (j >= 50 && j <= 52) continue;
    const double want = samples.x[10 * (j + 1)] - 2 * samples.x[10 * j] + samples.x[10 * (j - 1)];
    const double got = means.x[j + 1] - 2 * means.x[j] + means.x[j - 1];
    EXPECT_NEAR(got, want, 1e-12) << j;
  }
  // A stretch: the whole bins inside samples [95, 512), bins 10..50.
  const PhaseRecord part = acc.MeansPhase(0.01, 95, 512);
  EXPECT_EQ(part.size(), 42);
  EXPECT_EQ(InvalidRateIndices(part), (std::vector<int64_t>{27, 40}));
}

// Streamed bin sums give BinMeans' means of the same record, whatever the
// pieces it arrives in, with missing samples, invalid flags, and past the
// merge that keeps at most kMaxBaseBins base bins.
TEST(BinAccumulatorTest, MatchesBinMeansThroughGapsFlagsAndMerges) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  // 600 000 samples in base bins of 2: 300 000 base bins, so the
  // accumulator merges once (base 4).
  constexpr int64_t kSamples = 600000;
  std::vector<double> y(kSamples);
  for (double& v : y) v = static_cast<float>(g(rng));  // as the float samples arrive
  BinAccumulator acc(2);
  int64_t i = 0;
  while (i < kSamples) {
    const int64_t n = std::min<int64_t>(kSamples - i, 1 + static_cast<int64_t>(rng() % 997));
    if (i > 1000 && rng() % 50 == 0) {  // a gap
      for (int64_t k = i; k < i + n; ++k) y[k] = std::numeric_limits<double>::quiet_NaN();
      acc.AppendMissing(n);
    } else {
      std::vector<float> values(y.begin() + i, y.begin() + i + n);
      std::vector<uint8_t> invalid(n, 0);
      for (int64_t k = 0; k < n; k += 7) {  // every 7th sample flagged
        invalid[k] = 1;
        y[i + k] = std::numeric_limits<double>::quiet_NaN();
      }
      acc.Append(values, invalid);
    }
    i += n;
  }
  EXPECT_EQ(acc.samples(), kSamples);
  EXPECT_EQ(acc.base_samples(), 4);
  for (const int64_t want : {int64_t{4}, int64_t{2000}, int64_t{6001}}) {
    int64_t bin = want;
    const std::vector<double> got = acc.Means(&bin);
    EXPECT_EQ(bin % 4, 0);
    EXPECT_LE(std::abs(bin - want), 2);
    const std::vector<double> ref = BinMeans(y, bin, static_cast<int>(kSamples / bin));
    // The same bins' noise levels, differences across flags and gaps left out.
    const std::vector<double> got_square = acc.MeanSquareDifferences(bin);
    const std::vector<double> ref_square =
        BinMeanSquareDifferences(y, bin, static_cast<int>(kSamples / bin));
    ASSERT_EQ(got_square.size(), ref_square.size());
    int square_present = 0;
    for (size_t k = 0; k < got_square.size(); ++k) {
      if (std::isnan(ref_square[k])) {
        EXPECT_TRUE(std::isnan(got_square[k])) << k;
      } else {
        ++square_present;
        EXPECT_NEAR(got_square[k], ref_square[k], 1e-9 * ref_square[k]) << k;
      }
    }
    EXPECT_GT(square_present, static_cast<int>(got_square.size()) / 2);
    ASSERT_EQ(got.size(), ref.size());
    for (size_t k = 0; k < got.size(); ++k) {
      if (std::isnan(ref[k])) {
        EXPECT_TRUE(std::isnan(got[k])) << k;
      } else {
        EXPECT_NEAR(got[k], ref[k], 1e-12) << k;
      }
    }
  }
}

// The scan of bin means formed elsewhere is the scan of the record.
TEST(StationarityTest, ScanBinMeansIsTheScanOfTheRecord) {
  std::vector<double> y = WhiteRecord(1e-3, 360000, 11);
  for (size_t i = 200000; i < y.size(); ++i) y[i] += 0.004;
  auto direct = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(direct.ok());
  const std::vector<double> means = BinMeans(y, 1200, 300);
  auto binned = ScanBinMeans({means}, {White(1e-3)}, kTau0, 12.0);
  ASSERT_TRUE(binned.ok());
  ASSERT_EQ(direct->events.size(), binned->events.size());
  ASSERT_FALSE(direct->events.empty());
  for (size_t e = 0; e < direct->events.size(); ++e) {
    EXPECT_EQ(direct->events[e].time_s, binned->events[e].time_s);
    EXPECT_EQ(direct->events[e].axes[0].size, binned->events[e].axes[0].size);
  }
  EXPECT_EQ(direct->threshold_p, binned->threshold_p);
  // The step inside bin 166 (at 2000 s, bins of 12 s: 1992..2004) is one
  // step at its middle, not two half steps.
  EXPECT_NEAR(direct->events.front().time_s, 1998, 1e-9);
  EXPECT_NEAR(direct->events.front().axes[0].size, 0.004, 3 * direct->events.front().axes[0].sigma);
  // More bins than a scan takes: not scanned, said why.
  auto many = ScanBinMeans({BinMeans(y, 100, 3600)}, {White(1e-3)}, kTau0, 1.0);
  ASSERT_TRUE(many.ok());
  EXPECT_FALSE(many->scanned);
  EXPECT_NE(many->note.find("too many bins"), std::string::npos);
}

// The records of `record(seed)` for 200 seeds from `first_seed` that a scan
// at a 5 % level against `model` reports an event in; the test expects 10
// within three Monte Carlo standard errors.
template <typename Record>
void ExpectAlarmsAtTheLevel(const CompositeModel& model, uint64_t first_seed, Record record,
                            const char* what) {
  int alarms = 0;
  constexpr int kRecords = 200;
  constexpr double kLevel = 0.05;
  StationarityOptions o;
  o.false_alarm = kLevel;
  for (int seed = 0; seed < kRecords; ++seed) {
    const std::vector<double> y = record(first_seed + seed);
    auto scan = ScanStationarity({y}, {model}, kTau0, o);
    ASSERT_TRUE(scan.ok()) << scan.status().message();
    ASSERT_TRUE(scan->scanned);
    alarms += scan->events.empty() ? 0 : 1;
  }
  const double se = std::sqrt(kLevel * (1 - kLevel) * kRecords);
  std::printf("false alarms%s: %d of %d records at a %g level\n", what, alarms, kRecords, kLevel);
  EXPECT_NEAR(alarms, kLevel * kRecords, 3 * se);
}

TEST(StationarityTest, FalseAlarmsAtTheStatedRate) {
  // GIVEN 200 white records with their true model; WHEN scanned at a 5 %
  // level (the threshold calibrated on records drawn from the model); THEN
  // the alarm fraction is 5 % within three Monte Carlo standard errors, on
  // either side: the level is the rate, not a bound far above it (Bonferroni
  // over the candidates gave a fraction of the level).
  ExpectAlarmsAtTheLevel(
      White(1e-3), 100, [](uint64_t seed) { return WhiteRecord(1e-3, 30000, seed); }, "");
}

TEST(StationarityTest, FindsAPlantedStepWithItsSize) {
  // GIVEN a white record (N = 1e-3 u sqrt(s), 300 s) with a step of 1e-3 u
  // at 123.4 s: the 1 s bin means have sd 1e-3, so the step's sigma is
  // 1e-3 sqrt(1/123 + 1/177) = 1.2e-4 (z about 8).
  std::vector<double> y = WhiteRecord(1e-3, 30000, 7);
  const double step = 1e-3;
  for (size_t i = 12340; i < y.size(); ++i) y[i] += step;
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok()) << scan.status().message();
  ASSERT_EQ(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_EQ(e.kind, EventKind::kStep);
  // The boundary of the largest z: a step of one bin-mean sd moves it by a
  // few bins.
  EXPECT_NEAR(e.time_s, 123.4, 5 * scan->bin_s);
  EXPECT_TRUE(e.axes[0].named);
  // Within 3 sigma of the truth, the boundary's few bins off included (a
  // fraction bin / length of the size each).
  EXPECT_NEAR(e.axes[0].size, step, 3 * e.axes[0].sigma);
  EXPECT_LT(e.axes[0].sigma, step / 5);
}

TEST(StationarityTest, FindsABurstAndTheLongestStationarySegment) {
  std::vector<double> y = WhiteRecord(1e-3, 60000, 11);
  for (size_t i = 40000; i < 42000; ++i) y[i] += 2e-3;  // 400-420 s: z about 9
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok());
  ASSERT_GE(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_EQ(e.kind, EventKind::kBurst);
  EXPECT_NEAR(e.time_s, 400, 2 * scan->bin_s);
  EXPECT_NEAR(e.time_s + e.window_s, 420, 2 * scan->bin_s + 0.5 * 20);
  const Segment s = LongestStationarySegment(*scan, 600);
  EXPECT_NEAR(s.begin_s, 0, 1e-9);
  EXPECT_NEAR(s.end_s, e.time_s, 1e-9);
}

TEST(StationarityTest, JointEventNamesTheAxesItMoves) {
  // A step on axes 0 and 2 of three, z about 4.2 each (sigma 1.2e-4): below
  // a single axis's Bonferroni threshold (about 4.9), clear together.
  std::vector<std::vector<double>> y;
  for (int a = 0; a < 3; ++a) y.push_back(WhiteRecord(1e-3, 30000, 50 + a));
  for (int a : {0, 2}) {
    for (size_t i = 15000; i < y[a].size(); ++i) y[a][i] += 5e-4;
  }
  auto scan = ScanStationarity({y[0], y[1], y[2]}, {White(1e-3), White(1e-3), White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok());
  ASSERT_GE(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_NEAR(e.time_s, 150, 2 * scan->bin_s);
  EXPECT_TRUE(e.joint);
  EXPECT_TRUE(e.axes[0].named);
  EXPECT_FALSE(e.axes[1].named);
  EXPECT_TRUE(e.axes[2].named);
}

// The same step with the unmoved axis missing from 90 s on: the joint test
// sums over the axes with data at each candidate (2 degrees of freedom
// there), so the axis that stopped does not hide the others' event.
TEST(StationarityTest, JointTestStandsWhereAnAxisHasNoData) {
  std::vector<std::vector<double>> y;
  for (int a = 0; a < 3; ++a) y.push_back(WhiteRecord(1e-3, 30000, 50 + a));
  for (int a : {0, 2}) {
    for (size_t i = 15000; i < y[a].size(); ++i) y[a][i] += 5e-4;
  }
  for (size_t i = 9000; i < y[1].size(); ++i) y[1][i] = std::nan("");
  auto scan = ScanStationarity({y[0], y[1], y[2]}, {White(1e-3), White(1e-3), White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok());
  ASSERT_TRUE(scan->scanned) << scan->note;
  ASSERT_GE(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_NEAR(e.time_s, 150, 2 * scan->bin_s);
  EXPECT_TRUE(e.joint);
  EXPECT_TRUE(e.axes[0].named);
  EXPECT_FALSE(std::isfinite(e.axes[1].z));
  EXPECT_TRUE(e.axes[2].named);
}

TEST(StationarityTest, JointTestFalseAlarmsAtTheStatedRateWhereAnAxisHasNoData) {
  // Stationary records with one axis missing from 90 s: false alarms at the
  // stated 5 % (200 records, within three Monte Carlo standard errors).
  int alarms = 0;
  for (uint64_t seed = 0; seed < 200; ++seed) {
    std::vector<std::vector<double>> z;
    for (int a = 0; a < 3; ++a) z.push_back(WhiteRecord(1e-3, 30000, 7000 + 3 * seed + a));
    for (size_t i = 9000; i < z[1].size(); ++i) z[1][i] = std::nan("");
    auto s = ScanStationarity({z[0], z[1], z[2]}, {White(1e-3), White(1e-3), White(1e-3)}, kTau0,
                              {.false_alarm = 0.05});
    ASSERT_TRUE(s.ok());
    alarms += s->events.empty() ? 0 : 1;
  }
  std::printf("false alarms, 3 axes, one missing from 90 s: %d of 200 at a 0.05 level\n", alarms);
  EXPECT_NEAR(alarms, 10, 3 * std::sqrt(200 * 0.05 * 0.95));
}

TEST(StationarityTest, MissingSamplesAndShortRecords) {
  std::vector<double> y = WhiteRecord(1e-3, 30000, 3);
  for (size_t i = 5000; i < 9000; ++i) y[i] = std::nan("");  // a 40 s gap
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok()) << scan.status().message();
  EXPECT_TRUE(scan->scanned);
  EXPECT_TRUE(scan->events.empty());

  const std::vector<double> shortest(100, 0.0);
  auto too_short = ScanStationarity({shortest}, {White(1e-3)}, kTau0, {.bin_s = 1});
  ASSERT_TRUE(too_short.ok());
  EXPECT_FALSE(too_short->scanned);
  EXPECT_NE(too_short->note.find("too short"), std::string::npos);

  // An axis with data in fewer bins than a scan needs is named, and the
  // group not scanned (the station leaves such an axis out of its group).
  std::vector<double> dropped = WhiteRecord(1e-3, 30000, 4);
  for (size_t i = 2000; i < dropped.size(); ++i) dropped[i] = std::nan("");
  auto sparse = ScanStationarity({y, dropped}, {White(1e-3), White(1e-3)}, kTau0, {.bin_s = 1});
  ASSERT_TRUE(sparse.ok());
  EXPECT_FALSE(sparse->scanned);
  EXPECT_EQ(sparse->note,
            "axis 2 has data in 20 of its 300 bins of 1 s (32 needed for a stationarity scan)");
}

// White noise N and a rate random walk K (the wander that makes the bin
// means' differences correlate across a gap).
std::vector<double> WhiteAndRandomWalkRecord(double n, double k, int samples, uint64_t seed) {
  std::vector<double> y = WhiteRecord(n, samples, seed);
  std::mt19937_64 rng(seed + 1000003);
  std::normal_distribution<double> g(0.0, k * std::sqrt(kTau0));
  double walk = 0;
  for (double& v : y) {
    walk += g(rng);
    v += walk;
  }
  return y;
}

TEST(StationarityTest, FalseAlarmsAtTheStatedRateThroughAGap) {
  // GIVEN 200 records of white noise and a rate random walk (equal AVAR
  // near 100 s) with the same 40 s missing (bins 100..139 of 300), scanned
  // with their true model at 5 %: the differences of the present bins
  // bridge the gap with their own covariance, so the rate stays the level
  // (a wrong covariance across the gap would move it).
  const CompositeModel model{{{TermKind::kWhite, 1e-3}, {TermKind::kRandomWalk, 1.7e-5}}};
  ExpectAlarmsAtTheLevel(
      model, 500,
      [](uint64_t seed) {
        std::vector<double> y = WhiteAndRandomWalkRecord(1e-3, 1.7e-5, 30000, seed);
        for (size_t i = 10000; i < 14000; ++i) y[i] = std::nan("");
        return y;
      },
      " through a gap");
}

TEST(StationarityTest, AStepWhileTheRecordWasMissingIsFound) {
  // GIVEN a white record (1 s bin means of sd 1e-3) whose samples from 100
  // to 140 s never arrived, and a level step at 120 s, inside the gap
  // (sigma about 1e-3 sqrt(1/100 + 1/160) = 1.3e-4); THEN one step, its
  // size within 3 sigma. Of 1e-3 (z ~ 8) it is found at the gap or at the
  // middle of a bin beside it (half a step in that bin's mean is within one
  // sd of its noise); of 5e-3 (a bin beside the gap would be 2.5 sd off)
  // its boundary is anywhere in the gap, [100, 140] s.
  for (const double step : {1e-3, 5e-3}) {
    std::vector<double> y = WhiteRecord(1e-3, 30000, 11);
    for (size_t i = 12000; i < y.size(); ++i) y[i] += step;
    for (size_t i = 10000; i < 14000; ++i) y[i] = std::nan("");
    auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0, {.bin_s = 1});
    ASSERT_TRUE(scan.ok()) << scan.status().message();
    ASSERT_EQ(scan->events.size(), 1u) << step;
    const StationarityEvent& e = scan->events[0];
    EXPECT_EQ(e.kind, EventKind::kStep);
    const EventAxis& a = e.axes[0];
    EXPECT_TRUE(a.named);
    EXPECT_NEAR(a.size, step, 3 * a.sigma);
    EXPECT_LT(a.sigma, 2e-4);
    EXPECT_GE(e.time_s, 99.0);
    EXPECT_LE(e.time_s, 141.0);
    if (step > 2e-3 || std::isfinite(a.gap_from_s)) {
      EXPECT_DOUBLE_EQ(a.gap_from_s, 100.0) << "time " << e.time_s << " z " << a.z;
      EXPECT_DOUBLE_EQ(a.gap_to_s, 140.0);
    }
  }
  const double step = 1e-3;
  // A step outside a gap has no gap span.
  std::vector<double> z = WhiteRecord(1e-3, 30000, 12);
  for (size_t i = 20000; i < z.size(); ++i) z[i] += step;
  for (size_t i = 10000; i < 14000; ++i) z[i] = std::nan("");
  auto outside = ScanStationarity({z}, {White(1e-3)}, kTau0, {.bin_s = 1});
  ASSERT_TRUE(outside.ok());
  ASSERT_EQ(outside->events.size(), 1u);
  EXPECT_NEAR(outside->events[0].time_s, 200.0, 3.0);
  EXPECT_TRUE(std::isnan(outside->events[0].axes[0].gap_from_s));
}

// White noise N with its amplitude multiplied by `factor` from sample
// `from` on.
std::vector<double> WhiteRecordWithLevelChange(double n, int samples, int from, double factor,
                                               uint64_t seed) {
  std::vector<double> y = WhiteRecord(n, samples, seed);
  for (int i = from; i < samples; ++i) y[i] *= factor;
  return y;
}

TEST(NoiseLevelTest, FalseAlarmsAtTheLevelWhateverTheNoise) {
  // GIVEN 400 stationary records of each of three noises (white; white
  // rounded to a coarse LSB; white plus a 0.2 s Gauss-Markov and a rate
  // random walk), 300 bins of 1 s; WHEN their noise level is scanned at
  // 5 %; THEN the alarm fraction is the level within three Monte Carlo
  // standard errors (the null drawn for the record's bin count; over 2000
  // records of white noise 4.7 %, of independent Gaussian x 4.5 %).
  constexpr int kRecords = 400;
  constexpr double kLevel = 0.05;
  for (int noise = 0; noise < 3; ++noise) {
    int alarms = 0;
    for (int seed = 0; seed < kRecords; ++seed) {
      const uint64_t record_seed = 900 + 1000 * noise + seed;
      std::vector<double> y =
          noise == 1 ? WhiteRecord(1e-3, 30000, record_seed)
                     : WhiteAndRandomWalkRecord(1e-3, noise ? 2e-5 : 0, 30000, record_seed);
      if (noise == 1) {
        for (double& v : y) v = 4e-3 * std::round(v / 4e-3);  // ~0.4 sd LSB
      }
      if (noise == 2) {
        std::mt19937_64 rng(record_seed + 7);
        std::normal_distribution<double> g;
        const double phi = std::exp(-kTau0 / 0.2);
        double gm = 0;
        for (double& v : y) {
          gm = phi * gm + 2e-3 * std::sqrt(1 - phi * phi) * g(rng);
          v += gm;
        }
      }
      auto scan = ScanNoiseLevel(BinMeanSquareDifferences(y, 100, 300), 1.0, kLevel, 0);
      ASSERT_TRUE(scan.ok()) << scan.status().message();
      ASSERT_TRUE(scan->scanned) << scan->note;
      alarms += scan->significant ? 1 : 0;
    }
    const double se = std::sqrt(kLevel * (1 - kLevel) * kRecords);
    std::printf("noise %d: %d of %d records alarm at a %g level\n", noise, alarms, kRecords,
                kLevel);
    EXPECT_NEAR(alarms, kLevel * kRecords, 3 * se) << noise;
  }
}

TEST(NoiseLevelTest, AFrozenOutputIsTheLargestChange) {
  // GIVEN a white record whose output freezes (one value repeated) for its
  // last 60 s of 300: those bins' successive samples never differ; THEN the
  // change is found there, its ratio under a hundredth, and the note says
  // how the frozen bins were read.
  std::vector<double> y = WhiteRecord(1e-3, 30000, 41);
  for (size_t i = 24000; i < y.size(); ++i) y[i] = y[23999];
  auto scan = ScanNoiseLevel(BinMeanSquareDifferences(y, 100, 300), 1.0, 0.01, 0.05);
  ASSERT_TRUE(scan.ok());
  ASSERT_TRUE(scan->scanned) << scan->note;
  EXPECT_TRUE(scan->found());
  EXPECT_NEAR(scan->time_s, 240, 1.5);
  EXPECT_LT(scan->ratio, 0.01);
  EXPECT_NE(scan->note.find("frozen"), std::string::npos) << scan->note;
}

TEST(NoiseLevelTest, FindsALevelChangeWithItsSizeAndTime) {
  // GIVEN a white record whose amplitude rises 10 % at 180 s of 300
  auto y = WhiteRecordWithLevelChange(1e-3, 30000, 18000, 1.10, 21);
  auto scan = ScanNoiseLevel(BinMeanSquareDifferences(y, 100, 300), 1.0, 0.01, 0.05);
  ASSERT_TRUE(scan.ok());
  EXPECT_TRUE(scan->found());
  EXPECT_NEAR(scan->time_s, 180, 10);
  EXPECT_NEAR(scan->ratio, 1.10, 3 * scan->ratio_sigma);
  EXPECT_LT(scan->ratio_sigma, 0.015);
  // ... a 2 % rise is significant on this record but within a 5 % tolerance
  auto small = WhiteRecordWithLevelChange(1e-3, 300000, 150000, 1.02, 22);
  auto within = ScanNoiseLevel(BinMeanSquareDifferences(small, 1000, 300), 10.0, 0.01, 0.05);
  ASSERT_TRUE(within.ok());
  EXPECT_TRUE(within->significant) << within->p;
  EXPECT_FALSE(within->found()) << within->ratio;
  // ... and a record too short is not scanned, bad arguments are named
  auto short_scan = ScanNoiseLevel(BinMeanSquareDifferences(y, 1000, 30), 10.0, 0.01, 0.05);
  ASSERT_TRUE(short_scan.ok());
  EXPECT_FALSE(short_scan->scanned);
  EXPECT_NE(short_scan->note.find("too few bins"), std::string::npos);
  EXPECT_FALSE(ScanNoiseLevel(BinMeanSquareDifferences(y, 100, 300), 1.0, 0.7, 0.05).ok());
  EXPECT_FALSE(ScanNoiseLevel(BinMeanSquareDifferences(y, 100, 300), 1.0, 0.01, -1).ok());
}

TEST(StationarityTest, TwoEventsInAnotherAxisGapLeaveThatAxisWithoutAnEstimate) {
  // GIVEN two white axes scanned together, A missing 100..140 s, B with two
  // steps of 5e-3 at 110 and 125 s (both inside A's gap): on A both events'
  // regressors are the one difference across the gap, so the second is not
  // identifiable there. THEN both steps are named on B only, A's estimate
  // of the second is NaN (not a number from a singular fit) and A's of the
  // first is within 4 sigma of 0.
  std::vector<double> a = WhiteRecord(1e-3, 30000, 31);
  std::vector<double> b = WhiteRecord(1e-3, 30000, 32);
  for (size_t i = 10000; i < 14000; ++i) a[i] = std::nan("");
  for (size_t i = 11000; i < b.size(); ++i) b[i] += 5e-3;
  for (size_t i = 12500; i < b.size(); ++i) b[i] += 5e-3;
  auto scan = ScanStationarity({a, b}, {White(1e-3), White(1e-3)}, kTau0, {.bin_s = 1});
  ASSERT_TRUE(scan.ok()) << scan.status().message();
  ASSERT_EQ(scan->events.size(), 2u);
  int nan_on_a = 0;
  for (const StationarityEvent& e : scan->events) {
    EXPECT_TRUE(e.axes[1].named);
    EXPECT_FALSE(e.axes[0].named);
    EXPECT_NEAR(e.axes[1].size, 5e-3, 4 * e.axes[1].sigma);
    if (std::isnan(e.axes[0].size)) {
      ++nan_on_a;
    } else {
      EXPECT_LT(std::fabs(e.axes[0].size), 4 * e.axes[0].sigma);
    }
  }
  EXPECT_EQ(nan_on_a, 1);
}

TEST(StationarityTest, BadArgumentsAreNamed) {
  const std::vector<double> y(1000, 0.0);
  EXPECT_FALSE(ScanStationarity({}, {}, kTau0).ok());
  EXPECT_FALSE(ScanStationarity({y}, {}, kTau0).ok());
  EXPECT_FALSE(ScanStationarity({y}, {White(1)}, 0).ok());
  StationarityOptions o;
  o.false_alarm = 0.7;
  auto s = ScanStationarity({y}, {White(1)}, kTau0, o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("false_alarm"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::allan
