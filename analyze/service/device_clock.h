// The device's clock against the host's, from (device sample counter, host
// arrival time) of every batch that carries an arrival time.
//
// Arrival = emission + latency, and latency is never negative: USB polling,
// the kernel and a busy host only ever make data late, in bursts. So every
// arrival lies on or above the line of emission times, and the device clock
// is the line that supports the arrivals from below: the edge of their lower
// convex hull above the arrivals' mean counter (the line under every arrival
// with the least total lateness; the linear-programming estimator of clock
// skew). A busy spell of any length only adds arrivals above the hull, so it
// cannot tilt the line; a least-squares line through per-window minima could
// be tilted by a spell longer than a window. The slope is the device's real
// sample period: a part sold as 2000 Hz that runs at 2010 Hz shows +5000 ppm.
// The jitter is the RMS of each arrival's lateness over its window's
// least-late one (one second of device time per window).
//
// The host clock is the reference: its own error (NTP-disciplined, usually
// well under 10 ppm) bounds what a rate error can mean; a host clock stepped
// backwards (an arrival earlier than physics allows) is the one thing that
// moves the hull, and shows as a large RateSigmaHz(). Memory: one window of
// arrivals, and the hull of the windows' least-late arrivals (a few dozen
// points for random latencies; at most one per window). Pure; not
// thread-safe.
#ifndef IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
#define IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_

#include <cstdint>
#include <vector>

namespace imuqual::analyze {

class DeviceClockFit {
 public:
  // `nominal_rate_hz` > 0; `window_s` of device time per window.
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
  // 1-sigma standard error of RateHz(): the scatter of the windows'
  // least-late arrivals about the line, as a least-squares line through
  // them would have it (the supporting line is at least as precise when
  // latencies are random; a busy spell widens this, never the line).
  double RateSigmaHz() const;
  // RMS lateness of arrivals over their window's least-late one, seconds.
  double JitterRmsS() const;

 private:
  struct Point {
    double x, y;
  };
  // Co-moments of the windows' least-late arrivals (Welford-style).
  struct Moments {
    int64_t n = 0;
    double mean_x = 0, mean_y = 0, sxx = 0, syy = 0, sxy = 0;
    double min_x = 0, max_x = 0;
    void Add(double x, double y);
  };
  struct State {
    Moments minima;            // y is seconds minus x * tau0
    std::vector<Point> hull;   // lower convex hull of the minima, x rising
    double sum_x = 0;          // of every arrival, for the hull edge
    int64_t n = 0;
    // Each arrival against its window's least-late one (dx, dy): the
    // lateness along a slope s is dy - s dx, so its sum of squares is
    // syy - 2 s sxy + s^2 sxx, evaluated with the final slope.
    double dyy = 0, dxy = 0, dxx = 0;
    // The slope (seconds per sample, minus tau0) of the hull edge above the
    // arrivals' mean counter; 0 while the hull has one point.
    double Slope() const;
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
