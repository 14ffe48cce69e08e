#include "analyze/service/device_clock.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace imuqual::analyze {

void DeviceClockFit::Add(int64_t counter, int64_t utime) {
  if (n_ == 0) {
    c0_ = counter;
    u0_ = utime;
  }
  const double x = static_cast<double>(counter - c0_);
  const double y = static_cast<double>(utime - u0_) * 1e-6 - x * tau0_s_;
  ++n_;
  min_x_ = n_ == 1 ? x : std::min(min_x_, x);
  max_x_ = n_ == 1 ? x : std::max(max_x_, x);
  // Welford-style co-moments: stable over millions of points.
  const double dx = x - mean_x_;
  const double dy = y - mean_y_;
  mean_x_ += dx / static_cast<double>(n_);
  mean_y_ += dy / static_cast<double>(n_);
  sxx_ += dx * (x - mean_x_);
  syy_ += dy * (y - mean_y_);
  sxy_ += dx * (y - mean_y_);
}

double DeviceClockFit::Slope() const {
  if (!(sxx_ > 0)) return std::numeric_limits<double>::quiet_NaN();
  return tau0_s_ + sxy_ / sxx_;
}

bool DeviceClockFit::Usable(double min_span_samples) const {
  return n_ >= 3 && sxx_ > 0 && max_x_ - min_x_ >= min_span_samples && Slope() > 0;
}

double DeviceClockFit::RateHz() const { return 1.0 / Slope(); }

namespace {
double ResidualVariance(int64_t n, double sxx, double syy, double sxy) {
  if (n < 3 || !(sxx > 0)) return std::numeric_limits<double>::quiet_NaN();
  return std::max(syy - sxy * sxy / sxx, 0.0) / static_cast<double>(n - 2);
}
}  // namespace

double DeviceClockFit::RateSigmaHz() const {
  const double var = ResidualVariance(n_, sxx_, syy_, sxy_);
  const double slope = Slope();
  const double slope_sigma = std::sqrt(var / sxx_);
  return slope_sigma / (slope * slope);
}

double DeviceClockFit::JitterRmsS() const { return std::sqrt(ResidualVariance(n_, sxx_, syy_, sxy_)); }

}  // namespace imuqual::analyze
