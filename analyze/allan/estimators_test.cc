#include "analyze/allan/estimators.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "analyze/allan/phase.h"
#include "analyze/allan/reference_testing.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

using testing::Dataset;
using testing::ReadCsv;
using testing::ReadDatasets;
using testing::ReferencePath;

// The reference results were cross-checked against an 80-bit re-implementation
// to 3.6e-12 (tests/reference/NOTES.md); 1e-9 leaves room for a different but
// equally valid summation order.
constexpr double kReferenceRelTol = 1e-9;
// Published NBS14 values carry 7 significant digits, and the 10-point phase set
// is itself rounded to 5 decimals.
constexpr double kPublishedRelTol = 1e-6;
// Two double evaluations of the same sums in different order (pooled segments,
// brute force in long double): a few hundred ulps of accumulated rounding.
constexpr double kSameSumRelTol = 1e-12;

constexpr Deviation kAllDeviations[] = {Deviation::kAdev,  Deviation::kOadev, Deviation::kMdev,
                                        Deviation::kTdev,  Deviation::kHdev,  Deviation::kOhdev,
                                        Deviation::kTotdev};

// The long-tau reference files (tests/reference/compute_theo_refs.py): octave
// grid only, for these datasets.
constexpr Deviation kLongTauReferenceDeviations[] = {Deviation::kTheo1, Deviation::kMtotdev,
                                                     Deviation::kHtotdev, Deviation::kTtotdev};
const std::set<std::string> kLongTauReferenceDatasets = {"nbs14_1000_freq", "phasedat_phase",
                                                         "white_1e4", "rw_1e4"};
// Result files per dataset: 7 estimators x {octave, decade} + oadev 'all'.
constexpr int kClassicResultFiles = 8 * 15;
constexpr int kLongTauResultFiles = 4 * 4;

double RelativeError(double value, double expected) {
  return std::fabs(value - expected) / std::fabs(expected);
}

// White rate noise plus a random walk, seeded.
std::vector<double> NoisyRate(int64_t count, uint64_t seed, double offset = 0.3) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> rate(static_cast<size_t>(count));
  double walk = 0.0;
  for (double& y : rate) {
    walk += 0.01 * normal(rng);
    y = offset + normal(rng) + walk;
  }
  return rate;
}

// ---------------------------------------------------------------------------
// Brute force: each estimator written straight from its formula, in long
// double, with the validity of every window checked sample by sample against
// the caller's own list of valid rate samples.

struct BruteForcePoint {
  double dev = std::nan("");
  int64_t n = 0;
};

bool WindowValid(const std::vector<bool>& valid_rate, int64_t first, int64_t count) {
  for (int64_t k = first; k < first + count; ++k) {
    if (!valid_rate[k]) return false;
  }
  return true;
}

BruteForcePoint BruteForce(const std::vector<double>& x, const std::vector<bool>& valid_rate,
                           Deviation dev, int64_t m, double tau0) {
  const int64_t n_phase = static_cast<int64_t>(x.size());
  const long double tau = static_cast<long double>(m) * tau0;
  long double sum = 0;
  int64_t n = 0;
  const auto xl = [&](int64_t i) { return static_cast<long double>(x[i]); };
  switch (dev) {
    case Deviation::kAdev:
    case Deviation::kOadev: {
      const int64_t stride = dev == Deviation::kAdev ? m : 1;
      for (int64_t i = 0; i + 2 * m <= n_phase - 1; i += stride) {
        if (!WindowValid(valid_rate, i, 2 * m)) continue;
        const long double d = xl(i + 2 * m) - 2 * xl(i + m) + xl(i);
        sum += d * d;
        ++n;
      }
      if (n == 0) return {};
      return {static_cast<double>(std::sqrt(sum / (2 * n)) / tau), n};
    }
    case Deviation::kHdev:
    case Deviation::kOhdev: {
      const int64_t stride = dev == Deviation::kHdev ? m : 1;
      for (int64_t i = 0; i + 3 * m <= n_phase - 1; i += stride) {
        if (!WindowValid(valid_rate, i, 3 * m)) continue;
        const long double d = xl(i + 3 * m) - 3 * xl(i + 2 * m) + 3 * xl(i + m) - xl(i);
        sum += d * d;
        ++n;
      }
      if (n == 0) return {};
      return {static_cast<double>(std::sqrt(sum / (6 * n)) / tau), n};
    }
    case Deviation::kMdev:
    case Deviation::kTdev: {
      for (int64_t j = 0; j <= n_phase - 3 * m; ++j) {
        if (!WindowValid(valid_rate, j, 3 * m - 1)) continue;
        long double s = 0;
        for (int64_t i = j; i < j + m; ++i) s += xl(i + 2 * m) - 2 * xl(i + m) + xl(i);
        sum += s * s;
        ++n;
      }
      if (n == 0) return {};
      const long double mdev = std::sqrt(sum / (2 * n)) / (m * tau);
      return {static_cast<double>(dev == Deviation::kMdev ? mdev : mdev * tau / std::sqrt(3.0L)),
              n};
    }
    case Deviation::kTotdev: {
      // Longest gap-free span, then the doubly reflected record built in full.
      int64_t best_begin = 0, best_size = 0, begin = 0;
      for (int64_t k = 0; k <= n_phase - 1; ++k) {
        if (k == n_phase - 1 || !valid_rate[k]) {
          if (k + 1 - begin > best_size) best_begin = begin, best_size = k + 1 - begin;
          begin = k + 1;
        }
      }
      const int64_t length = best_size;
      if (length < 3 || m > length - 1) return {};
      std::vector<long double> extended(3 * length - 4);
      const int64_t offset = length - 2;  // extended[j + offset] = x*_j
      for (int64_t j = -(length - 2); j <= 2 * length - 3; ++j) {
        long double value;
        if (j < 0) {
          value = 2 * xl(best_begin) - xl(best_begin - j);
        } else if (j > length - 1) {
          value = 2 * xl(best_begin + length - 1) - xl(best_begin + 2 * (length - 1) - j);
        } else {
          value = xl(best_begin + j);
        }
        extended[j + offset] = value;
      }
      for (int64_t i = 1; i <= length - 2; ++i) {
        const long double d =
            extended[i - m + offset] - 2 * extended[i + offset] + extended[i + m + offset];
        sum += d * d;
      }
      n = length - 2;
      return {static_cast<double>(std::sqrt(sum / (2 * n)) / tau), n};
    }
    default:  // the long-tau estimators have their own brute force (long_tau_test.cc)
      break;
  }
  return {};
}

// ---------------------------------------------------------------------------
// Reference results (allantools) for every dataset, estimator and grid.

TEST(ReferenceResults, EveryResultFileIsReproducedExactly) {
  const std::vector<Dataset> datasets = ReadDatasets();
  ASSERT_EQ(datasets.size(), 8u) << "datasets.json unreadable or changed";
  int files_compared = 0;
  std::map<Deviation, double> worst_rel_error;
  for (const Dataset& dataset : datasets) {
    SCOPED_TRACE(dataset.name);
    const PhaseRecord phase = testing::LoadDataset(dataset);
    ASSERT_GT(phase.size(), 0);
    std::set<std::string> expected_files;
    std::vector<std::pair<Deviation, std::string>> files;  // (estimator, grid)
    for (Deviation dev : kAllDeviations) {
      files.emplace_back(dev, "octave");
      files.emplace_back(dev, "decade");
      if (dev == Deviation::kOadev && dataset.all_taus) files.emplace_back(dev, "all");
    }
    if (kLongTauReferenceDatasets.count(dataset.name)) {
      for (Deviation dev : kLongTauReferenceDeviations) files.emplace_back(dev, "octave");
    }
    for (const auto& [dev, grid_name] : files) {
      {
        const std::string file =
            dataset.name + "_" + std::string(DeviationName(dev)) + "_" + grid_name + ".csv";
        SCOPED_TRACE(file);
        expected_files.insert(file);
        const testing::CsvTable table =
            ReadCsv(ReferencePath("results/" + dataset.name + "/" + file));
        ASSERT_TRUE(table.ok);
        const int tau_col = table.Column("tau");
        const int n_col = table.Column("n");
        const int dev_col = table.Column("dev");
        ASSERT_GE(std::min({tau_col, n_col, dev_col}), 0);

        const Result<TauGridSpec> grid = ParseTauGrid(grid_name);
        ASSERT_TRUE(grid.ok());
        const std::vector<int64_t> m_list =
            AveragingFactors(*grid, phase.tau0_s, phase.size(), dev, StopRule::kNone);
        const Curve curve = ComputeDeviation(phase, dev, m_list);
        ASSERT_EQ(curve.points.size(), table.rows.size());
        for (size_t row = 0; row < table.rows.size(); ++row) {
          const CurvePoint& point = curve.points[row];
          SCOPED_TRACE("tau " + std::to_string(point.tau_s));
          if (dev == Deviation::kTheo1) {
            // The reference labels Theo1 with tau = m tau0; this library
            // reports the effective tau 0.75 m tau0 (long_tau.h).
            EXPECT_EQ(static_cast<double>(point.m) * phase.tau0_s, table.rows[row][tau_col]);
            EXPECT_EQ(point.tau_s, 0.75 * static_cast<double>(point.m) * phase.tau0_s);
          } else {
            EXPECT_EQ(point.tau_s, table.rows[row][tau_col]);
          }
          EXPECT_EQ(point.n, static_cast<int64_t>(table.rows[row][n_col]));
          const double error = RelativeError(point.dev, table.rows[row][dev_col]);
          EXPECT_LE(error, kReferenceRelTol) << point.dev << " vs " << table.rows[row][dev_col];
          worst_rel_error[dev] = std::max(worst_rel_error[dev], error);
        }
        ++files_compared;
      }
    }
    // No result file of this dataset goes unchecked (CI files are checked in
    // confidence_test).
    for (const auto& entry :
         std::filesystem::directory_iterator(ReferencePath("results/" + dataset.name))) {
      const std::string file = entry.path().filename().string();
      if (file.find("_ci_") != std::string::npos) continue;
      EXPECT_TRUE(expected_files.count(file)) << "unchecked reference file " << file;
    }
  }
  EXPECT_EQ(files_compared, kClassicResultFiles + kLongTauResultFiles);
  for (const auto& [dev, error] : worst_rel_error) {
    std::printf("%-8s largest relative difference from the reference %.3g\n",
                std::string(DeviationName(dev)).c_str(), error);
  }
}

TEST(ReferenceResults, EveryResultFolderIsADataset) {
  std::set<std::string> names;
  for (const Dataset& dataset : ReadDatasets()) names.insert(dataset.name);
  int folders = 0;
  for (const auto& entry : std::filesystem::directory_iterator(ReferencePath("results"))) {
    if (!entry.is_directory()) continue;
    EXPECT_TRUE(names.count(entry.path().filename().string()))
        << "results folder without a dataset: " << entry.path().filename();
    ++folders;
  }
  EXPECT_EQ(folders, static_cast<int>(names.size()));
}

TEST(ReferenceResults, RowCountsMatchTheManifest) {
  // results/row_counts.txt: "<dataset> <dev> <grid> <rows>".
  std::ifstream in(ReferencePath("results/row_counts.txt"));
  ASSERT_TRUE(in.good());
  std::string name, dev_name, grid_name;
  int64_t rows = 0;
  int lines = 0;
  const std::vector<Dataset> datasets = ReadDatasets();
  while (in >> name >> dev_name >> grid_name >> rows) {
    SCOPED_TRACE(name + " " + dev_name + " " + grid_name);
    const auto dataset = std::find_if(datasets.begin(), datasets.end(),
                                      [&](const Dataset& d) { return d.name == name; });
    ASSERT_NE(dataset, datasets.end());
    const std::optional<Deviation> dev = ParseDeviation(dev_name);
    ASSERT_TRUE(dev.has_value());
    const Result<TauGridSpec> grid = ParseTauGrid(grid_name);
    ASSERT_TRUE(grid.ok());
    const PhaseRecord phase = testing::LoadDataset(*dataset);
    const Curve curve = ComputeDeviation(
        phase, *dev, AveragingFactors(*grid, phase.tau0_s, phase.size(), *dev, StopRule::kNone));
    EXPECT_EQ(static_cast<int64_t>(curve.points.size()), rows);
    ++lines;
  }
  EXPECT_EQ(lines, kClassicResultFiles + kLongTauResultFiles);
}

// ---------------------------------------------------------------------------
// Published values.

TEST(PublishedValues, Nbs14TablesFromTheReferenceFile) {
  const testing::CsvTable table = ReadCsv(ReferencePath("nbs14_published_ref.csv"));
  ASSERT_TRUE(table.ok);
  // ReadCsv parses every cell as a number; re-read the text columns here.
  std::ifstream in(ReferencePath("nbs14_published_ref.csv"));
  std::string line;
  std::getline(in, line);
  int compared = 0;
  const std::vector<Dataset> datasets = ReadDatasets();
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = testing::SplitCsvLine(line);
    ASSERT_GE(cells.size(), 4u);
    const std::optional<Deviation> dev = ParseDeviation(cells[1]);
    ASSERT_TRUE(dev.has_value()) << line;
    const int64_t m = std::stoll(cells[2]);
    const double published = std::stod(cells[3]);
    // "nbs14_10pt" stands for both the frequency and the phase form.
    for (const Dataset& dataset : datasets) {
      if (dataset.name.rfind(cells[0], 0) != 0) continue;
      SCOPED_TRACE(dataset.name + " " + cells[1] + " m=" + cells[2]);
      const CurvePoint point = ComputeDeviationAt(testing::LoadDataset(dataset), *dev, m);
      EXPECT_LE(RelativeError(point.dev, published), kPublishedRelTol) << point.dev;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 21 + 2 * 14);
}

TEST(PublishedValues, Nbs14TenPointPhaseSet) {
  const std::vector<double> x = {0,        103.11111, 123.22222, 157.33333, 166.44444,
                                 48.55555, -96.33333, -2.22222,  111.88889, 0};
  const PhaseRecord phase = PhaseFromPhase(x, 1.0);
  struct Case {
    Deviation dev;
    int64_t m;
    double expected;
  };
  const Case cases[] = {
      {Deviation::kAdev, 1, 91.22945},  {Deviation::kAdev, 2, 115.8082},
      {Deviation::kOadev, 2, 85.95287}, {Deviation::kMdev, 2, 74.78849},
      {Deviation::kTdev, 1, 52.67135},  {Deviation::kTdev, 2, 86.35831},
      {Deviation::kHdev, 1, 70.80608},  {Deviation::kHdev, 2, 116.7980},
      {Deviation::kOhdev, 2, 85.61487}, {Deviation::kTotdev, 2, 93.90379},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(DeviationName(c.dev)) + " m=" + std::to_string(c.m));
    EXPECT_LE(RelativeError(ComputeDeviationAt(phase, c.dev, c.m).dev, c.expected),
              kPublishedRelTol);
  }
}

TEST(PublishedValues, Nbs14ThousandPointSetBuiltFromItsDefinition) {
  // n_0 = 1234567890, n_{i+1} = 16807 n_i mod (2^31 - 1), y_i = n_i / (2^31 - 1).
  std::vector<double> rate(1000);
  int64_t state = 1234567890;
  for (double& y : rate) {
    y = static_cast<double>(state) / 2147483647.0;
    state = state * 16807 % 2147483647;
  }
  const PhaseRecord phase = PhaseFromRate(rate, 1.0);
  struct Case {
    Deviation dev;
    int64_t m;
    double expected;
  };
  const Case cases[] = {
      {Deviation::kAdev, 1, 2.922319e-1},    {Deviation::kAdev, 10, 9.965736e-2},
      {Deviation::kAdev, 100, 3.897804e-2},  {Deviation::kOadev, 10, 9.159953e-2},
      {Deviation::kOadev, 100, 3.241343e-2}, {Deviation::kMdev, 10, 6.172376e-2},
      {Deviation::kMdev, 100, 2.170921e-2},  {Deviation::kHdev, 1, 2.943883e-1},
      {Deviation::kHdev, 10, 1.052754e-1},   {Deviation::kHdev, 100, 3.910860e-2},
      {Deviation::kOhdev, 10, 9.581083e-2},  {Deviation::kOhdev, 100, 3.237638e-2},
      {Deviation::kTotdev, 10, 9.134743e-2}, {Deviation::kTotdev, 100, 3.406530e-2},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(DeviationName(c.dev)) + " m=" + std::to_string(c.m));
    EXPECT_LE(RelativeError(ComputeDeviationAt(phase, c.dev, c.m).dev, c.expected),
              kPublishedRelTol);
  }
}

TEST(PublishedValues, Stable32TablesForPhaseDat) {
  // Stable32 1.60 prints 5 significant digits: our value must lie within half
  // a unit of the printed value's last digit.
  const std::vector<double> x = testing::ReadColumn(ReferencePath("data/PHASE.DAT"));
  ASSERT_EQ(x.size(), 1001u);
  const PhaseRecord phase = PhaseFromPhase(x, 1.0);
  int rows_compared = 0;
  // Stable32's own arithmetic differs from ours by ~1e-8 relative: one TDEV
  // value (0.7883550132, printed 7.8835e-01) sits just past the rounding edge.
  constexpr double kStable32ArithmeticRelTol = 1e-7;
  for (Deviation dev : kAllDeviations) {
    for (const std::string suffix : {"", "_octave"}) {
      const std::string file =
          "stable32_ref/phase_dat_" + std::string(DeviationName(dev)) + suffix + ".txt";
      SCOPED_TRACE(file);
      const std::vector<testing::Stable32Row> rows =
          testing::ReadStable32Table(ReferencePath(file));
      ASSERT_GE(rows.size(), 8u);
      std::vector<int64_t> m_list;
      for (const testing::Stable32Row& row : rows) m_list.push_back(row.af);
      const Curve curve = ComputeDeviation(phase, dev, m_list);
      ASSERT_EQ(curve.points.size(), rows.size());
      for (size_t k = 0; k < rows.size(); ++k) {
        SCOPED_TRACE("AF " + std::to_string(rows[k].af));
        EXPECT_EQ(curve.points[k].tau_s, rows[k].tau_s);
        EXPECT_EQ(curve.points[k].n, rows[k].n);
        EXPECT_LE(std::fabs(curve.points[k].dev - rows[k].sigma),
                  testing::HalfUnitInLastPlace(rows[k].sigma_text) +
                      kStable32ArithmeticRelTol * rows[k].sigma)
            << curve.points[k].dev << " printed " << rows[k].sigma_text;
        ++rows_compared;
      }
    }
  }
  EXPECT_GT(rows_compared, 900);
}

// ---------------------------------------------------------------------------
// Agreement with the brute-force formulas, with and without gaps.

TEST(Estimators, MatchBruteForceOnGapFreeRecords) {
  const std::vector<double> rate = NoisyRate(600, 11);
  const PhaseRecord phase = PhaseFromRate(rate, 0.5);
  const std::vector<bool> valid(rate.size(), true);
  for (Deviation dev : kAllDeviations) {
    for (int64_t m = 1; m < phase.size(); m += (m < 20 ? 1 : 37)) {
      SCOPED_TRACE(std::string(DeviationName(dev)) + " m=" + std::to_string(m));
      const BruteForcePoint expected = BruteForce(phase.x, valid, dev, m, 0.5);
      const CurvePoint point = ComputeDeviationAt(phase, dev, m);
      EXPECT_EQ(point.n, expected.n);
      if (expected.n > 0) {
        EXPECT_LE(RelativeError(point.dev, expected.dev), kSameSumRelTol);
        EXPECT_EQ(point.tau_s, m * 0.5);
      }
    }
  }
}

TEST(Estimators, MatchBruteForceWithGapsSkippingEveryTermThatTouchesOne) {
  // GIVEN a record with isolated NaNs, flagged samples, a run of gaps and
  // exact zeros (which are valid rates).
  std::vector<double> rate = NoisyRate(3000, 12);
  std::vector<uint8_t> flags(rate.size(), 0);
  std::vector<bool> valid(rate.size(), true);
  for (int k : {5, 400, 401, 402, 1500, 2999}) {
    rate[k] = std::nan("");
    valid[k] = false;
  }
  for (int k : {77, 1200, 1201}) {
    flags[k] = 1;
    valid[k] = false;
  }
  rate[2000] = std::numeric_limits<double>::infinity();
  valid[2000] = false;
  rate[900] = 0.0;
  rate[901] = 0.0;
  // WHEN the phase record is built
  const PhaseRecord phase = PhaseFromRate(rate, 1.0, flags);
  // THEN the validity count is exact and every point matches brute force.
  EXPECT_EQ(phase.invalid_count(), 10);
  for (Deviation dev : kAllDeviations) {
    for (int64_t m : {1, 2, 3, 5, 8, 16, 50, 100, 200, 333, 450, 700}) {
      SCOPED_TRACE(std::string(DeviationName(dev)) + " m=" + std::to_string(m));
      const BruteForcePoint expected = BruteForce(phase.x, valid, dev, m, 1.0);
      const CurvePoint point = ComputeDeviationAt(phase, dev, m);
      EXPECT_EQ(point.n, expected.n);
      if (expected.n > 0) {
        ASSERT_TRUE(std::isfinite(point.dev));
        EXPECT_LE(RelativeError(point.dev, expected.dev), kSameSumRelTol);
      }
    }
  }
}

TEST(Estimators, GapsGiveExactlyThePooledPerSegmentSums) {
  // GIVEN three gap-free segments separated by single invalid samples placed
  // so that every segment starts at a multiple of 16 (keeping the
  // non-overlapped estimators' stride aligned).
  const std::vector<double> full = NoisyRate(3 * 1024, 21);
  std::vector<double> rate = full;
  const int64_t gaps[] = {1023, 2047};
  for (int64_t g : gaps) rate[g] = std::nan("");
  const PhaseRecord record = PhaseFromRate(rate, 1.0);
  std::vector<PhaseRecord> segments;
  int64_t begin = 0;
  for (int64_t end : {int64_t{1023}, int64_t{2047}, int64_t{3072}}) {
    segments.push_back(
        PhaseFromRate(std::span<const double>(full).subspan(begin, end - begin), 1.0));
    begin = end + 1;
  }
  for (Deviation dev : {Deviation::kAdev, Deviation::kOadev, Deviation::kMdev, Deviation::kHdev,
                        Deviation::kOhdev}) {
    for (int64_t m : {1, 2, 4, 8, 16}) {
      SCOPED_TRACE(std::string(DeviationName(dev)) + " m=" + std::to_string(m));
      // WHEN the pooled variance sum_s n_s var_s / sum_s n_s is formed
      double pooled = 0.0;
      int64_t n = 0;
      for (const PhaseRecord& segment : segments) {
        const CurvePoint p = ComputeDeviationAt(segment, dev, m);
        if (p.n == 0) continue;
        pooled += p.n * p.dev * p.dev;
        n += p.n;
      }
      // THEN the gapped record gives the same n and variance.
      const CurvePoint point = ComputeDeviationAt(record, dev, m);
      EXPECT_EQ(point.n, n);
      EXPECT_LE(RelativeError(point.dev * point.dev, pooled / n), kSameSumRelTol);
    }
  }
}

TEST(Estimators, NanInTheMiddleDoesNotPoisonLaterTaus) {
  std::vector<double> rate = NoisyRate(4096, 31);
  rate[2000] = std::nan("");
  const PhaseRecord phase = PhaseFromRate(rate, 1.0);
  for (double x : phase.x) ASSERT_TRUE(std::isfinite(x));
  for (Deviation dev : kAllDeviations) {
    const Curve curve =
        ComputeDeviation(phase, dev, AveragingFactors({}, 1.0, phase.size(), dev, StopRule::kNone));
    ASSERT_FALSE(curve.points.empty());
    EXPECT_EQ(curve.invalid_rate_samples, 1);
    for (const CurvePoint& point : curve.points) {
      EXPECT_TRUE(std::isfinite(point.dev)) << DeviationName(dev) << " m=" << point.m;
    }
  }
}

TEST(Estimators, ZeroIsAValidRate) {
  // A rate of exactly 0 deg/s (a still gyro) is data, not a gap.
  std::vector<double> rate(1000, 0.0);
  for (size_t k = 0; k < rate.size(); k += 3) rate[k] = 1.0;
  const PhaseRecord phase = PhaseFromRate(rate, 1.0);
  EXPECT_EQ(phase.invalid_count(), 0);
  EXPECT_TRUE(phase.invalid_prefix.empty());
  const CurvePoint point = ComputeDeviationAt(phase, Deviation::kOadev, 1);
  EXPECT_EQ(point.n, phase.size() - 2);
  // Period-3 pattern 1,0,0: consecutive differences are +-1 or 0, two out of
  // three adjacent pairs differ, so AVAR(1) = (1/2) (2/3).
  EXPECT_NEAR(point.dev, std::sqrt(1.0 / 3.0), 1e-3);
}

TEST(Estimators, InvalidFlagsAndNanAreTheSameGap) {
  std::vector<double> rate = NoisyRate(2000, 41);
  std::vector<double> with_nan = rate;
  std::vector<uint8_t> flags(rate.size(), 0);
  for (int k : {10, 999, 1000, 1777}) {
    with_nan[k] = std::nan("");
    flags[k] = 1;
  }
  const PhaseRecord a = PhaseFromRate(with_nan, 1.0);
  const PhaseRecord b = PhaseFromRate(rate, 1.0, flags);
  EXPECT_EQ(a.invalid_prefix, b.invalid_prefix);
  EXPECT_EQ(a.x, b.x);
}

TEST(Estimators, FloatRateGivesTheSamePhaseAsItsDoubleValues) {
  const std::vector<double> rate = NoisyRate(1000, 42);
  std::vector<float> as_float(rate.begin(), rate.end());
  const std::vector<double> widened(as_float.begin(), as_float.end());
  EXPECT_EQ(PhaseFromRate(as_float, 0.01).x, PhaseFromRate(widened, 0.01).x);
}

TEST(Estimators, PhaseGapInvalidatesOnlyTermsWhoseWindowHoldsIt) {
  // A NaN phase point x_k becomes invalid rate samples y_{k-1} and y_k.
  std::vector<double> x(200);
  std::mt19937_64 rng(51);
  std::normal_distribution<double> normal;
  for (double& v : x) v = normal(rng);
  x[100] = std::nan("");
  const PhaseRecord phase = PhaseFromPhase(x, 1.0);
  EXPECT_EQ(phase.invalid_count(), 2);
  for (double v : phase.x) ASSERT_TRUE(std::isfinite(v));
  // OADEV at m: the terms i with i <= 100 <= i + 2m are skipped, 2m + 1 of them.
  for (int64_t m : {1, 5, 20}) {
    EXPECT_EQ(ComputeDeviationAt(phase, Deviation::kOadev, m).n, 200 - 2 * m - (2 * m + 1));
  }
}

TEST(Estimators, EmptyAndTinyRecords) {
  const PhaseRecord empty = PhaseFromRate(std::span<const double>(), 1.0);
  EXPECT_EQ(empty.size(), 0);
  EXPECT_TRUE(
      ComputeDeviation(empty, Deviation::kOadev, std::vector<int64_t>{1, 2}).points.empty());
  const PhaseRecord two = PhaseFromRate(std::vector<double>{1.0}, 1.0);
  for (Deviation dev : kAllDeviations) {
    EXPECT_TRUE(ComputeDeviation(two, dev, std::vector<int64_t>{0, 1, 2}).points.empty());
    EXPECT_EQ(ComputeDeviationAt(two, dev, 5).n, 0);
  }
}

TEST(Estimators, MdevRecurrenceStaysExactOverLongRuns) {
  // Long runs exercise the side-by-side recurrence chains, their exact
  // restarts and the leftover terms; a phase offset of 1000 (1000 times the
  // typical second difference) makes every recurrence step round at that
  // scale, so drift would show.
  const std::vector<double> rate = NoisyRate(100003, 61);
  std::vector<double> x = PhaseFromRate(rate, 1.0).x;
  for (double& v : x) v += 1000.0;
  const PhaseRecord phase = PhaseFromPhase(x, 1.0);
  const std::vector<bool> valid(rate.size(), true);
  for (int64_t m : {1, 7, 600, 1000, 2500}) {
    SCOPED_TRACE("m=" + std::to_string(m));
    const BruteForcePoint expected = BruteForce(phase.x, valid, Deviation::kMdev, m, 1.0);
    const CurvePoint point = ComputeDeviationAt(phase, Deviation::kMdev, m);
    EXPECT_EQ(point.n, expected.n);
    EXPECT_LE(RelativeError(point.dev, expected.dev), kSameSumRelTol);
  }
}

TEST(Estimators, CurveEqualsPointByPointEvaluationBitForBit) {
  // ComputeDeviation sweeps all m of OADEV/OHDEV together; the result for an
  // m must not depend on which other m were swept with it.
  std::vector<double> rate = NoisyRate(50000, 81);
  rate[7777] = std::nan("");
  for (bool with_gap : {false, true}) {
    const PhaseRecord phase =
        with_gap ? PhaseFromRate(rate, 0.1) : PhaseFromRate(NoisyRate(50000, 81), 0.1);
    for (Deviation dev : kAllDeviations) {
      const std::vector<int64_t> m_list = {1000, 1, 3, 2048, 5, 4096, 1};  // any order
      const Curve curve = ComputeDeviation(phase, dev, m_list);
      ASSERT_EQ(curve.points.size(), m_list.size()) << DeviationName(dev);
      for (size_t k = 0; k < m_list.size(); ++k) {
        const CurvePoint single = ComputeDeviationAt(phase, dev, m_list[k]);
        EXPECT_EQ(curve.points[k].m, m_list[k]);
        EXPECT_EQ(curve.points[k].n, single.n);
        EXPECT_EQ(curve.points[k].dev, single.dev) << DeviationName(dev) << " m=" << m_list[k];
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Strided OAVAR.

TEST(OverlappingAllanStrided, StrideOneIsOadevAndStrideMIsAdev) {
  std::vector<double> rate = NoisyRate(5000, 71);
  rate[3333] = std::nan("");
  const PhaseRecord phase = PhaseFromRate(rate, 0.01);
  for (int64_t m : {1, 3, 16, 100, 1000}) {
    SCOPED_TRACE("m=" + std::to_string(m));
    const CurvePoint oadev = ComputeDeviationAt(phase, Deviation::kOadev, m);
    const CurvePoint adev = ComputeDeviationAt(phase, Deviation::kAdev, m);
    const CurvePoint s1 = OverlappingAllanStrided(phase, m, 1);
    const CurvePoint sm = OverlappingAllanStrided(phase, m, m);
    EXPECT_EQ(s1.n, oadev.n);
    EXPECT_EQ(s1.dev, oadev.dev);
    EXPECT_EQ(sm.n, adev.n);
    EXPECT_EQ(sm.dev, adev.dev);
  }
}

TEST(OverlappingAllanStrided, IntermediateStrideMatchesBruteForce) {
  std::vector<double> rate = NoisyRate(4000, 72);
  std::vector<bool> valid(rate.size(), true);
  rate[1234] = std::nan("");
  valid[1234] = false;
  const PhaseRecord phase = PhaseFromRate(rate, 1.0);
  for (int64_t m : {8, 64, 256}) {
    for (int64_t stride : {2, 4, 8}) {
      SCOPED_TRACE("m=" + std::to_string(m) + " stride=" + std::to_string(stride));
      long double sum = 0;
      int64_t n = 0;
      for (int64_t i = 0; i + 2 * m < phase.size(); i += stride) {
        if (!WindowValid(valid, i, 2 * m)) continue;
        const long double d =
            static_cast<long double>(phase.x[i + 2 * m]) - 2.0L * phase.x[i + m] + phase.x[i];
        sum += d * d;
        ++n;
      }
      const double expected = static_cast<double>(std::sqrt(sum / (2 * n)) / m);
      const CurvePoint point = OverlappingAllanStrided(phase, m, stride);
      EXPECT_EQ(point.n, n);
      EXPECT_LE(RelativeError(point.dev, expected), kSameSumRelTol);
    }
  }
  EXPECT_EQ(OverlappingAllanStrided(phase, 5000, 1).n, 0);
  EXPECT_TRUE(std::isnan(OverlappingAllanStrided(phase, 5000, 1).dev));
}

// ---------------------------------------------------------------------------
// Numerical precision on a long record (ALGORITHMS.md §4).

TEST(Precision, HundredMillionSampleOadevMatchesLongDouble) {
  // GIVEN 1e8 samples at 100 Hz of 9.80665 + white (0.02) + a small random walk.
  constexpr int64_t kSamples = 100'000'000;
  constexpr double kTau0 = 0.01;
  // Relative error budget of the double path (mean-removed phase, chunked
  // sums) against 80-bit long double; ALGORITHMS.md §4 measured <= 1e-12.
  constexpr double kPrecisionRelTol = 1e-9;
  std::vector<double> rate(kSamples);
  {
    std::mt19937_64 rng(20240607);
    std::normal_distribution<double> normal;
    double walk = 0.0;
    for (double& y : rate) {
      walk += 2e-6 * normal(rng);
      y = 9.80665 + 0.02 * normal(rng) + walk;
    }
  }
  // WHEN OADEV is computed in double
  const PhaseRecord phase = PhaseFromRate(rate, kTau0);
  const std::vector<int64_t> m_list = {1, 1000, 1000000};
  const Curve curve = ComputeDeviation(phase, Deviation::kOadev, m_list);
  ASSERT_EQ(curve.points.size(), m_list.size());

  // THEN it matches a long-double evaluation streamed over the same samples:
  // phase X_{k+1} = X_k + tau0 (y_k - mean) with a long-double mean, and
  // for each m a ring of the last 2m + 1 phases.
  long double mean = 0;
  for (double y : rate) mean += y;
  mean /= kSamples;
  struct Ring {
    int64_t m;
    std::vector<long double> values;
    long double sum = 0;
    int64_t n = 0;
    int64_t head = 0;
  };
  std::vector<Ring> rings;
  for (int64_t m : m_list) rings.push_back({m, std::vector<long double>(2 * m + 1), 0, 0, 0});
  long double phase_ld = 0;
  for (int64_t k = 0; k <= kSamples; ++k) {
    if (k > 0) phase_ld += kTau0 * (static_cast<long double>(rate[k - 1]) - mean);
    for (Ring& ring : rings) {
      // head = k mod (2m + 1); x_{k-m} and x_{k-2m} sit m and 2m slots back.
      const int64_t size = 2 * ring.m + 1;
      ring.values[ring.head] = phase_ld;
      if (k >= 2 * ring.m) {
        const int64_t back1 = ring.head >= ring.m ? ring.head - ring.m : ring.head - ring.m + size;
        const int64_t back2 =
            ring.head >= 2 * ring.m ? ring.head - 2 * ring.m : ring.head - 2 * ring.m + size;
        const long double d = phase_ld - 2 * ring.values[back1] + ring.values[back2];
        ring.sum += d * d;
        ++ring.n;
      }
      if (++ring.head == size) ring.head = 0;
    }
  }
  for (size_t i = 0; i < rings.size(); ++i) {
    const Ring& ring = rings[i];
    const long double tau = ring.m * static_cast<long double>(kTau0);
    const double expected = static_cast<double>(std::sqrt(ring.sum / (2 * ring.n)) / tau);
    SCOPED_TRACE("m=" + std::to_string(ring.m));
    EXPECT_EQ(curve.points[i].n, ring.n);
    const double error = RelativeError(curve.points[i].dev, expected);
    EXPECT_LE(error, kPrecisionRelTol);
    RecordProperty("rel_error_m" + std::to_string(ring.m), std::to_string(error));
    std::printf("m=%lld OADEV %.17g long double %.17g rel error %.3g\n",
                static_cast<long long>(ring.m), curve.points[i].dev, expected, error);
  }
}

}  // namespace
}  // namespace imuqual::allan
