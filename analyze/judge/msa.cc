#include "analyze/judge/msa.h"

#include <algorithm>
#include <cmath>

#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/students_t.hpp>

namespace imuqual::judge {
namespace {

// AIAG: an interaction this unlikely to be real is pooled into the error.
constexpr double kPoolAbove = 0.25;

double Sq(double x) { return x * x; }

}  // namespace

Result<MsaResult> AnalyzeMsa(const MsaStudy& s) {
  const size_t p = s.values.size();
  if (p < 2) return Status::InvalidArgument("an MSA needs at least 2 golden units");
  if (s.parts.size() != p) return Status::InvalidArgument("parts: names and values differ in count");
  const size_t o = s.stations.size();
  if (o < 2) return Status::InvalidArgument("an MSA needs at least 2 stations");
  size_t r = 0;
  for (size_t i = 0; i < p; ++i) {
    if (s.values[i].size() != o) {
      return Status::InvalidArgument("unit " + s.parts[i] + ": not measured on every station");
    }
    for (size_t j = 0; j < o; ++j) {
      const size_t n = s.values[i][j].size();
      if (r == 0) r = n;
      if (n != r) {
        return Status::InvalidArgument("unit " + s.parts[i] + " on " + s.stations[j] + ": " +
                                       std::to_string(n) + " trials, others " +
                                       std::to_string(r) + " (the study must be balanced)");
      }
      for (double v : s.values[i][j]) {
        if (!std::isfinite(v)) {
          return Status::InvalidArgument("unit " + s.parts[i] + " on " + s.stations[j] +
                                         ": a value that is not a number");
        }
      }
    }
  }
  if (r < 2) return Status::InvalidArgument("an MSA needs at least 2 trials of each unit on each station");

  MsaResult m;
  m.parts = static_cast<int>(p);
  m.stations = static_cast<int>(o);
  m.trials = static_cast<int>(r);
  const double P = static_cast<double>(p), O = static_cast<double>(o), R = static_cast<double>(r);
  std::vector<double> part_mean(p, 0), station_mean(o, 0);
  std::vector<std::vector<double>> cell(p, std::vector<double>(o, 0));
  double grand = 0;
  for (size_t i = 0; i < p; ++i) {
    for (size_t j = 0; j < o; ++j) {
      for (double v : s.values[i][j]) cell[i][j] += v / R;
      part_mean[i] += cell[i][j] / O;
      station_mean[j] += cell[i][j] / P;
      grand += cell[i][j] / (P * O);
    }
  }
  m.mean = grand;
  double ss_part = 0, ss_station = 0, ss_inter = 0, ss_error = 0;
  for (size_t i = 0; i < p; ++i) ss_part += O * R * Sq(part_mean[i] - grand);
  for (size_t j = 0; j < o; ++j) ss_station += P * R * Sq(station_mean[j] - grand);
  for (size_t i = 0; i < p; ++i) {
    for (size_t j = 0; j < o; ++j) {
      ss_inter += R * Sq(cell[i][j] - part_mean[i] - station_mean[j] + grand);
      for (double v : s.values[i][j]) ss_error += Sq(v - cell[i][j]);
    }
  }
  m.df_part = P - 1;
  m.df_station = O - 1;
  m.df_interaction = (P - 1) * (O - 1);
  m.df_error = P * O * (R - 1);
  m.ms_part = ss_part / m.df_part;
  m.ms_station = ss_station / m.df_station;
  m.ms_interaction = ss_inter / m.df_interaction;
  m.ms_error = ss_error / m.df_error;

  if (m.ms_error > 0) {
    const boost::math::fisher_f f(m.df_interaction, m.df_error);
    m.p_interaction =
        boost::math::cdf(boost::math::complement(f, m.ms_interaction / m.ms_error));
  } else {
    m.p_interaction = m.ms_interaction > 0 ? 0.0 : 1.0;
  }
  // The error term of stations and parts: the interaction, or with it
  // pooled, the pooled error.
  double ms_term = m.ms_interaction, df_term = m.df_interaction;
  double ms_repeat = m.ms_error;
  if (m.p_interaction > kPoolAbove) {
    m.interaction_pooled = true;
    ms_term = (ss_inter + ss_error) / (m.df_interaction + m.df_error);
    df_term = m.df_interaction + m.df_error;
    ms_repeat = ms_term;
  }
  const double ev2 = ms_repeat;
  const double int2 = m.interaction_pooled ? 0.0 : std::max(0.0, (m.ms_interaction - m.ms_error) / R);
  const double av2 = std::max(0.0, (m.ms_station - ms_term) / (P * R));
  const double pv2 = std::max(0.0, (m.ms_part - ms_term) / (O * R));
  m.ev = std::sqrt(ev2);
  m.av = std::sqrt(av2);
  m.interaction = std::sqrt(int2);
  m.grr = std::sqrt(ev2 + av2 + int2);
  m.pv = std::sqrt(pv2);
  m.tv = std::sqrt(ev2 + av2 + int2 + pv2);
  if (m.tv > 0) m.percent_grr_tv = 100 * m.grr / m.tv;
  if (m.grr > 0) m.ndc = static_cast<int>(std::floor(1.41 * m.pv / m.grr));
  if (s.low && s.high && *s.high > *s.low) {
    m.percent_grr_tolerance = 100 * 6 * m.grr / (*s.high - *s.low);
    m.tolerance_basis = "USL - LSL";
  } else if (s.high && *s.high != grand) {
    m.percent_grr_tolerance = 100 * 3 * m.grr / std::abs(*s.high - grand);
    m.tolerance_basis = "USL - mean";
  } else if (s.low && *s.low != grand) {
    m.percent_grr_tolerance = 100 * 3 * m.grr / std::abs(grand - *s.low);
    m.tolerance_basis = "mean - LSL";
  }
  const double judged = std::isfinite(m.percent_grr_tolerance) ? m.percent_grr_tolerance
                                                                : m.percent_grr_tv;
  m.verdict = !std::isfinite(judged) ? ""
              : judged < 10          ? "acceptable"
              : judged <= 30         ? "may be acceptable"
                                     : "unacceptable";

  // Each station's offset from the fleet, stations fixed and units random.
  const double se = std::sqrt((1 - 1 / O) * ms_term / (P * R));
  const double t = boost::math::quantile(boost::math::complement(boost::math::students_t(df_term), 0.025));
  for (size_t j = 0; j < o; ++j) {
    StationOffset off;
    off.station = s.stations[j];
    off.offset = station_mean[j] - grand;
    off.low = off.offset - t * se;
    off.high = off.offset + t * se;
    off.differs = off.low > 0 || off.high < 0;
    m.offsets.push_back(off);
  }
  return m;
}

}  // namespace imuqual::judge
