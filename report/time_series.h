// Time-series plots of a run's raw samples: each axis's rate and the unit's
// temperature against device time, decimated into at most a few hundred bins
// with the min/max envelope and the mean of each bin, as self-contained SVG
// (no scripts, no ids, every text escaped). What an engineer looks at first
// when a unit FAILs: a bias step, a drift, a burst of outliers, a temperature
// ramp, a stretch of missing samples.
#ifndef IMUQUAL_REPORT_TIME_SERIES_H_
#define IMUQUAL_REPORT_TIME_SERIES_H_

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/status.h"
#include "store/archive.h"

namespace imuqual::report {

// One bin of consecutive device counters [first, first + width).
struct EnvelopeBin {
  int64_t first = 0;
  std::vector<double> min, max, sum;  // per channel
  std::vector<int64_t> n;             // values per channel (0: none in this bin)
};

// Streams values per device counter into bins of equal width (a power of two
// of counters), at most `max_bins` of them: when the record outgrows them,
// neighbouring bins merge and the width doubles, so one pass with O(max_bins)
// memory covers a record of any length, and the bins do not depend on how
// the samples were batched. Counters must not go back.
class EnvelopeBuilder {
 public:
  EnvelopeBuilder(size_t channels, size_t max_bins);
  // The values at `counter`, one per channel; NaN: none for that channel.
  void Add(int64_t counter, std::span<const double> values);
  int64_t width() const { return width_; }
  int64_t first() const { return first_; }
  size_t channels() const { return channels_; }
  // The bins from the first counter to the last one added; bins no value
  // fell in are present with n = 0 (a gap).
  const std::vector<EnvelopeBin>& bins() const { return bins_; }

 private:
  void Halve();
  size_t channels_, max_bins_;
  bool started_ = false;
  int64_t first_ = 0, width_ = 1;
  std::vector<EnvelopeBin> bins_;
};

// A stacked plot of panels sharing the time axis. A panel shows one
// channel, its values mapped to (v - offset) x scale: either the bin min..max
// band with the bin mean (the raw signal, outliers and all), or the bin mean
// alone on its own scale (the drift, which the band's noise would hide).
struct SeriesPanel {
  std::string label;  // y axis label with its unit, e.g. "gx [deg/s]"
  std::string color = "#1f77b4";
  size_t channel = 0;
  bool envelope = true;  // false: the bin mean only
  double offset = 0, scale = 1;
};
// An event the stationarity scan found on a channel, marked in that
// channel's panels: a step as a line at its time, a burst as a band over its
// stretch (seconds from the first sample), its label in the first of them.
struct EventMark {
  size_t channel = 0;
  double start_s = 0;
  double end_s = 0;  // == start_s: a step
  std::string label;
};
// The stretch a channel's axis was judged on when the plan judged its longest
// segment without events (and it was not the whole record): a green bar
// along the bottom of that channel's panels, seconds from the first sample.
struct JudgedStretch {
  size_t channel = 0;
  double start_s = 0;
  double end_s = 0;
  std::string label;
};
struct TimeSeriesPlot {
  std::string title;
  std::vector<EventMark> events;
  std::vector<JudgedStretch> judged;
  std::vector<SeriesPanel> panels;  // channels of `builder` (others skipped)
  double counters_per_second = 1;   // device rate
  std::vector<std::string> notes;   // lines under the plot
  // Seconds from the first sample that are shaded in every panel and named
  // (the plan's warm-up: recorded, not analysed); 0: none.
  double shaded_s = 0;
  std::string shaded_label = "warm-up (not analysed)";
  int width = 760;
  int panel_height = 120;      // an envelope panel
  int mean_panel_height = 80;  // a mean-only panel
  // The SVG for `builder`'s bins, breaks where a bin has no value; x in s,
  // min or h by length.
  std::string ToSvg(const EnvelopeBuilder& builder) const;
};

// The time-series plot of a stored run: per axis the raw rate (deg/s for
// gyros, m/s^2 for accelerometers, as archived) as a band with its mean, then
// the bin mean less the run's mean in datasheet units (deg/h, ug: the bias
// drift), and the temperature when the unit reported one; the plan's
// warm-up shaded; every event the run's stationarity scan found (its
// event_<k> measurements) marked on its axis. NotFound names the run, or
// says the run has no archived sample.
Result<std::string> RunTimeSeriesSvg(store::Archive& archive, const std::string& run_id);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_TIME_SERIES_H_
