#include "analyze/allan/streaming.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {
namespace {

// Same phase, same terms; only the order of the double sums differs
// (8 lanes and blocks vs one running sum): ~1e-16 per addition.
constexpr double kSameTermsRelTol = 1e-12;

// A rate sample stream with optional invalid flags and missing runs.
struct Record {
  std::vector<double> rate;
  std::vector<uint8_t> invalid;  // one per rate sample; 1 = invalid
  // Missing runs: before rate sample `at`, `count` samples never arrived.
  struct Missing {
    size_t at;
    int64_t count;
  };
  std::vector<Missing> missing;
};

// White rate noise of standard deviation `sd` on top of `offset`, plus
// (optionally) a random walk of step `walk` per sample.
std::vector<double> WhitePlusWalk(size_t count, double offset, double sd, double walk,
                                  uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<double> rate(count);
  double w = 0;
  for (size_t i = 0; i < count; ++i) {
    w += walk * gauss(rng);
    rate[i] = offset + sd * gauss(rng) + w;
  }
  return rate;
}

// Flicker-like rate noise: a sum of first-order Gauss-Markov processes with
// corner frequencies two per decade and equal variances (1/f over the band).
std::vector<double> FlickerLike(size_t count, double tau0_s, double level, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double rho = std::sqrt(10.0);
  std::vector<double> phi, drive, state;
  for (double f = 1.0 / (2 * std::numbers::pi * 4 * tau0_s); f > 1e-3 / (count * tau0_s);
       f /= rho) {
    const double p = std::exp(-2 * std::numbers::pi * f * tau0_s);
    phi.push_back(p);
    drive.push_back(level * std::sqrt(1 - p * p));
    state.push_back(level * gauss(rng));
  }
  std::vector<double> rate(count);
  for (size_t i = 0; i < count; ++i) {
    double y = 0;
    for (size_t k = 0; k < phi.size(); ++k) {
      state[k] = phi[k] * state[k] + drive[k] * gauss(rng);
      y += state[k];
    }
    rate[i] = y;
  }
  return rate;
}

// Marks about `fraction` of the samples invalid (flags, NaN or Inf) and adds a
// few missing runs.
Record WithGaps(std::vector<double> rate, double fraction, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Record r;
  r.invalid.assign(rate.size(), 0);
  for (size_t i = 0; i < rate.size(); ++i) {
    const double v = u(rng);
    if (v < fraction / 3) {
      r.invalid[i] = 1;
    } else if (v < 2 * fraction / 3) {
      rate[i] = std::numeric_limits<double>::quiet_NaN();
    } else if (v < fraction) {
      rate[i] = -std::numeric_limits<double>::infinity();
    }
  }
  // A burst of invalid samples and missing runs, one straddling a block.
  for (size_t i = rate.size() / 3; i < rate.size() / 3 + 700; ++i) r.invalid[i] = 1;
  r.missing = {{rate.size() / 5, 3}, {rate.size() / 2, 1000}, {rate.size() / 2 + 17, 1}};
  r.rate = std::move(rate);
  return r;
}

// Feeds `r` in batches whose sizes come from `batch_sizes` (cycled); an empty
// list means one batch.
void Feed(const Record& r, const std::vector<size_t>& batch_sizes, bool as_float,
          StreamingAllan* engine) {
  size_t pos = 0, b = 0;
  size_t next_missing = 0;
  std::vector<float> as_f(r.rate.begin(), r.rate.end());
  while (pos < r.rate.size()) {
    while (next_missing < r.missing.size() && r.missing[next_missing].at == pos) {
      engine->AppendMissing(r.missing[next_missing++].count);
    }
    size_t end = r.rate.size();
    if (!batch_sizes.empty()) end = std::min(end, pos + batch_sizes[b++ % batch_sizes.size()]);
    if (next_missing < r.missing.size()) end = std::min(end, r.missing[next_missing].at);
    const std::span<const uint8_t> flags =
        r.invalid.empty() ? std::span<const uint8_t>()
                          : std::span<const uint8_t>(r.invalid).subspan(pos, end - pos);
    if (as_float) {
      engine->Append(std::span<const float>(as_f).subspan(pos, end - pos), flags);
    } else {
      engine->Append(std::span<const double>(r.rate).subspan(pos, end - pos), flags);
    }
    pos = end;
  }
}

// Expands a record to one rate value and validity per sample (missing samples
// become invalid samples), as the engine sees it.
void Expand(const Record& r, std::vector<double>* rate, std::vector<uint8_t>* invalid) {
  size_t next_missing = 0;
  for (size_t i = 0; i < r.rate.size(); ++i) {
    while (next_missing < r.missing.size() && r.missing[next_missing].at == i) {
      rate->insert(rate->end(), r.missing[next_missing].count, 0.0);
      invalid->insert(invalid->end(), r.missing[next_missing].count, 1);
      ++next_missing;
    }
    const bool bad = (!r.invalid.empty() && r.invalid[i] != 0) || !std::isfinite(r.rate[i]);
    rate->push_back(bad ? 0.0 : r.rate[i]);
    invalid->push_back(bad ? 1 : 0);
  }
}

// The engine's stride for m: 1 below 2C, else 2^j with m = c 2^j, c in [C, 2C).
int64_t EngineStride(int64_t m, int density) {
  int64_t stride = 1;
  while (m / stride >= 2 * density) stride *= 2;
  return stride;
}

// Direct strided OAVAR from a phase built here with the engine's reference:
//   u_{k+1} = u_k + (y_k - yref) for valid y_k (unchanged otherwise),
//   G_k = invalid samples before k; term i (i = 0, s, 2s, ..) valid iff
//   G_{i+2m} = G_i; AVAR = sum (u_{i+2m} - 2u_{i+m} + u_i)^2 / (2 m^2 n).
CurvePoint DirectStrided(const std::vector<double>& rate, const std::vector<uint8_t>& invalid,
                         double yref, int64_t m, int64_t stride) {
  const size_t n_phase = rate.size() + 1;
  std::vector<double> u(n_phase, 0.0);
  std::vector<int64_t> g(n_phase, 0);
  for (size_t k = 0; k < rate.size(); ++k) {
    u[k + 1] = u[k] + (invalid[k] ? 0.0 : rate[k] - yref);
    g[k + 1] = g[k] + (invalid[k] ? 1 : 0);
  }
  double sum = 0;
  int64_t n = 0;
  for (int64_t i = 0; i + 2 * m <= static_cast<int64_t>(n_phase) - 1; i += stride) {
    if (g[i + 2 * m] != g[i]) continue;
    const double d = u[i + 2 * m] - 2 * u[i + m] + u[i];
    sum += d * d;
    ++n;
  }
  CurvePoint p;
  p.m = m;
  p.n = n;
  p.dev = std::sqrt(sum / (2.0 * m * m * n));
  return p;
}

StreamingOptions Options(int density, std::optional<double> reference = std::nullopt) {
  StreamingOptions o;
  o.tau0_s = 0.01;
  o.density = density;
  o.reference_rate = reference;
  return o;
}

TEST(StreamingOptionsTest, ValidateNamesTheField) {
  StreamingOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.tau0_s = 0;
  EXPECT_NE(o.Validate().message().find("tau0_s"), std::string::npos);
  o = {};
  o.density = 12;
  EXPECT_NE(o.Validate().message().find("density"), std::string::npos);
  o.density = 128;
  EXPECT_NE(o.Validate().message().find("density"), std::string::npos);
  o = {};
  o.max_m = 0;
  EXPECT_NE(o.Validate().message().find("max_m"), std::string::npos);
  o = {};
  o.reference_rate = std::numeric_limits<double>::infinity();
  EXPECT_NE(o.Validate().message().find("reference_rate"), std::string::npos);
}

// GIVEN one record with invalid, NaN, Inf and missing samples
// WHEN it arrives in one batch, or in random batch sizes (float or double)
// THEN every output double is bit-identical.
TEST(StreamingAllanTest, BatchBoundariesDoNotChangeOutput) {
  const Record r = WithGaps(WhitePlusWalk(200000, 3.5, 0.1, 1e-4, 11), 0.001, 12);
  for (int density : {1, 8, 16}) {
    for (bool as_float : {false, true}) {
      StreamingAllan whole(Options(density));
      Feed(r, {}, as_float, &whole);
      std::mt19937_64 rng(13);
      std::vector<size_t> sizes;
      for (int i = 0; i < 1000; ++i) sizes.push_back(1 + rng() % (i % 3 == 0 ? 5 : 700));
      StreamingAllan batched(Options(density));
      Feed(r, sizes, as_float, &batched);
      // Querying mid-stream must not disturb the state.
      StreamingAllan queried(Options(density));
      Feed(r, {1, 63, 64, 65, 4096, 257}, as_float, &queried);
      (void)queried.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kChi2);

      ASSERT_EQ(whole.samples(), batched.samples());
      ASSERT_EQ(whole.invalid_samples(), batched.invalid_samples());
      for (CiMethod ci : {CiMethod::kNone, CiMethod::kChi2}) {
        const Curve a = whole.Oadev(StreamGrid::kDense, StopRule::kNone, ci);
        const Curve b = batched.Oadev(StreamGrid::kDense, StopRule::kNone, ci);
        const Curve c = queried.Oadev(StreamGrid::kDense, StopRule::kNone, ci);
        ASSERT_EQ(a.points.size(), b.points.size());
        ASSERT_EQ(a.points.size(), c.points.size());
        ASSERT_GT(a.points.size(), 10u);
        for (size_t i = 0; i < a.points.size(); ++i) {
          EXPECT_EQ(a.points[i].m, b.points[i].m);
          EXPECT_EQ(a.points[i].n, b.points[i].n);
          EXPECT_EQ(a.points[i].dev, b.points[i].dev) << "m " << a.points[i].m;
          EXPECT_EQ(a.points[i].dev, c.points[i].dev) << "m " << a.points[i].m;
          if (ci == CiMethod::kChi2) {
            EXPECT_EQ(a.points[i].edf, b.points[i].edf);
            EXPECT_EQ(a.points[i].lo, b.points[i].lo);
            EXPECT_EQ(a.points[i].hi, b.points[i].hi);
          }
        }
      }
    }
  }
}

// GIVEN gap-free and gappy records
// WHEN the engine runs with a known reference rate
// THEN each tracked m equals the direct strided sum with the engine's stride
//      (same phase, same terms, same n).
TEST(StreamingAllanTest, EqualsDirectStridedSumWithSameReference) {
  const double yref = 3.5;
  const Record clean{WhitePlusWalk(150000, yref + 0.01, 0.2, 3e-4, 21), {}, {}};
  const Record gappy = WithGaps(clean.rate, 0.002, 22);
  for (const Record* r : {&clean, &gappy}) {
    for (int density : {1, 4, 8}) {
      StreamingAllan engine(Options(density, yref));
      Feed(*r, {997}, /*as_float=*/false, &engine);
      std::vector<double> rate;
      std::vector<uint8_t> invalid;
      Expand(*r, &rate, &invalid);
      ASSERT_EQ(engine.samples(), static_cast<int64_t>(rate.size()));
      ASSERT_EQ(engine.invalid_samples(), std::count(invalid.begin(), invalid.end(), 1));
      const Curve curve = engine.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kNone);
      ASSERT_GT(curve.points.size(), 10u);
      EXPECT_EQ(curve.invalid_rate_samples, engine.invalid_samples());
      for (const CurvePoint& p : curve.points) {
        const CurvePoint want = DirectStrided(rate, invalid, yref, p.m, EngineStride(p.m, density));
        EXPECT_EQ(p.n, want.n) << "C " << density << " m " << p.m;
        EXPECT_NEAR(p.dev, want.dev, kSameTermsRelTol * want.dev)
            << "C " << density << " m " << p.m;
      }
    }
  }
}

// The same check against the batch library's strided estimator. PhaseFromRate
// removes the mean of the valid samples; the engine is given that mean.
TEST(StreamingAllanTest, EqualsOverlappingAllanStridedOfBatchLibrary) {
  const Record clean{WhitePlusWalk(100000, -1.25, 0.05, 0.0, 31), {}, {}};
  const Record gappy = WithGaps(clean.rate, 0.001, 32);
  for (const Record* r : {&clean, &gappy}) {
    std::vector<double> rate;
    std::vector<uint8_t> invalid;
    Expand(*r, &rate, &invalid);
    double sum = 0;
    int64_t valid = 0;
    for (size_t i = 0; i < rate.size(); ++i) {
      if (!invalid[i]) {
        sum += rate[i];
        ++valid;
      }
    }
    const int density = 8;
    StreamingAllan engine(Options(density, sum / valid));
    Feed(*r, {333}, false, &engine);
    const PhaseRecord phase = PhaseFromRate(rate, 0.01, invalid);
    const Curve curve = engine.Oadev(StreamGrid::kDense, StopRule::kBins9, CiMethod::kNone);
    ASSERT_GT(curve.points.size(), 50u);
    for (const CurvePoint& p : curve.points) {
      const CurvePoint want = OverlappingAllanStrided(phase, p.m, EngineStride(p.m, density));
      EXPECT_EQ(p.n, want.n) << "m " << p.m;
      EXPECT_NEAR(p.dev, want.dev, kSameTermsRelTol * want.dev) << "m " << p.m;
      EXPECT_DOUBLE_EQ(p.tau_s, want.tau_s);
    }
  }
}

// With C = 1 the octave grid runs at stride m: the non-overlapped ADEV.
TEST(StreamingAllanTest, DensityOneOctaveIsNonOverlappedAdev) {
  const Record r{WhitePlusWalk(50000, 0.0, 1.0, 1e-3, 41), {}, {}};
  StreamingAllan engine(Options(1, 0.0));
  Feed(r, {}, false, &engine);
  const PhaseRecord phase = PhaseFromRate(r.rate, 0.01);
  for (const CurvePoint& p :
       engine.Oadev(StreamGrid::kOctave, StopRule::kBins9, CiMethod::kNone).points) {
    const CurvePoint want = ComputeDeviationAt(phase, Deviation::kAdev, p.m);
    EXPECT_EQ(p.n, want.n) << "m " << p.m;
    EXPECT_NEAR(p.dev, want.dev, kSameTermsRelTol * want.dev) << "m " << p.m;
  }
}

// GIVEN the default reference (mean of the first 64 valid samples)
// THEN the output equals that of an engine told the same mean explicitly,
//      including when the curve is read before 64 valid samples have arrived.
TEST(StreamingAllanTest, DefaultReferenceIsMeanOfFirst64ValidSamples) {
  Record r = WithGaps(WhitePlusWalk(30000, 7.0, 0.3, 0.0, 51), 0.0, 52);
  r.invalid[0] = r.invalid[5] = 1;
  r.rate[9] = std::numeric_limits<double>::quiet_NaN();
  r.missing.push_back({0, 4});
  std::sort(r.missing.begin(), r.missing.end(),
            [](const Record::Missing& a, const Record::Missing& b) { return a.at < b.at; });
  // The mean the engine should use: the first 64 valid samples, in order.
  double sum = 0;
  int used = 0;
  for (size_t i = 0; i < r.rate.size() && used < 64; ++i) {
    if (r.invalid[i] == 0 && std::isfinite(r.rate[i])) {
      sum += r.rate[i];
      ++used;
    }
  }
  StreamingAllan by_default(Options(8));
  StreamingAllan explicit_ref(Options(8, sum / 64));
  Feed(r, {10, 1, 50}, false, &by_default);
  Feed(r, {}, false, &explicit_ref);
  ASSERT_TRUE(by_default.reference_rate().has_value());
  EXPECT_EQ(*by_default.reference_rate(), sum / 64);
  const Curve a = by_default.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kNone);
  const Curve b = explicit_ref.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kNone);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].dev, b.points[i].dev);
    EXPECT_EQ(a.points[i].n, b.points[i].n);
  }

  // Only 40 samples (37 valid): the reference is their mean.
  const std::vector<double> few(r.rate.begin() + 10, r.rate.begin() + 50);
  double few_sum = 0;
  for (double y : few) few_sum += y;
  StreamingAllan early(Options(1));
  early.Append(few);
  EXPECT_FALSE(early.reference_rate().has_value());
  StreamingAllan early_explicit(Options(1, few_sum / few.size()));
  early_explicit.Append(few);
  const Curve c = early.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kNone);
  const Curve d = early_explicit.Oadev(StreamGrid::kDense, StopRule::kNone, CiMethod::kNone);
  ASSERT_EQ(c.points.size(), d.points.size());
  ASSERT_FALSE(c.points.empty());
  for (size_t i = 0; i < c.points.size(); ++i) EXPECT_EQ(c.points[i].dev, d.points[i].dev);
}

// A rate of exactly 0 is a valid sample, not a gap marker.
TEST(StreamingAllanTest, ZeroRateIsValid) {
  std::vector<double> rate = WhitePlusWalk(5000, 0.0, 1.0, 0.0, 61);
  for (size_t i = 0; i < rate.size(); i += 7) rate[i] = 0.0;
  StreamingAllan engine(Options(8, 0.0));
  engine.Append(rate);
  EXPECT_EQ(engine.invalid_samples(), 0);
  const Curve curve = engine.Oadev(StreamGrid::kOctave, StopRule::kNone, CiMethod::kNone);
  ASSERT_FALSE(curve.points.empty());
  EXPECT_EQ(curve.points[0].m, 1);
  EXPECT_EQ(curve.points[0].n, static_cast<int64_t>(rate.size()) - 1);
}

// GIVEN a long record  THEN the state does not grow and stays within 64 KiB
// (C = 8, max_m = 2^30: 28 levels).
TEST(StreamingAllanTest, StateIsBoundedWhateverTheRecordLength) {
  StreamingAllan engine(Options(8, 0.0));
  const size_t start = engine.StateBytes();
  EXPECT_LE(start, 64u * 1024u);
  const std::vector<double> chunk = WhitePlusWalk(1 << 20, 0.0, 1.0, 0.0, 71);
  for (int i = 0; i < 8; ++i) engine.Append(chunk);
  engine.AppendMissing(12345);
  EXPECT_EQ(engine.StateBytes(), start);
  StreamingOptions dense = Options(64, 0.0);
  EXPECT_LE(StreamingAllan(dense).StateBytes(), 256u * 1024u);
}

// Octave points sit on the tracked grid; the dense grid has C points per
// octave beyond 2C; kBins9 stops at floor(M/9).
TEST(StreamingAllanTest, GridsAndStopRules) {
  StreamingAllan engine(Options(8, 0.0));
  engine.Append(WhitePlusWalk(100000, 0.0, 1.0, 0.0, 81));
  const Curve octave = engine.Oadev(StreamGrid::kOctave, StopRule::kBins9, CiMethod::kNone);
  const Curve dense = engine.Oadev(StreamGrid::kDense, StopRule::kBins9, CiMethod::kNone);
  ASSERT_FALSE(octave.points.empty());
  for (size_t i = 0; i < octave.points.size(); ++i) {
    EXPECT_EQ(octave.points[i].m, int64_t{1} << i);
  }
  EXPECT_EQ(octave.points.back().m, 8192);  // 2^13 <= 100000/9 = 11111 < 2^14
  EXPECT_EQ(dense.points[14].m, 15);
  EXPECT_EQ(dense.points[15].m, 16);
  EXPECT_EQ(dense.points[16].m, 18);
  EXPECT_EQ(dense.points[23].m, 32);
  EXPECT_LE(dense.points.back().m, 100000 / 9);
  EXPECT_EQ(octave.n_phase, 100001);
  EXPECT_DOUBLE_EQ(octave.points[3].tau_s, 0.08);
  const Curve all = engine.Oadev(StreamGrid::kOctave, StopRule::kNone, CiMethod::kNone);
  EXPECT_GT(all.points.back().m, 8192);
}

// Simple CI: K = floor(valid samples/m) clusters, edf = K - 1.
TEST(StreamingAllanTest, SimpleConfidence) {
  StreamingAllan engine(Options(8, 0.0));
  engine.Append(WhitePlusWalk(10000, 0.0, 1.0, 0.0, 91));
  engine.AppendMissing(100);
  const Curve curve = engine.Oadev(StreamGrid::kOctave, StopRule::kBins9, CiMethod::kSimple);
  for (const CurvePoint& p : curve.points) {
    const int64_t k = 10000 / p.m;
    EXPECT_EQ(p.edf, static_cast<double>(k - 1));
    const double f = 1 / std::sqrt(2.0 * (k - 1));
    EXPECT_NEAR(p.lo, p.dev * (1 - f), 1e-15 * p.dev);
    EXPECT_NEAR(p.hi, p.dev * (1 + f), 1e-15 * p.dev);
  }
}

struct NoiseCase {
  const char* name;
  int alpha;  // its power-law exponent, for the exact curve's interval
  std::vector<double> rate;
};

// GIVEN long seeded records of white, random-walk and flicker-like rate noise
// WHEN the engine (C = 8) and the exact full-overlap estimator both run
// THEN every octave point of the stream lies inside the exact curve's 1-sigma
//      chi-square interval (Greenhall edf for the known alpha), and the engine's
//      own chi2 interval identifies that alpha in the mid range.
TEST(StreamingAllanTest, WithinOneSigmaOfExactFullOverlapCurve) {
  const size_t count = size_t{1} << 21;
  std::vector<NoiseCase> cases;
  cases.push_back({"white", 0, WhitePlusWalk(count, 2.0, 1.0, 0.0, 101)});
  cases.push_back({"random_walk", -2, WhitePlusWalk(count, 0.0, 0.0, 1e-3, 102)});
  cases.push_back({"flicker", -1, FlickerLike(count, 0.01, 1.0, 103)});
  for (const NoiseCase& c : cases) {
    StreamingAllan engine(Options(8));
    engine.Append(c.rate);
    const Curve stream = engine.Oadev(StreamGrid::kOctave, StopRule::kBins9, CiMethod::kChi2);
    const PhaseRecord phase = PhaseFromRate(c.rate, 0.01);
    std::vector<int64_t> m_list;
    for (const CurvePoint& p : stream.points) m_list.push_back(p.m);
    const Curve exact = ComputeDeviation(phase, Deviation::kOadev, m_list);
    ASSERT_EQ(exact.points.size(), stream.points.size());
    ASSERT_GE(stream.points.size(), 17u);
    for (size_t i = 0; i < stream.points.size(); ++i) {
      const CurvePoint& s = stream.points[i];
      const CurvePoint& e = exact.points[i];
      const std::optional<double> edf =
          GreenhallEdf(c.alpha, 2, e.m, exact.n_phase, static_cast<double>(e.m), e.m);
      ASSERT_TRUE(edf.has_value());
      const auto [lo, hi] = Chi2Interval(e.dev, *edf, kOneSigmaConfidence);
      EXPECT_GE(s.dev, lo) << c.name << " m " << s.m;
      EXPECT_LE(s.dev, hi) << c.name << " m " << s.m;
      // The stream's own interval brackets its estimate.
      if (s.alpha.has_value()) {
        EXPECT_LT(s.lo, s.dev);
        EXPECT_GT(s.hi, s.dev);
      }
    }
    // The local-slope alpha is the true one away from the ends (m = 64..4096).
    for (const CurvePoint& s : stream.points) {
      if (s.m >= 64 && s.m <= 4096) {
        ASSERT_TRUE(s.alpha.has_value()) << c.name;
        EXPECT_EQ(*s.alpha, c.alpha) << c.name << " m " << s.m;
      }
    }
  }
}

// GIVEN a gappy record with a mark after every sample
// WHEN the curve of a stretch is taken between two marks
// THEN it has exactly the terms of an engine fed that stretch alone (same m,
//      same n, the same deviation to rounding: the same reference rate);
//      with marks every 256 samples it has a subset of them, none reaching
//      outside the stretch, and the whole record's stretch is the record's
//      curve.
TEST(StreamingAllanTest, SegmentBetweenMarksHasTheStretchsOwnTerms) {
  const Record r = WithGaps(WhitePlusWalk(6000, 1.5, 0.1, 1e-3, 21), 0.002, 22);
  std::vector<double> rate;
  std::vector<uint8_t> invalid;
  Expand(r, &rate, &invalid);
  StreamingAllan engine(Options(8, 1.5));
  std::vector<StreamMark> marks{engine.Mark()};
  for (size_t i = 0; i < rate.size(); ++i) {
    engine.Append(std::span<const double>(&rate[i], 1), std::span<const uint8_t>(&invalid[i], 1));
    marks.push_back(engine.Mark());
  }
  // At a multiple of the largest stride used, so the engine's strided terms
  // fall at the same places in the stretch as in an engine fed it alone.
  const size_t from = 1024, to = 5120;
  StreamingAllan alone(Options(8, 1.5));
  alone.Append(std::span<const double>(rate).subspan(from, to - from),
               std::span<const uint8_t>(invalid).subspan(from, to - from));
  for (CiMethod ci : {CiMethod::kNone, CiMethod::kChi2}) {
    const Curve want = alone.Oadev(StreamGrid::kDense, StopRule::kBins9, ci);
    const Curve got =
        engine.SegmentOadev(marks, from, to, StreamGrid::kDense, StopRule::kBins9, ci);
    ASSERT_GT(want.points.size(), 20u);
    ASSERT_EQ(got.points.size(), want.points.size());
    EXPECT_EQ(got.n_phase, want.n_phase);
    EXPECT_EQ(got.invalid_rate_samples, want.invalid_rate_samples);
    for (size_t i = 0; i < want.points.size(); ++i) {
      EXPECT_EQ(got.points[i].m, want.points[i].m);
      EXPECT_EQ(got.points[i].n, want.points[i].n) << "m " << want.points[i].m;
      EXPECT_NEAR(got.points[i].dev, want.points[i].dev, 1e-9 * want.points[i].dev);
      if (ci == CiMethod::kChi2) {
        EXPECT_NEAR(got.points[i].edf, want.points[i].edf, 1e-6);
      }
    }
  }
  // Marks every 256 samples: fewer terms, and the deviation within its own
  // spread of the stretch's.
  std::vector<StreamMark> coarse;
  for (size_t k = 0; k < marks.size(); k += 256) coarse.push_back(marks[k]);
  const Curve want = alone.Oadev(StreamGrid::kDense, StopRule::kBins9, CiMethod::kNone);
  const Curve got = engine.SegmentOadev(coarse, from / 256, to / 256, StreamGrid::kDense,
                                        StopRule::kBins9, CiMethod::kNone);
  ASSERT_FALSE(got.points.empty());
  for (const CurvePoint& p : got.points) {
    const auto w = std::find_if(want.points.begin(), want.points.end(),
                                [&](const CurvePoint& q) { return q.m == p.m; });
    ASSERT_NE(w, want.points.end()) << p.m;
    EXPECT_LE(p.n, w->n) << p.m;
    EXPECT_GE(p.n, w->n - 256 / p.stride - 1) << p.m;
    EXPECT_NEAR(p.dev, w->dev, 3 * w->dev / std::sqrt(static_cast<double>(p.n))) << p.m;
  }
  // The whole record between its first and last marks is the record.
  const Curve all = engine.Oadev(StreamGrid::kDense, StopRule::kBins9, CiMethod::kChi2);
  const Curve whole = engine.SegmentOadev(marks, 0, marks.size() - 1, StreamGrid::kDense,
                                          StopRule::kBins9, CiMethod::kChi2);
  ASSERT_EQ(whole.points.size(), all.points.size());
  for (size_t i = 0; i < all.points.size(); ++i) {
    EXPECT_EQ(whole.points[i].n, all.points[i].n);
    EXPECT_NEAR(whole.points[i].dev, all.points[i].dev, 1e-12 * all.points[i].dev);
  }
}

// A single point (or none) gives no chi2 interval rather than a guess.
TEST(StreamingAllanTest, NoChi2IntervalWithoutASlope) {
  StreamingOptions o = Options(1, 0.0);
  o.max_m = 1;
  StreamingAllan engine(o);
  engine.Append(WhitePlusWalk(1000, 0.0, 1.0, 0.0, 111));
  const Curve curve = engine.Oadev(StreamGrid::kDense, StopRule::kBins9, CiMethod::kChi2);
  ASSERT_EQ(curve.points.size(), 1u);
  EXPECT_TRUE(std::isnan(curve.points[0].lo));
  EXPECT_FALSE(curve.points[0].alpha.has_value());
}

}  // namespace
}  // namespace imuqual::allan
