#include "analyze/allan/dynamic_allan.h"

#include <cmath>
#include <string>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"
#include "common/strings.h"

namespace imuqual::allan {

Status DynamicAllanOptions::Validate() const {
  if (!std::isfinite(window_s) || window_s < 0) {
    return Status::InvalidArgument("dynamic Allan: window_s must be >= 0, got " +
                                   ShortestReal(window_s));
  }
  if (!std::isfinite(step_s) || step_s < 0) {
    return Status::InvalidArgument("dynamic Allan: step_s must be >= 0, got " +
                                   ShortestReal(step_s));
  }
  if (window_s > 0 && step_s > window_s) {
    return Status::InvalidArgument("dynamic Allan: the step (" + ShortestReal(step_s) +
                                   " s) is longer than the window (" + ShortestReal(window_s) +
                                   " s): samples between windows would be left out");
  }
  return Status::Ok();
}

namespace {

template <typename Sample>
Result<DynamicAllan> Compute(std::span<const Sample> rate, double tau0_s,
                             std::span<const uint8_t> invalid, const DynamicAllanOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (!(tau0_s > 0) || !std::isfinite(tau0_s)) {
    return Status::InvalidArgument("dynamic Allan: tau0 must be > 0, got " + ShortestReal(tau0_s));
  }
  if (!invalid.empty() && invalid.size() != rate.size()) {
    return Status::InvalidArgument("dynamic Allan: " + std::to_string(invalid.size()) +
                                   " invalid flags for " + std::to_string(rate.size()) +
                                   " samples");
  }
  const int64_t n = static_cast<int64_t>(rate.size());
  if (options.window_s / tau0_s > static_cast<double>(n) + 0.5) {
    return Status::InvalidArgument("dynamic Allan: the window (" + ShortestReal(options.window_s) +
                                   " s) is longer than the record (" +
                                   ShortestReal(static_cast<double>(n) * tau0_s) + " s)");
  }
  const int64_t window = options.window_s > 0 ? std::llround(options.window_s / tau0_s) : n / 4;
  constexpr int64_t kMinWindow = 64;
  if (window < kMinWindow) {
    return Status::InvalidArgument("dynamic Allan: a window of " + std::to_string(window) +
                                   " samples is too short (at least " +
                                   std::to_string(kMinWindow) + ")");
  }
  if (window > n) {
    return Status::InvalidArgument("dynamic Allan: the window (" + std::to_string(window) +
                                   " samples) is longer than the record (" + std::to_string(n) +
                                   ")");
  }
  int64_t step = options.step_s > 0 ? std::llround(options.step_s / tau0_s) : window / 4;
  if (step < 1) {
    return Status::InvalidArgument("dynamic Allan: the step is shorter than one sample");
  }
  // At most kMaxWindows (the last one, ending at the record's end, included).
  const int64_t room = n - window;
  if (room / step + 2 > DynamicAllanOptions::kMaxWindows) {
    step = room / (DynamicAllanOptions::kMaxWindows - 2) + 1;
  }
  DynamicAllan out;
  out.tau0_s = tau0_s;
  out.window_s = static_cast<double>(window) * tau0_s;
  out.step_s = static_cast<double>(step) * tau0_s;
  std::vector<int64_t> starts;
  for (int64_t s = 0; s + window <= n; s += step) starts.push_back(s);
  if (starts.back() + window < n) starts.push_back(n - window);
  for (int64_t s : starts) {
    const PhaseRecord phase = PhaseFromRate(
        rate.subspan(static_cast<size_t>(s), static_cast<size_t>(window)), tau0_s,
        invalid.empty() ? invalid
                        : invalid.subspan(static_cast<size_t>(s), static_cast<size_t>(window)));
    DynamicAllanWindow w;
    w.start_s = static_cast<double>(s) * tau0_s;
    w.length_s = out.window_s;
    w.valid_samples = window - static_cast<int64_t>(InvalidRateIndices(phase).size());
    const std::vector<int64_t> m = AveragingFactors(TauGridSpec{}, tau0_s, phase.size(),
                                                    Deviation::kOadev, StopRule::kBins9);
    w.curve = ComputeDeviation(phase, Deviation::kOadev, m);
    if (options.intervals) {
      AttachConfidence(phase, CiMethod::kChi2, kOneSigmaConfidence, &w.curve);
    }
    out.windows.push_back(std::move(w));
  }
  return out;
}

}  // namespace

Result<DynamicAllan> ComputeDynamicAllan(std::span<const float> rate, double tau0_s,
                                         std::span<const uint8_t> invalid,
                                         const DynamicAllanOptions& options) {
  return Compute(rate, tau0_s, invalid, options);
}

Result<DynamicAllan> ComputeDynamicAllan(std::span<const double> rate, double tau0_s,
                                         std::span<const uint8_t> invalid,
                                         const DynamicAllanOptions& options) {
  return Compute(rate, tau0_s, invalid, options);
}

std::optional<LevelChange> ShortTauLevelChange(const DynamicAllan& davar) {
  const DynamicAllanWindow* first = nullptr;
  const DynamicAllanWindow* last = nullptr;
  int64_t m = 0;
  for (const DynamicAllanWindow& w : davar.windows) {
    if (w.curve.points.empty()) continue;
    if (first == nullptr) {
      first = &w;
      m = w.curve.points.front().m;
    } else if (w.curve.points.front().m == m) {
      last = &w;
    }
  }
  if (first == nullptr || last == nullptr) return std::nullopt;
  const CurvePoint& a = first->curve.points.front();
  const CurvePoint& b = last->curve.points.front();
  const double edf_a = PointEdf(a, first->curve.n_phase, 0);
  const double edf_b = PointEdf(b, last->curve.n_phase, 0);
  if (!(edf_a > 0 && edf_b > 0 && a.dev > 0 && b.dev > 0)) return std::nullopt;
  LevelChange out;
  out.tau_s = a.tau_s;
  out.first_start_s = first->start_s;
  out.last_start_s = last->start_s;
  out.ratio = b.dev / a.dev;
  out.sigma = out.ratio * std::sqrt(1 / (2 * edf_a) + 1 / (2 * edf_b));
  return out;
}

}  // namespace imuqual::allan
