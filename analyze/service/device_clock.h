// The device's clock against the host's: a least-squares line through
// (device sample counter, host arrival time) of every batch that carries an
// arrival time. Its slope is the device's real sample period, so a part sold
// as 2000 Hz that runs at 2010 Hz shows +5000 ppm; the scatter about the line
// is the arrival jitter the host saw (USB and scheduler latency, buffering).
// The host clock is the reference: its own error (NTP-disciplined, usually
// well under 10 ppm) bounds what a rate error can mean. Pure; not
// thread-safe.
#ifndef IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
#define IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_

#include <cstdint>

namespace imuqual::analyze {

class DeviceClockFit {
 public:
  // `nominal_rate_hz` > 0: the line is fitted to the arrival times minus
  // the nominal clock, which keeps the sums' cancellation small over days.
  explicit DeviceClockFit(double nominal_rate_hz) : tau0_s_(1.0 / nominal_rate_hz) {}

  // A batch whose first sample (device counter `counter`) arrived at host
  // time `utime` (us). Points need not be in counter order.
  void Add(int64_t counter, int64_t utime);

  int64_t points() const { return n_; }
  // True when the line is determined: three or more points spanning at
  // least `min_span_samples` of counter, and time moving forward with it.
  bool Usable(double min_span_samples) const;
  // Samples per second of host time.
  double RateHz() const;
  // 1-sigma standard error of RateHz() from the scatter (treating the
  // residuals as independent, which latency is not quite: a lower bound).
  double RateSigmaHz() const;
  // RMS of the arrival times about the line, seconds.
  double JitterRmsS() const;

 private:
  double Slope() const;  // seconds per sample

  double tau0_s_;
  int64_t n_ = 0;
  int64_t c0_ = 0, u0_ = 0;  // origin, for precision
  double min_x_ = 0, max_x_ = 0;
  double mean_x_ = 0, mean_y_ = 0;  // x: samples from c0; y: seconds from u0 - x tau0
  double sxx_ = 0, syy_ = 0, sxy_ = 0;
};

}  // namespace imuqual::analyze

#endif  // IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
