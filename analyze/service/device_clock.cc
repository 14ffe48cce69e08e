#include "analyze/service/device_clock.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace imuqual::analyze {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

DeviceClockFit::DeviceClockFit(double nominal_rate_hz, double window_s)
    : tau0_s_(1.0 / nominal_rate_hz), window_samples_(std::max(1.0, window_s * nominal_rate_hz)) {}

double DeviceClockFit::State::Slope() const {
  if (hull.size() < 2 || n == 0) return 0.0;
  const double mean_x = sum_x / static_cast<double>(n);
  // The first edge that reaches the mean counter (the ends' edges beyond it).
  size_t i = 1;
  while (i + 1 < hull.size() && hull[i].x < mean_x) ++i;
  return (hull[i].y - hull[i - 1].y) / (hull[i].x - hull[i - 1].x);
}

void DeviceClockFit::Add(int64_t counter, int64_t utime) {
  if (points_ == 0) {
    c0_ = counter;
    u0_ = utime;
  }
  ++points_;
  const double x = static_cast<double>(counter - c0_);
  // Arrival minus the nominal clock: small numbers, so the sums keep their
  // precision over days.
  const double y = static_cast<double>(utime - u0_) * 1e-6 - x * tau0_s_;
  const int64_t window = static_cast<int64_t>(std::floor(x / window_samples_));
  if (window != window_ && !open_.empty()) {
    minima_.push_back(Close(open_, &closed_));
    open_.clear();
  }
  window_ = window;
  open_.push_back({x, y});
}

DeviceClockFit::Point DeviceClockFit::Close(const std::vector<Point>& window, State* s) {
  // Lateness is judged along the clock fitted so far (a device 0.5% fast
  // drifts 5 ms a second against the nominal clock).
  const double slope = s->Slope();
  const Point* best = &window.front();
  for (const Point& p : window) {
    if (p.y - slope * p.x < best->y - slope * best->x) best = &p;
    s->sum_x += p.x;
    ++s->n;
  }
  for (const Point& p : window) {
    const double dx = p.x - best->x, dy = p.y - best->y;
    s->dyy += dy * dy;
    s->dxy += dx * dy;
    s->dxx += dx * dx;
  }
  // Monotone chain: counters only rise, so the new point ends the hull; drop
  // the points it makes non-convex from below.
  std::vector<Point>& h = s->hull;
  if (!h.empty() && best->x <= h.back().x) {
    if (best->y >= h.back().y) return *best;
    h.pop_back();
  }
  while (h.size() >= 2) {
    const Point& o = h[h.size() - 2];
    const Point& a = h.back();
    const double cross = (a.x - o.x) * (best->y - o.y) - (a.y - o.y) * (best->x - o.x);
    if (cross > 0) break;
    h.pop_back();
  }
  h.push_back(*best);
  return *best;
}

DeviceClockFit::State DeviceClockFit::Current(Point* open_best, bool* has_open) const {
  State s = closed_;
  if (has_open != nullptr) *has_open = !open_.empty();
  if (!open_.empty()) {
    const Point best = Close(open_, &s);
    if (open_best != nullptr) *open_best = best;
  }
  return s;
}

double DeviceClockFit::Slope() const {
  const State s = Current();
  if (s.hull.size() < 2) return kNaN;
  return tau0_s_ + s.Slope();
}

bool DeviceClockFit::Usable(double min_span_samples) const {
  Point open_best{};
  bool has_open = false;
  const State s = Current(&open_best, &has_open);
  const size_t windows = minima_.size() + (has_open ? 1 : 0);
  if (windows < 3 || s.hull.size() < 2) return false;
  const double first = minima_.front().x;  // windows >= 3: at least two closed
  const double last = has_open ? open_best.x : minima_.back().x;
  return last - first >= min_span_samples && tau0_s_ + s.Slope() > 0;
}

double DeviceClockFit::RateHz() const { return 1.0 / Slope(); }

double DeviceClockFit::RateSigmaHz() const {
  Point open_best{};
  bool has_open = false;
  const State s = Current(&open_best, &has_open);
  const Point* open = has_open ? &open_best : nullptr;
  if (minima_.size() + (has_open ? 1 : 0) < 3 || s.hull.size() < 2) return kNaN;
  // Each window's lateness above the line; those of a busy spell lie far
  // above the rest and are left out (beyond the median + 5 robust sigma).
  const double k = s.Slope();
  const Point& o = s.hull.front();
  std::vector<double> late;
  late.reserve(minima_.size() + 1);
  ForEachMinimum(open, [&](const Point& p) { late.push_back(p.y - o.y - k * (p.x - o.x)); });
  std::vector<double> spread = late;
  const auto mid = spread.begin() + static_cast<std::ptrdiff_t>(spread.size() / 2);
  std::nth_element(spread.begin(), mid, spread.end());
  const double median = *mid;
  for (double& v : spread) v = std::abs(v - median);
  std::nth_element(spread.begin(), mid, spread.end());
  const double cut = median + 5 * 1.4826 * *mid;
  // The least-squares standard error of a slope through the kept windows.
  int64_t n = 0;
  size_t i = 0;
  double mean_x = 0, mean_r = 0, sxx = 0, srr = 0, sxr = 0;
  ForEachMinimum(open, [&](const Point& p) {
    const double r = late[i++];
    if (r > cut) return;
    ++n;
    const double dx = p.x - mean_x, dr = r - mean_r;
    mean_x += dx / static_cast<double>(n);
    mean_r += dr / static_cast<double>(n);
    sxx += dx * (p.x - mean_x);
    srr += dr * (r - mean_r);
    sxr += dx * (r - mean_r);
  });
  if (n < 3 || !(sxx > 0)) return kNaN;
  const double var = std::max(srr - sxr * sxr / sxx, 0.0) / static_cast<double>(n - 2);
  const double slope = tau0_s_ + k;
  return std::sqrt(var / sxx) / (slope * slope);
}

double DeviceClockFit::JitterRmsS() const {
  const State s = Current();
  if (s.n == 0) return kNaN;
  const double k = s.Slope();
  const double sum_sq = s.dyy - 2 * k * s.dxy + k * k * s.dxx;
  return std::sqrt(std::max(sum_sq, 0.0) / static_cast<double>(s.n));
}

}  // namespace imuqual::analyze
