// The device's clock against the host's, from (device sample counter, host
// arrival time) of every batch that carries an arrival time.
//
// Arrival = emission + latency, and latency is never negative: USB polling,
// the kernel and a busy host only ever make data late, in bursts. So the
// device clock is fitted to the least-late arrival of each window of device
// time (one second), by least squares: a busy spell that delays a few
// hundred batches moves none of the window minima much, where it would tilt
// a fit through every point. The slope is the device's real sample period:
// a part sold as 2000 Hz that runs at 2010 Hz shows +5000 ppm. The jitter is
// the RMS of each arrival's lateness over its window's least-late one.
//
// The host clock is the reference: its own error (NTP-disciplined, usually
// well under 10 ppm) bounds what a rate error can mean. Memory is constant
// (one window of points). Pure; not thread-safe.
#ifndef IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
#define IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_

#include <cstdint>
#include <vector>

namespace imuqual::analyze {

class DeviceClockFit {
 public:
  // `nominal_rate_hz` > 0; `window_s` of device time per fitted point.
  explicit DeviceClockFit(double nominal_rate_hz, double window_s = 1.0);

  // A batch whose first sample (device counter `counter`) arrived at host
  // time `utime` (us). Counters must not go backwards.
  void Add(int64_t counter, int64_t utime);

  int64_t points() const { return points_; }
  // True when the line is determined: three or more windows spanning at
  // least `min_span_samples` of counter, and time moving forward with it.
  bool Usable(double min_span_samples) const;
  // Samples per second of host time.
  double RateHz() const;
  // 1-sigma standard error of RateHz() from the window minima's scatter.
  double RateSigmaHz() const;
  // RMS lateness of arrivals over their window's least-late one, seconds.
  double JitterRmsS() const;

 private:
  // Least squares of y on x, with Welford-style co-moments.
  struct Line {
    int64_t n = 0;
    double mean_x = 0, mean_y = 0, sxx = 0, syy = 0, sxy = 0;
    double min_x = 0, max_x = 0;
    void Add(double x, double y);
    double Slope() const { return sxx > 0 ? sxy / sxx : 0.0; }
  };
  struct Point {
    double x, y;
  };
  struct State {
    Line line;  // window minima; y is seconds minus x * tau0
    // Each arrival against its window's least-late one (dx, dy): the
    // lateness along a slope s is dy - s dx, so its sum of squares is
    // syy - 2 s sxy + s^2 sxx, evaluated with the final slope.
    double dyy = 0, dxy = 0, dxx = 0;
    int64_t late_n = 0;
  };
  // Folds a window's points into *s.
  static void Close(const std::vector<Point>& window, State* s);
  // The state with the open window folded in.
  State Current() const;
  double Slope() const;  // seconds per sample

  double tau0_s_;
  double window_samples_;
  int64_t points_ = 0;
  int64_t c0_ = 0, u0_ = 0;  // origin, for precision
  int64_t window_ = -1;      // index of the open window
  std::vector<Point> open_;
  State closed_;
};

}  // namespace imuqual::analyze

#endif  // IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
