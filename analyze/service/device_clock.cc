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

void DeviceClockFit::Moments::Add(double x, double y) {
  ++n;
  min_x = n == 1 ? x : std::min(min_x, x);
  max_x = n == 1 ? x : std::max(max_x, x);
  const double dx = x - mean_x;
  const double dy = y - mean_y;
  mean_x += dx / static_cast<double>(n);
  mean_y += dy / static_cast<double>(n);
  sxx += dx * (x - mean_x);
  syy += dy * (y - mean_y);
  sxy += dx * (y - mean_y);
}

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
    Close(open_, &closed_);
    open_.clear();
  }
  window_ = window;
  open_.push_back({x, y});
}

void DeviceClockFit::Close(const std::vector<Point>& window, State* s) {
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
  s->minima.Add(best->x, best->y);
  // Monotone chain: counters only rise, so the new point ends the hull; drop
  // the points it makes non-convex from below.
  std::vector<Point>& h = s->hull;
  if (!h.empty() && best->x <= h.back().x) {
    if (best->y >= h.back().y) return;
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
}

DeviceClockFit::State DeviceClockFit::Current() const {
  State s = closed_;
  if (!open_.empty()) Close(open_, &s);
  return s;
}

double DeviceClockFit::Slope() const {
  const State s = Current();
  if (s.hull.size() < 2) return kNaN;
  return tau0_s_ + s.Slope();
}

bool DeviceClockFit::Usable(double min_span_samples) const {
  const State s = Current();
  const Moments& m = s.minima;
  return m.n >= 3 && s.hull.size() >= 2 && m.max_x - m.min_x >= min_span_samples &&
         tau0_s_ + s.Slope() > 0;
}

double DeviceClockFit::RateHz() const { return 1.0 / Slope(); }

double DeviceClockFit::RateSigmaHz() const {
  const State s = Current();
  const Moments& m = s.minima;
  if (m.n < 3 || !(m.sxx > 0) || s.hull.size() < 2) return kNaN;
  // The minima's scatter about the line: their residuals y - k x, centred.
  const double k = s.Slope();
  const double ss = std::max(m.syy - 2 * k * m.sxy + k * k * m.sxx, 0.0);
  const double var = ss / static_cast<double>(m.n - 2);
  const double slope = tau0_s_ + k;
  return std::sqrt(var / m.sxx) / (slope * slope);
}

double DeviceClockFit::JitterRmsS() const {
  const State s = Current();
  if (s.n == 0) return kNaN;
  const double k = s.Slope();
  const double sum_sq = s.dyy - 2 * k * s.dxy + k * k * s.dxx;
  return std::sqrt(std::max(sum_sq, 0.0) / static_cast<double>(s.n));
}

}  // namespace imuqual::analyze
