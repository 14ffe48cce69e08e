// The points of an ADEV or OADEV curve that a noise-model fit uses, with what
// their statistics need: shared by the IEEE 952 weighted fit (noise_model.h)
// and the composite-model fit (gmwm.h). Pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_FIT_ROWS_H_
#define IMUQUAL_ANALYZE_ALLAN_FIT_ROWS_H_

#include <cstdint>
#include <vector>

#include "analyze/allan/curve.h"

namespace imuqual::allan {

struct FitRow {
  int64_t m = 0;
  double tau_s = 0;
  double avar = 0;            // dev^2
  int64_t n_eff = 0;          // phase points spanned by the valid terms
  int64_t stride = 1;         // samples between consecutive terms
  double point_edf = kNaN;    // the curve's own edf, if any
  bool identified = false;    // that edf comes from a noise identification (alpha)
  double local_slope = kNaN;  // d ln AVAR / d ln tau of the measured curve
};

// The usable points (m within the stop rule, n > 1, positive finite dev and
// tau), ascending m, duplicates dropped, optionally thinned to about one per
// octave (the first point, then each with m >= 2 x the last kept). The
// stride is the point's own (the streaming cascade takes every (m/c)-th
// term), else the deviation's convention (1 OADEV, m ADEV); the local slope
// is to both neighbours (one at the ends; NaN with one point).
std::vector<FitRow> UsableFitRows(const Curve& curve, StopRule stop, bool thin_to_octaves);

// alpha from an AVAR slope mu = -alpha - 1, clamped to [-2, 1]: a slope cannot
// tell white from flicker phase noise, and alpha = 1 is the conservative one.
int AlphaFromAvarSlope(double mu);

// Greenhall edf of an AVAR point (d = 2, F = m, S = m / stride), or the
// non-overlapped cluster count - 1 where Greenhall is undefined.
double FitRowEdf(int alpha, const FitRow& row);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_FIT_ROWS_H_
