// The device's clock against the host's, from (device sample counter, host
// arrival time) of every batch that carries an arrival time.
//
// Arrival = emission + latency, and latency is never negative: USB polling,
// the kernel and a busy host only ever make data late, in bursts. So every
// arrival lies on or above the line of emission times. Each window of device
// time (one second) keeps its least-late arrival, and the device clock is
// the line that supports those from below with the least total lateness:
// the edge of their lower convex hull above the arrivals' mean counter (the
// linear-programming estimator of clock skew). A busy spell inside the run
// only adds points above the hull, so it cannot tilt the line; a
// least-squares line through the window minima was tilted by a spell longer
// than a window. The slope is the device's real sample period: a part sold
// as 2000 Hz that runs at 2010 Hz shows +5000 ppm. The jitter is the RMS of
// each arrival's lateness over its window's least-late one.
//
// The host clock is the reference: its own error (NTP-disciplined, usually
// well under 10 ppm) bounds what a rate error can mean. What can still move
// the line: an arrival earlier than physics allows (the host clock stepped
// backwards), and a spell that lasts from the run's start or to its end past
// the mean counter (a forward clock step looks the same); both show in
// RateSigmaHz(). Memory: one window of arrivals and one point per window
// (16 bytes a second). Pure; not thread-safe.
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
  // latencies are random), over the windows whose lateness above the line is
  // within 5 robust sigma of the median one (a busy spell's windows lie far
  // above the line and do not widen it).
  double RateSigmaHz() const;
  // RMS lateness of arrivals over their window's least-late one, seconds.
  double JitterRmsS() const;

 private:
  struct Point {
    double x, y;
  };
  struct State {
    std::vector<Point> hull;   // lower convex hull of the windows' minima
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
  // Folds a window's points into *s; returns its least-late arrival.
  static Point Close(const std::vector<Point>& window, State* s);
  // The state with the open window folded in, and that window's least-late
  // arrival into *open_best when asked for (false when no window is open).
  State Current(Point* open_best = nullptr, bool* has_open = nullptr) const;
  // Every window's least-late arrival, x rising: the closed ones, then the
  // open one's. Calls f(point) for each, without copying.
  template <typename F>
  void ForEachMinimum(const Point* open_best, F&& f) const {
    for (const Point& p : minima_) f(p);
    if (open_best != nullptr) f(*open_best);
  }
  double Slope() const;  // seconds per sample

  double tau0_s_;
  double window_samples_;
  int64_t points_ = 0;
  int64_t c0_ = 0, u0_ = 0;  // origin, for precision
  int64_t window_ = -1;      // index of the open window
  std::vector<Point> open_;
  State closed_;
  std::vector<Point> minima_;  // closed windows' least-late arrivals; y is
                               // seconds minus x * tau0
};

}  // namespace imuqual::analyze

#endif  // IMUQUAL_ANALYZE_SERVICE_DEVICE_CLOCK_H_
