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

void DeviceClockFit::Line::Add(double x, double y) {
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
  const double slope = s->line.n >= 2 ? s->line.Slope() : 0.0;
  const Point* best = &window.front();
  for (const Point& p : window) {
    if (p.y - slope * p.x < best->y - slope * best->x) best = &p;
  }
  for (const Point& p : window) {
    const double dx = p.x - best->x, dy = p.y - best->y;
    s->dyy += dy * dy;
    s->dxy += dx * dy;
    s->dxx += dx * dx;
    ++s->late_n;
  }
  s->line.Add(best->x, best->y);
}

DeviceClockFit::State DeviceClockFit::Current() const {
  State s = closed_;
  if (!open_.empty()) Close(open_, &s);
  return s;
}

double DeviceClockFit::Slope() const {
  const State s = Current();
  if (!(s.line.sxx > 0)) return kNaN;
  return tau0_s_ + s.line.Slope();
}

bool DeviceClockFit::Usable(double min_span_samples) const {
  const State s = Current();
  return s.line.n >= 3 && s.line.sxx > 0 && s.line.max_x - s.line.min_x >= min_span_samples &&
         tau0_s_ + s.line.Slope() > 0;
}

double DeviceClockFit::RateHz() const { return 1.0 / Slope(); }

double DeviceClockFit::RateSigmaHz() const {
  const State s = Current();
  const Line& l = s.line;
  if (l.n < 3 || !(l.sxx > 0)) return kNaN;
  const double var = std::max(l.syy - l.sxy * l.sxy / l.sxx, 0.0) / static_cast<double>(l.n - 2);
  const double slope = tau0_s_ + l.Slope();
  return std::sqrt(var / l.sxx) / (slope * slope);
}

double DeviceClockFit::JitterRmsS() const {
  const State s = Current();
  if (s.late_n == 0) return kNaN;
  const double k = s.line.Slope();
  const double sum_sq = s.dyy - 2 * k * s.dxy + k * k * s.dxx;
  return std::sqrt(std::max(sum_sq, 0.0) / static_cast<double>(s.late_n));
}

}  // namespace imuqual::analyze
