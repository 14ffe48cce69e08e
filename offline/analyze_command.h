// `imuqual analyze FILE`: offline Allan analysis of a recorded series (one
// value per line, or CSV with a header and a chosen column), with every
// estimator, grid, stop rule and confidence interval of the analysis core,
// the composite noise-model fit (analyze/allan/gmwm.h) beside the slope-line
// read-offs, and an SVG plot.
#ifndef IMUQUAL_OFFLINE_ANALYZE_COMMAND_H_
#define IMUQUAL_OFFLINE_ANALYZE_COMMAND_H_

#include <limits>
#include <string>

namespace imuqual::offline {

struct AnalyzeFileOptions {
  std::string path;
  std::string column;           // CSV column (required if several)
  double rate_hz = std::numeric_limits<double>::quiet_NaN();  // sample rate: required
  bool rate_given = false;                                     // --rate was given
  std::string type = "rate";    // "rate" (deg/s, m/s^2, fractional frequency) or "phase"
  std::string devs = "oadev";   // comma list of adev, oadev, mdev, tdev, hdev, ohdev, totdev
  std::string grid = "octave";  // octave, decade, all, logN, or explicit taus "1,2,5"
  std::string stop = "bins9";   // bins9, stable32, none
  std::string ci = "none";      // none, simple, chi2
  double confidence = 0.682689492137086;
  bool fit = false;  // composite noise model and slope-line read-offs
  double fit_min_tau_s = 0;  // points below it are not fitted (a sensor filter's range)
  // With fit: Theo1 beyond the fitted curve's last tau against the model's
  // expectation of it (does the model hold where OADEV does not reach?).
  bool long_tau_check = false;
  // With fit: Theo1 at octaves beyond the curve's last tau joins the fit as
  // moments (E[Theo1] under the model), so the model follows the record to
  // 0.3 of its length instead of the stop rule's reach.
  bool fit_long_taus = false;
  // Scan the series for level steps and bursts (analyze/allan/stationarity.h)
  // at this false-alarm level per record; 0: no scan.
  double stationarity_level = 0;
  // With stationarity_level: scan against this plan's reference model of
  // --kind (plan.proto Stationarity) instead of the series' own model.
  std::string stationarity_plan;
  // With stationarity_level: the curves, fit and read-offs are the longest
  // stretch's that no found event touches.
  bool judge_longest_segment = false;
  std::string kind;  // gyro, accel or "" (units of the fit report)
  // The values' unit (a gyro's deg/s, rad/s, mrad/s, deg/h, rpm; an
  // accelerometer's m/s^2, g, mg, ug; needs kind) and a factor (an LSB):
  // values x scale x unit-to-base are analysed in deg/s or m/s^2.
  std::string unit;
  double scale = 1.0;
  std::string format = "table";  // table, csv, json
  std::string plot_path;         // SVG output, "" for none
  // The dynamic Allan deviation's SVG plot ("" for none) and its window, s
  // (0: a quarter of the record; allan/dynamic_allan.h).
  std::string davar_path;
  double davar_window_s = 0;
};

int AnalyzeFileCommand(const AnalyzeFileOptions& options);

}  // namespace imuqual::offline

#endif  // IMUQUAL_OFFLINE_ANALYZE_COMMAND_H_
