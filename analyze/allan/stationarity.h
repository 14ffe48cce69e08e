// Is a record stationary? A scan for the events an Allan curve would average
// into its noise figures: level steps (a bias jump, a
// knock, a power glitch) and bursts (a stretch whose level departs and comes
// back: a tilt, a shock, a warm spell), on each axis and on the axes of one
// kind together (a unit-wide event moves several axes at once). A change
// of the noise level is ScanNoiseLevel's (below).
//
// The record is cut into bins of b seconds (bin means of the valid samples;
// a bin with fewer than half its samples valid is missing). The first
// differences of the bin means, d_i = ybar_{i+1} - ybar_i, are second
// differences of the phase x(t) = int y: for every noise of the composite
// model (composite_model.h) they are stationary with covariance
//   C(L) = -1/(2 b^2) sum_{p,q in 0..2} c_p c_q D(|L + q - p| b),  c = (1, -2, 1),
// from the phase structure function D(s) = E[(x(t+s) - x(t))^2] of each term:
//   Q      2 Q^2 (s > 0)                 N   N^2 s
//   B      -(B^2/pi) s^2 ln s            K   -(K^2/6) s^3
//   GM     Nw^2 (s - T (1 - e^(-s/T))), Nw^2 = sigma^2 tau0 (1+phi)/(1-phi)
//   sine   A^2 (1 - cos 2 pi f s) / (4 pi^2 f^2)  (random phase)
// (each reproduces its AVAR (4 D(tau) - D(2 tau)) / (2 tau^2); a ramp R is a
// constant in d, fitted as a nuisance when the model has one: a ramp the
// model does not have is itself an event, e.g. a warm-up). In d a level step between bins k-1
// and k is one impulse at k-1, a burst on bins [k, k+w) an impulse pair
// (+1 at k-1, -1 at k+w-1): each a regressor g tested by generalized least
// squares under C with the nuisances X (the ramp's constant, then every
// accepted event): with P = C^-1 and r the GLS residual of d on X,
//   z = g'P r / sqrt(g'P g - g'P X (X'P X)^-1 X'P g),
// standard normal for a stationary record of the axis's model. Candidates:
// every boundary and every bin's middle (steps: a step inside bin k moves
// that bin's mean by part of it, +1/2 at k-1 and k for one at its middle;
// with boundaries alone a step between them reads as two half steps) and
// bursts of w = 1, 2, 4, ... bins up to a ninth
// of the record (the bins-9 stop: the longest tau the model was fitted to);
// joint: the group's sum of z^2 at one candidate over the axes with data
// there, chi-square with as many degrees of freedom (A when none misses it).
// The record's smallest p over every candidate of every family
// (each axis alone, and the joint family when A > 1) is compared with a
// threshold calibrated on M = 10 / false_alarm - 1 records drawn from the
// models (each axis independent, differences with covariance C at the
// present bins): the r-th smallest of their smallest p, r = floor((M + 1)
// false_alarm), so a record of the models reports an event with probability
// r / (M + 1), `false_alarm` itself, in expectation over the calibration
// (the draws have a fixed seed: one threshold's own rate is within about
// +-1/sqrt(r), 32 %, of it; 3x the draws would bring that to 18 % at 3x the
// cost of every scan whose draws are not cached), whatever the
// correlations between the
// candidates (Bonferroni over them is only a bound, well above the rate of
// correlated candidates; stationarity_test measures the rate). The draws
// depend on the models, the bins and the missing bins only, and are cached
// for the process (a station's runs under one plan's models share them). The
// strongest candidate below the threshold is an event; its regressor joins X
// on every axis of the group and the scan repeats with the same threshold
// (at most max_events). At the end every event's size (the level change,
// after - before, rate units) and 1-sigma are the joint GLS estimate with
// all events. A joint event names the axes whose own two-sided p is below
// 1 % (else the axis of the largest |z|). Missing bins are bridged: the
// differences are those of consecutive present bins (their covariance from
// D at the four phase points of each), so a level change while the record
// was missing (a unit reset in a lost stretch) is one difference, found
// like any step, its time the span of the gap; a burst inside a gap is not
// seen.
//
// The model is a reference from outside the record (a plan's, judge/
// stationarity_measure.h: the level holds for a unit whose noise it is, and
// bounds the rate of a quieter one) or the axis's own fitted composite model
// (gmwm.h), which is not fit for a verdict: the level holds for the true
// model; with a model fitted to the same one-hour record it does not, and
// what fits the record decides what the scan can see. 40 one-hour records of each simulator profile
// (stationarity_bench; false alarms per record, both groups; steps of 3 sd
// of the 100 s bin means found) for vg700 / tactical / fog / mems-lab /
// mems-real:
//   true model, Bonferroni:         0 / 2.5 / 0 / 2.5 / 0 %;  100 / 55 / 78 / 70 / 50 %
//   true model, calibrated:         0 / 2.5 / 2.5 / 2.5 / 0 %; 100 / 63 / 80 / 73 / 53 %
//   selected model, calibrated:     0 / 50 / 5 / 33 / 8 %;    100 / 43 / 45 / 63 / 25 %
//   most wander (FitModelForScan's `most_wander`), calibrated:
//                                   0 / 5 / 0 / 2.5 / 0 %;    98 / 28 / 3 / 58 / 8 %
//   the profile's typical unit's model (units spread 15 % per term):
//                                   15 / 30 / 20 / 23 / 25 %;  100 / 63 / 80 / 78 / 58 %
// A selection that leaves out a flicker floor or random walk which the
// record barely shows (a parsimonious model on a 1 h curve) makes the
// scan read that wander as steps; the candidate with the most wander the
// curve allows stops the false alarms, but a step inflates the curve's
// long-tau end like a random walk K ~ size / sqrt(T), so candidates with
// such a K pass the J test and then explain the step away. A one-hour
// record alone cannot tell a 3-sigma step from a random walk it cannot
// exclude; the model has to come from elsewhere (a lot's pooled model, a
// part's qualified model). Even the true model finds a 3-sigma step in a 1 h
// record only 53-80 % of the time on four profiles (its GLS z is about 4.6
// on a tactical gyro): 90 % needs a larger step or a longer record. Pure and
// thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_STATIONARITY_H_
#define IMUQUAL_ANALYZE_ALLAN_STATIONARITY_H_

#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/allan/curve.h"
#include "analyze/allan/phase.h"
#include "common/status.h"

namespace imuqual::allan {

enum class EventKind { kStep, kBurst };
// "step" or "burst".
std::string_view EventKindName(EventKind kind);

struct StationarityOptions {
  // Bin length, s; 0: the record's length / 300 (whole samples, at least one).
  double bin_s = 0;
  // A record of fewer bins is not scanned (too short to tell an event from
  // its noise); >= 16.
  int min_bins = 32;
  // The probability that a stationary record of the models (all axes of the
  // group, both kinds) reports any event, in (0, 0.5).
  double false_alarm = 0.01;
  // Events reported at most, >= 1.
  int max_events = 8;
  // Scans at most (ScanStationarityRefitting), >= 1.
  int passes = 3;

  // Ok, or InvalidArgument naming the field.
  Status Validate() const;
};

// One axis's reading of an event.
struct EventAxis {
  double size = kNaN;   // the step's or burst's size, rate units (after - before)
  double sigma = kNaN;  // 1-sigma of size under the axis's noise model
  double z = kNaN;      // at detection (before the later events joined the nuisances)
  bool named = false;   // the event is on this axis
  // A step in missing bins of this axis: its boundary is anywhere in
  // [gap_from_s, gap_to_s] (s from the record's first sample); NaN otherwise.
  double gap_from_s = kNaN;
  double gap_to_s = kNaN;
};

struct StationarityEvent {
  EventKind kind = EventKind::kStep;
  // Step: the boundary; burst: the start of the departing window. Seconds
  // from the record's first sample.
  double time_s = kNaN;
  // The window on each side (step) or the departing stretch (burst), s.
  double window_s = kNaN;
  bool joint = false;           // found by the group's joint test
  double p_adjusted = kNaN;     // with the multiplicity of the whole scan
  std::vector<EventAxis> axes;  // one per input axis, in order
};

struct StationarityScan {
  bool scanned = false;  // false: too short (see note)
  std::string note;      // why not scanned
  double bin_s = kNaN;
  int bins = 0;
  int tests = 0;  // candidates per axis (steps and bursts)
  double false_alarm = kNaN;
  double threshold_p = kNaN;              // a candidate's p below this is an event (calibrated)
  std::vector<StationarityEvent> events;  // in the order found (strongest first)
  int passes = 0;                         // scans made (ScanStationarityRefitting)
  std::vector<std::string> models;        // each axis's noise model of the last scan
};

// Scans the axes (rate samples, NaN where invalid, all of one length and of
// one sample interval tau0_s; models[a] is axis a's noise model in the same
// rate unit) as one group. Errors: no axis, unequal lengths or model count,
// tau0 not positive, bad options, a model whose covariance is not positive
// definite at these bins.
Result<StationarityScan> ScanStationarity(const std::vector<std::span<const double>>& axes,
                                          const std::vector<CompositeModel>& models, double tau0_s,
                                          const StationarityOptions& options = {});

// A scan of more bins is not made (its covariance matrices would take
// hundreds of MB and its factorisation minutes): the note says so.
inline constexpr int kMaxScanBins = 2000;

// The same scan of bin means already formed (means[a][i]: axis a's mean
// over bin i of bin_s seconds, NaN where fewer than half its samples were
// valid), e.g. accumulated while the record streamed in. tau0_s is the
// samples' interval (the models' short-tau terms depend on it).
Result<StationarityScan> ScanBinMeans(const std::vector<std::vector<double>>& means,
                                      const std::vector<CompositeModel>& models, double tau0_s,
                                      double bin_s, const StationarityOptions& options = {});

// A noise model of one axis's record, as the caller fits it.
using StationarityModelFit =
    std::function<Result<CompositeModel>(std::span<const double> rate, double tau0_s)>;

// The fit the scan uses unless told otherwise: the octave OADEV to the
// bins-9 stop, Greenhall edf of the identified noise, the composite fit
// without bootstrap or absent-term bounds. `most_wander` (the default):
// of the candidates the J test accepts, the one with the most random
// variance at a third of the record (a ramp not counted), which keeps the
// false alarms at the level but also explains many real steps away; else
// the selected model, which sees more steps and raises false alarms (the
// figures above).
Result<CompositeModel> FitModelForScan(std::span<const double> rate, double tau0_s,
                                       bool most_wander = true);
// The same from an OADEV curve of the record already computed (any grid to
// the bins-9 stop; its n_phase gives the record's length).
Result<CompositeModel> FitModelForScan(const Curve& curve, bool most_wander = true);

// The scan with models fitted by `fit`. A step of size s in a record of
// length T reads on the Allan curve as a random walk K ~ s / sqrt(T): a
// model fitted through an event is inflated by it and hides it (and any
// other). So while a scan finds events, each axis's model is refitted to its
// record with the events found taken out (RemoveEvents) and the original
// record scanned again, until the events stop changing or `options.passes`
// scans were made. A record whose first scan finds nothing is not scanned
// again, so the false-alarm rate is the first scan's. What this cannot do:
// a single step large enough to dominate the record's long-tau curve is
// fitted as random walk by the first model and then not found (the figures
// above).
Result<StationarityScan> ScanStationarityRefitting(
    const std::vector<std::span<const double>>& axes, double tau0_s,
    const StationarityOptions& options = {},
    const StationarityModelFit& fit = [](std::span<const double> r, double t) {
      return FitModelForScan(r, t);
    });

// Axis `axis` of the scan's record with its events' fitted sizes taken out
// (a step from its time on, a burst over its window), in place.
void RemoveEvents(const StationarityScan& scan, int axis, double tau0_s, std::span<double> rate);

// Means of `bins` consecutive bins of `bin_samples` samples each; a bin
// with fewer than half its samples finite is NaN.
std::vector<double> BinMeans(std::span<const double> rate, int64_t bin_samples, int bins);

// How many of `means` (bin means, NaN for a bin without data) hold data.
int BinsWithData(std::span<const double> means);

// Per bin of `bin_samples` samples: the mean square of the differences of
// successive valid samples (a difference belongs to the bin of its later
// sample; there is none across an invalid or missing sample); NaN where
// fewer than half the bin's samples end one.
std::vector<double> BinMeanSquareDifferences(std::span<const double> rate, int64_t bin_samples,
                                             int bins);

// A change of an axis's noise level (its short-tau noise: white noise and
// quantization rule the differences of successive samples, the wander of
// flicker, random walk and a slow Gauss-Markov barely moves them). The
// logarithms x_i of the bins' mean square differences are, for a
// stationary record, nearly independent with a common mean, whatever the
// noise model; their CUSUM S_k = sum_{i<k} (x_i - xbar) over the n present
// bins, scaled by s sqrt(n) (s^2 from successive differences of x, which a
// change barely moves), has max_k |S_k| / (s sqrt(n)) -> sup |Brownian
// bridge| (Kolmogorov's distribution); for a finite record its p is read
// from kNoiseLevelDraws records of n independent Gaussian x drawn for the
// purpose (cached per n; Kolmogorov's limit would be conservative, 2.5 %
// at 5 % for 300 bins, as the discrete maximum is below the supremum). The
// change is at the largest |S_k|; its size is
// the noise amplitude after over before, sqrt of the ratio of the
// geometric mean squares, with the 1-sigma s sqrt(1/k + 1/(n-k)) / 2 of its
// logarithm. A gradual drift of the level reads as one change near its
// middle. What it does not see: a change in the wander alone.
inline constexpr int kNoiseLevelDraws = 9999;
struct NoiseLevelChange {
  bool scanned = false;  // false: too few bins (see note)
  std::string note;
  int bins = 0;                   // present bins scanned
  double statistic = kNaN;        // max |S_k| / (s sqrt(n))
  double p = kNaN;                // the drawn records' tail at the statistic
  double time_s = kNaN;           // the change's bin boundary, s from the record's first sample
  double ratio = kNaN;            // noise amplitude after / before
  double ratio_sigma = kNaN;      // its 1-sigma
  bool significant = false;       // p < the level
  bool beyond_tolerance = false;  // ratio outside [1 / (1 + tol), 1 + tol]
  bool found() const { return significant && beyond_tolerance; }
};
// mean_square: BinMeanSquareDifferences (NaN: missing); bins of bin_s
// seconds. Errors: a level outside (0, 0.5), a negative tolerance, bin_s
// not positive.
Result<NoiseLevelChange> ScanNoiseLevel(std::span<const double> mean_square, double bin_s,
                                        double false_alarm, double tolerance, int min_bins = 32);

// Bin sums of a record as it streams in, for ScanBinMeans without keeping
// the samples: base bins of `base_samples` samples each (the sum and count
// of the valid samples, the sum and count of the squared differences of
// successive valid samples, and every sample's place, valid or not), two
// merged into one whenever there would be more than kMaxBaseBins. Not
// thread-safe.
class BinAccumulator {
 public:
  static constexpr int64_t kMaxBaseBins = 1 << 18;
  explicit BinAccumulator(int64_t base_samples = 1);
  // Samples in order; invalid[i] != 0 or a non-finite value: not valid.
  void Append(std::span<const float> values, std::span<const uint8_t> invalid);
  // Samples that never arrived.
  void AppendMissing(int64_t count);
  int64_t samples() const { return samples_; }
  int64_t base_samples() const { return base_; }
  // Means of the whole bins of `*bin_samples` samples (rounded to a
  // multiple of the base, at least one base bin; the value used is written
  // back), NaN where fewer than half the bin's samples were valid; a partial
  // last bin is left out.
  std::vector<double> Means(int64_t* bin_samples) const;
  // The bins' mean square differences (BinMeanSquareDifferences), the bin
  // length rounded to whole base bins as Means rounds it.
  std::vector<double> MeanSquareDifferences(int64_t bin_samples) const;
  // The phase of the base bins' means at interval base_samples() tau0_s
  // (every base_samples()-th point of the samples' phase), over the whole
  // base bins inside samples [begin, end); a base bin with an invalid or
  // missing sample is a gap, a partial one at either end left out. What a
  // Theo1 moment of means is computed on (long_tau.h, Theo1Moment::block).
  PhaseRecord MeansPhase(double tau0_s, int64_t begin = 0, int64_t end = INT64_MAX) const;

 private:
  void Merge();
  // Base bins per bin of about `bin_samples` samples (at least one).
  int64_t BaseBinsPer(int64_t bin_samples) const;
  // Per whole bin of `per` base bins: sum(num) / sum(den), NaN where
  // sum(den) is under half the bin's samples.
  std::vector<double> Pooled(const std::vector<double>& num, const std::vector<int64_t>& den,
                             int64_t per) const;
  int64_t base_;
  int64_t samples_ = 0;
  bool has_last_ = false;  // the last sample was valid
  double last_ = 0;
  std::vector<double> sum_;     // per base bin
  std::vector<int64_t> valid_;  // per base bin
  std::vector<double> square_;  // per base bin: squared differences
  std::vector<int64_t> diffs_;  // per base bin
};

// The phase structure function D(s) of the model (above), s > 0 seconds,
// rate unit^2 s^2. Exposed for tests.
double PhaseStructureFunction(const CompositeModel& model, double tau0_s, double s);

// What a found event cuts from a record when the longest stationary stretch
// is judged: a step in missing data its missing stretch, a step its time, a
// burst from its start to its end, each widened by `margin_s` either side
// (a scan bin: the scan places an event to within its bins). `a` is the
// event's entry for the axis cut.
std::pair<double, double> EventCut(const StationarityEvent& e, const EventAxis& a, double margin_s);

// The longest stretch [begin_s, end_s) of a record of `length_s` seconds that
// no event of the scan touches on the given axis (all axes: axis < 0), each
// event cut as EventCut with no margin.
struct Segment {
  double begin_s = 0;
  double end_s = 0;
};
Segment LongestStationarySegment(const StationarityScan& scan, double length_s, int axis = -1);
// The stretches of [0, length_s) that no cut [from_s, to_s] (a point when
// equal) touches, in time order, clipped to the record; the longest of them
// (the earliest of equal ones).
std::vector<Segment> UncutStretches(std::vector<std::pair<double, double>> cuts, double length_s);
Segment LongestUncutStretch(std::vector<std::pair<double, double>> cuts, double length_s);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_STATIONARITY_H_
