#include "analyze/allan/fit_rows.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "analyze/allan/confidence.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {

std::vector<FitRow> UsableFitRows(const Curve& curve, StopRule stop, bool thin_to_octaves) {
  const bool overlapped = curve.deviation == Deviation::kOadev;
  const int64_t m_max = stop == StopRule::kNone
                            ? std::numeric_limits<int64_t>::max()
                            : StopRuleMaxAveragingFactor(stop, curve.deviation, curve.n_phase);
  std::vector<CurvePoint> usable;
  for (const CurvePoint& p : curve.points) {
    if (p.m >= 1 && p.m <= m_max && p.n > 1 && std::isfinite(p.dev) && p.dev > 0 &&
        std::isfinite(p.tau_s) && p.tau_s > 0) {
      usable.push_back(p);
    }
  }
  std::sort(usable.begin(), usable.end(),
            [](const CurvePoint& a, const CurvePoint& b) { return a.m < b.m; });
  std::vector<FitRow> rows;
  for (const CurvePoint& p : usable) {
    if (!rows.empty() && p.m == rows.back().m) continue;
    if (thin_to_octaves && !rows.empty() && p.m < 2 * rows.back().m) continue;
    FitRow row;
    row.m = p.m;
    row.tau_s = p.tau_s;
    row.avar = p.dev * p.dev;
    row.stride = p.stride > 0 ? p.stride : (overlapped ? 1 : p.m);
    row.n_eff = std::min(curve.n_phase, (p.n - 1) * row.stride + 2 * p.m + 1);
    row.point_edf = p.edf;
    row.identified = p.alpha.has_value();
    rows.push_back(row);
  }
  for (size_t i = 0; i < rows.size() && rows.size() > 1; ++i) {
    const size_t a = i == 0 ? 0 : i - 1, b = i + 1 == rows.size() ? i : i + 1;
    rows[i].local_slope =
        std::log(rows[b].avar / rows[a].avar) / std::log(rows[b].tau_s / rows[a].tau_s);
  }
  return rows;
}

int AlphaFromAvarSlope(double mu) {
  if (!std::isfinite(mu)) return 0;
  return static_cast<int>(std::clamp(std::lround(-mu - 1.0), -2L, 1L));
}

double FitRowEdf(int alpha, const FitRow& row) {
  const double md = static_cast<double>(row.m);
  const std::optional<double> nu = GreenhallEdf(alpha, /*d=*/2, row.m, row.n_eff, /*F=*/md,
                                                /*S=*/md / static_cast<double>(row.stride));
  if (nu.has_value() && std::isfinite(*nu) && *nu > 0) return *nu;
  return std::max<double>(1.0, static_cast<double>((row.n_eff - 1) / row.m - 1));
}

}  // namespace imuqual::allan
