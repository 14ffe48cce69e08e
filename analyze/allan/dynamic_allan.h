// The dynamic Allan deviation (DAVAR; L. Galleani and P. Tavella, "The
// dynamic Allan variance", IEEE Trans. UFFC 56(3), 2009): the overlapping
// Allan deviation of windows of the record sliding along it, each window
// analysed as a record of its own (exact, fully overlapped, octave grid, the
// bins-9 stop, 1-sigma chi-square intervals with the Greenhall edf of the
// identified noise; invalid samples are gaps, as everywhere). A stationary record gives the same curve in every window
// within the curves' intervals; a bias step, a warm-up ramp or a burst lifts
// the windows that hold it at the taus it spans, and a change of the noise
// itself moves the short taus. Pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_DYNAMIC_ALLAN_H_
#define IMUQUAL_ANALYZE_ALLAN_DYNAMIC_ALLAN_H_

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "analyze/allan/curve.h"
#include "common/status.h"

namespace imuqual::allan {

struct DynamicAllanOptions {
  // Window length, s; 0: a quarter of the record.
  double window_s = 0;
  // Step between window starts, s, at most the window; 0: a quarter of the
  // window. Widened when the record would hold more than kMaxWindows.
  double step_s = 0;
  // Chi-square intervals on each window's curve (a plot of the curves alone
  // does without).
  bool intervals = true;
  static constexpr int kMaxWindows = 200;
  // Ok, or InvalidArgument naming the field (negative or not finite, a step
  // longer than the window).
  Status Validate() const;
};

struct DynamicAllanWindow {
  double start_s = 0;   // from the record's first sample
  double length_s = 0;  // window_s
  int64_t valid_samples = 0;
  Curve curve;  // OADEV of the window's samples
};

struct DynamicAllan {
  double tau0_s = 0;
  double window_s = 0;  // whole samples
  double step_s = 0;    // whole samples
  // From the record's start, every step_s, while the window fits; the last
  // one ends at the record's end (so every sample is in some window). A
  // window inside a gap has a curve without points.
  std::vector<DynamicAllanWindow> windows;
};

// `rate`: the record's rate samples, NaN (or a non-zero `invalid` entry)
// where a sample is invalid or missing; `invalid` is empty or as long as
// `rate`. Errors (InvalidArgument, naming what): tau0 not positive, bad
// options, a window of fewer than 64 samples or longer than the record, a
// step of less than one sample.
Result<DynamicAllan> ComputeDynamicAllan(std::span<const float> rate, double tau0_s,
                                         std::span<const uint8_t> invalid = {},
                                         const DynamicAllanOptions& options = {});
Result<DynamicAllan> ComputeDynamicAllan(std::span<const double> rate, double tau0_s,
                                         std::span<const uint8_t> invalid = {},
                                         const DynamicAllanOptions& options = {});

// How much the noise level at the shortest tau changed from the first
// window to the last (each the first and last window with a point at that
// tau): ratio = dev_last / dev_first and its 1-sigma from the two points'
// chi-square errors (Greenhall edf for white FM, the shortest tau's usual
// noise; the windows are independent when they do not overlap, as the
// defaults' first and last quarter). A ratio many sigmas from 1 is a
// change of the noise itself, which a level-step scan does not look for.
// nullopt without two such windows.
struct LevelChange {
  double tau_s = 0;
  double first_start_s = 0, last_start_s = 0;
  double ratio = 0;
  double sigma = 0;
};
std::optional<LevelChange> ShortTauLevelChange(const DynamicAllan& davar);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_DYNAMIC_ALLAN_H_
