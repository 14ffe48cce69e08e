// A lot's noise model and the units that do not belong to it.
//
// Pooling (the multi-signal wavelet variance of Bakalli, Radi, Guerrier et
// al., IEEE TIM 2019, with the units of a lot as the replicates): at every
// octave averaging factor m that every unit's curve has, the lot's AVAR is
// the mean of the units' AVARs,
//   nu_lot(m) = (1/K) sum_k avar_k(m).
// The mean of the units' AVARs of any of the composite terms is the AVAR of
// the same term with the mean square scale (N_lot^2 = mean N_k^2, and a Gauss-
// Markov mixture stays one where the units share T), so the lot curve is in
// the model family and the composite model (gmwm.h) fitted to it, as one
// record of K times the samples, is the lot model: its J test says whether
// the family holds for the lot, its sigmas are the precision of the lot-mean
// curve from these records (not the spread of the production, which is the
// between-unit sd of ln AVAR at each tau, reported beside it).
// Consistency: a unit belongs to the lot when, at every pooled tau, its
// ln AVAR lies within the others' prediction interval: with the other K-1
// units' mean m and sd s of ln AVAR,
//   t = (ln avar_k - m) / (s sqrt(1 + 1/(K-1)))  ~  Student t, K-2 dof,
// and the unit's p-value is the smallest two-sided p over the taus times
// their number (Bonferroni). Below the level the unit is flagged, with the
// tau where it departs most and by what factor on the deviation, and left
// out of the pooled curve: the lot model is the model of the units that
// belong to the lot (a planted failing unit made the simulated vg700 lot's
// pooled curve a mixture, "inadequate" at p = 8e-5 on x; without it p =
// 0.63), with the all-units fit kept for the record.
// Pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_LOT_MODEL_H_
#define IMUQUAL_ANALYZE_ALLAN_LOT_MODEL_H_

#include <string>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/gmwm.h"
#include "common/status.h"

namespace imuqual::allan {

struct UnitCurve {
  std::string unit;  // e.g. the serial
  Curve curve;       // OADEV or ADEV, same tau0 for every unit
};

struct LotModelOptions {
  GmwmOptions fit;  // edf_from_curve is forced on
  // A unit whose consistency p-value is below this level is flagged, in (0, 1).
  double consistency_level = 0.01;
  // Fewer units give no spread to judge by (the t test needs K - 2 >= 2).
  int min_units = 4;

  Status Validate() const;
};

struct LotPoint {
  int64_t m = 0;
  double tau_s = kNaN;
  double mean_dev = kNaN;   // sqrt of the lot's mean AVAR
  double model_dev = kNaN;  // the lot model
  double spread_factor =
      kNaN;  // exp(sd of ln AVAR / 2): the units' 1-sigma factor on the deviation
};

struct UnitConsistency {
  std::string unit;
  double p_value = kNaN;  // Bonferroni over the pooled taus
  bool consistent = true;
  double worst_tau_s = kNaN;   // where the unit departs most
  double worst_factor = kNaN;  // its deviation there / the other units' geometric mean
};

struct LotModel {
  int units = 0;                 // units pooled into the model
  std::vector<LotPoint> points;  // over the pooled units
  CompositeFit fit;  // the lot model (sigmas: the precision of the lot-mean model)
  std::vector<UnitConsistency> consistency;  // every unit, in input order
  // Units inconsistent with their lot, left out of the model (input order);
  // empty when every unit is pooled (all consistent, or fewer than half or
  // than 2 consistent: no majority to model).
  std::vector<std::string> left_out;
  // With units left out: the model every unit pooled would have had, its J
  // and p (the mixture the left-out units make), for the record.
  std::string all_units_model;
  double all_units_objective = kNaN;
  double all_units_p_value = kNaN;
};

// Errors: bad options, fewer than min_units curves, curves of different
// deviation kinds or tau0, fewer than 4 averaging factors common to all, or
// no model could be fitted.
Result<LotModel> FitLotModel(const std::vector<UnitCurve>& units,
                             const LotModelOptions& options = {});

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_LOT_MODEL_H_
