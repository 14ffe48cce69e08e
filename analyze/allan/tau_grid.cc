#include "analyze/allan/tau_grid.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

#include "analyze/allan/long_tau.h"

namespace imuqual::allan {
namespace {

std::string_view Trim(std::string_view text) {
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  return text;
}

// Parses all of `text` as a number of type T; nullopt on any leftover.
template <typename T>
std::optional<T> ParseNumber(std::string_view text) {
  T value{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

// Largest k with base^k <= n (n >= 1), in exact integer arithmetic so that
// n = 1000 gives 3 for base 10 (a floating log10 may round below 3).
int FloorLog(int64_t n, int64_t base) {
  int k = 0;
  for (int64_t power = base; power <= n; power *= base) {
    ++k;
    if (power > std::numeric_limits<int64_t>::max() / base) break;
  }
  return k;
}

// The grid before clipping; `m_max` only bounds the "all" list (which would
// otherwise hold N entries).
std::vector<int64_t> RawGrid(const TauGridSpec& grid, double tau0_s, int64_t n_phase,
                             int64_t m_max) {
  std::vector<int64_t> m_list;
  switch (grid.kind) {
    case TauGridSpec::Kind::kOctave: {
      const int k_max = FloorLog(n_phase, 2);
      for (int k = 0; k <= k_max; ++k) m_list.push_back(int64_t{1} << k);
      break;
    }
    case TauGridSpec::Kind::kDecade: {
      const int k_max = FloorLog(n_phase, 10);
      int64_t power = 1;
      for (int k = 0; k <= k_max; ++k, power *= 10) {
        for (int64_t factor : {1, 2, 4}) m_list.push_back(factor * power);
      }
      break;
    }
    case TauGridSpec::Kind::kAll: {
      const int64_t last = std::min(n_phase, m_max);
      m_list.reserve(static_cast<size_t>(std::max<int64_t>(last, 0)));
      for (int64_t m = 1; m <= last; ++m) m_list.push_back(m);
      break;
    }
    case TauGridSpec::Kind::kLogDense: {
      // round(logspace(0, L, floor(P L))): count points evenly spaced in
      // log10 m from 0 to L = log10 N inclusive.
      const double decades = std::log10(static_cast<double>(n_phase));
      const int64_t count = static_cast<int64_t>(grid.points_per_decade * decades);
      if (count == 1) m_list.push_back(1);
      for (int64_t k = 0; count > 1 && k < count; ++k) {
        const double exponent = decades * static_cast<double>(k) / static_cast<double>(count - 1);
        m_list.push_back(static_cast<int64_t>(std::nearbyint(std::pow(10.0, exponent))));
      }
      break;
    }
    case TauGridSpec::Kind::kExplicit: {
      for (double tau_s : grid.tau_s) {
        if (!std::isfinite(tau_s) || tau_s <= 0) continue;
        const double m = std::nearbyint(tau_s / tau0_s);
        if (m >= 1 && m < static_cast<double>(n_phase)) m_list.push_back(static_cast<int64_t>(m));
      }
      break;
    }
  }
  return m_list;
}

}  // namespace

Result<TauGridSpec> ParseTauGrid(std::string_view text) {
  const std::string_view trimmed = Trim(text);
  TauGridSpec grid;
  if (trimmed == "octave") {
    grid.kind = TauGridSpec::Kind::kOctave;
    return grid;
  }
  if (trimmed == "decade") {
    grid.kind = TauGridSpec::Kind::kDecade;
    return grid;
  }
  if (trimmed == "all") {
    grid.kind = TauGridSpec::Kind::kAll;
    return grid;
  }
  if (trimmed.starts_with("log")) {
    const std::optional<int> per_decade = ParseNumber<int>(trimmed.substr(3));
    if (!per_decade || *per_decade < 1 || *per_decade > 10000) {
      return Status::InvalidArgument("tau grid '" + std::string(text) +
                                     "': expected logP with P points per decade, 1..10000");
    }
    grid.kind = TauGridSpec::Kind::kLogDense;
    grid.points_per_decade = *per_decade;
    return grid;
  }
  grid.kind = TauGridSpec::Kind::kExplicit;
  std::string_view rest = trimmed;
  while (true) {
    const size_t comma = rest.find(',');
    const std::string_view item = Trim(rest.substr(0, comma));
    const std::optional<double> tau_s = ParseNumber<double>(item);
    if (!tau_s || !std::isfinite(*tau_s) || *tau_s <= 0) {
      return Status::InvalidArgument(
          "tau grid '" + std::string(text) + "': '" + std::string(item) +
          "' is not octave, decade, all, logP or a positive tau in seconds");
    }
    grid.tau_s.push_back(*tau_s);
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  return grid;
}

std::string TauGridName(const TauGridSpec& grid) {
  switch (grid.kind) {
    case TauGridSpec::Kind::kOctave:
      return "octave";
    case TauGridSpec::Kind::kDecade:
      return "decade";
    case TauGridSpec::Kind::kAll:
      return "all";
    case TauGridSpec::Kind::kLogDense:
      return "log" + std::to_string(grid.points_per_decade);
    case TauGridSpec::Kind::kExplicit: {
      std::string text;
      for (double tau_s : grid.tau_s) {
        char buffer[32];
        const auto result = std::to_chars(buffer, buffer + sizeof(buffer), tau_s);
        if (!text.empty()) text += ',';
        text.append(buffer, result.ptr);
      }
      return text;
    }
  }
  return "";
}

int64_t MaxAveragingFactor(Deviation dev, int64_t n_phase) {
  const int64_t n = n_phase;
  if (n < 4) return 0;
  switch (dev) {
    case Deviation::kAdev:  // floor((N-1)/m) - 1 > 1
    case Deviation::kMdev:  // N - 3m + 1 > 1
    case Deviation::kTdev:
      return (n - 1) / 3;
    case Deviation::kOadev:  // N - 2m > 1
      return (n - 2) / 2;
    case Deviation::kHdev:  // floor((N-1)/m) - 2 > 1
      return (n - 1) / 4;
    case Deviation::kOhdev:  // N - 3m > 1
      return (n - 2) / 3;
    case Deviation::kTotdev:  // N - 2 > 1 for every m < N
      return n - 1;
    case Deviation::kTheo1:  // (N - m) m/2 > 1 for every even m < N
      return n - 1;
    case Deviation::kTheoBr:  // and TheoBR's ratio needs N >= 90
      return n >= 90 ? n - 1 : 0;
    case Deviation::kTheoH:  // below 90 points only the Allan part, m < floor((N-1)/5)
      return n >= 90 ? n - 1 : std::max<int64_t>(TheoHSwitchFactor(n) - 1, 0);
    case Deviation::kMtotdev:  // N - 3m + 1 > 1
    case Deviation::kTtotdev:
      return (n - 1) / 3;
    case Deviation::kHtotdev:  // N - 3m > 1
      return (n - 2) / 3;
  }
  return 0;
}

namespace {

// Whether the estimator has a point at m at all (Theo1 and TheoBR only at even
// m, TheoH not between its Allan and its Theo part).
bool HasPointAt(Deviation dev, int64_t m, int64_t n_phase) {
  if (dev == Deviation::kTheo1 || dev == Deviation::kTheoBr) return m % 2 == 0;
  if (dev == Deviation::kTheoH) return TheoHHasPoint(m, n_phase);
  return true;
}

}  // namespace

int64_t StopRuleMaxAveragingFactor(StopRule stop, Deviation dev, int64_t n_phase) {
  switch (stop) {
    case StopRule::kBins9:
      return std::max<int64_t>(n_phase - 1, 0) / 9;
    case StopRule::kStable32: {
      int64_t ratio = 4;
      if (dev == Deviation::kAdev || dev == Deviation::kHdev) ratio = 5;
      if (dev == Deviation::kTotdev) ratio = 2;
      if (dev == Deviation::kMtotdev || dev == Deviation::kTtotdev || dev == Deviation::kHtotdev) {
        ratio = 3;
      }
      if (IsTheoDeviation(dev)) ratio = 1;
      return std::max<int64_t>(n_phase, 0) / ratio;
    }
    case StopRule::kNone:
      return n_phase;
  }
  return n_phase;
}

std::vector<int64_t> AveragingFactors(const TauGridSpec& grid, double tau0_s, int64_t n_phase,
                                      Deviation dev, StopRule stop) {
  if (n_phase < 2 || !(tau0_s > 0)) return {};
  const int64_t dev_max = MaxAveragingFactor(dev, n_phase);
  const int64_t stop_max = StopRuleMaxAveragingFactor(stop, dev, n_phase);
  // The stop rule bounds the point's tau: m for most estimators, 0.75 m for
  // the Theo family (long_tau.h).
  const int64_t raw_max =
      std::min(dev_max, IsTheoDeviation(dev) ? stop_max + stop_max / 3 + 1 : stop_max);
  std::vector<int64_t> m_list = RawGrid(grid, tau0_s, n_phase, raw_max);
  std::erase_if(m_list, [&](int64_t m) {
    return m < 1 || m >= n_phase || m > dev_max ||
           EffectiveAveragingFactor(dev, m, n_phase) > static_cast<double>(stop_max) ||
           !HasPointAt(dev, m, n_phase);
  });
  std::sort(m_list.begin(), m_list.end());
  m_list.erase(std::unique(m_list.begin(), m_list.end()), m_list.end());
  return m_list;
}

}  // namespace imuqual::allan
