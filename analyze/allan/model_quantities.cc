#include "analyze/allan/model_quantities.h"

#include <algorithm>

namespace imuqual::allan {
namespace {

struct UnitOf {
  double factor = 1;  // datasheet value = factor x base value
  std::string unit;
};

// The unit of a quantity that scales like `analog` (a Gauss-Markov sigma or a
// line amplitude is a rate like B).
UnitOf Unit(NoiseTerm analog, std::optional<SensorKind> kind) {
  if (!kind.has_value()) {
    static const char* kBase[] = {"u*s", "u*sqrt(s)", "u", "u/sqrt(s)", "u/s"};
    return {1.0, kBase[static_cast<int>(analog)]};
  }
  const DatasheetValue one = ToDatasheetUnits(analog, *kind, 1.0);
  return {one.value, std::string(one.unit)};
}

NoiseTerm Analog(TermKind kind) {
  switch (kind) {
    case TermKind::kQuantization:
      return NoiseTerm::kQuantization;
    case TermKind::kWhite:
      return NoiseTerm::kAngleRandomWalk;
    case TermKind::kRandomWalk:
      return NoiseTerm::kRateRandomWalk;
    case TermKind::kDrift:
      return NoiseTerm::kRateRamp;
    case TermKind::kFlicker:
    case TermKind::kGaussMarkov:
    case TermKind::kSinusoid:
      return NoiseTerm::kBiasInstability;
  }
  return NoiseTerm::kBiasInstability;
}

const char* ParameterName(TermKind kind) {
  switch (kind) {
    case TermKind::kQuantization:
      return "quantization";
    case TermKind::kWhite:
      return "white_noise";
    case TermKind::kFlicker:
      return "flicker_floor";
    case TermKind::kDrift:
      return "rate_ramp";
    default:
      return "";
  }
}

}  // namespace

std::vector<ModelQuantity> DescribeCompositeFit(const CompositeFit& fit,
                                                std::optional<SensorKind> kind) {
  std::vector<ModelQuantity> out;
  auto add = [&](std::string name, bool figure, NoiseTerm analog, double value, double sigma,
                 std::string note = "") {
    const UnitOf u = Unit(analog, kind);
    out.push_back(
        {std::move(name), figure, value * u.factor, sigma * u.factor, u.unit, std::move(note)});
  };
  const bool accel = kind == SensorKind::kAccelerometer;
  add(accel ? "velocity_random_walk" : "angle_random_walk", true, NoiseTerm::kAngleRandomWalk,
      fit.white_asymptote.value, fit.white_asymptote.sigma,
      fit.has_white_region ? "-1/2 asymptote of the model at 1 s"
                           : "-1/2 asymptote only: the model has no -1/2 region");
  const std::string edge =
      fit.minimum_at_edge ? "minimum at the edge of the analysed taus: a bound, not a minimum" : "";
  add("bias_instability", true, NoiseTerm::kBiasInstability, fit.curve_minimum.value,
      fit.curve_minimum.sigma, edge.empty() ? "minimum of the model curve" : edge);
  add("bias_instability_ieee", true, NoiseTerm::kBiasInstability, fit.bias_instability_ieee.value,
      fit.bias_instability_ieee.sigma, edge.empty() ? "model-curve minimum / 0.664" : edge);
  out.push_back(
      {"tau_at_minimum", true, fit.tau_at_minimum.value, fit.tau_at_minimum.sigma, "s", edge});
  const bool has_k = fit.model.CountOf(TermKind::kRandomWalk) > 0;
  if (has_k) {
    add("rate_random_walk", true, NoiseTerm::kRateRandomWalk, fit.rate_random_walk.value,
        fit.rate_random_walk.sigma, "averaged over the plausible models");
  } else {
    add("rate_random_walk", true, NoiseTerm::kRateRandomWalk, 0.0, kNaN,
        "not in the selected model");
  }

  // The IEEE 952 term parameters, model-averaged, always listed (0 when no
  // plausible candidate has the term), so a plan limit on one always meets a
  // value.
  const TermKind ieee[] = {TermKind::kQuantization, TermKind::kWhite, TermKind::kFlicker,
                           TermKind::kRandomWalk, TermKind::kDrift};
  for (int i = 0; i < 5; ++i) {
    if (ieee[i] == TermKind::kRandomWalk) continue;  // a figure above
    if (fit.model.CountOf(ieee[i]) == 0) {
      add(ParameterName(ieee[i]), false, Analog(ieee[i]), 0.0, kNaN, "not in the selected model");
      continue;
    }
    const ModelFigure& f = fit.ieee_terms[i];
    add(ParameterName(ieee[i]), false, Analog(ieee[i]), f.value, f.sigma,
        "averaged over the plausible models");
  }
  std::vector<const FittedTerm*> gms, lines;
  for (const FittedTerm& t : fit.terms) {
    switch (t.term.kind) {
      case TermKind::kGaussMarkov:
        gms.push_back(&t);
        break;
      case TermKind::kSinusoid:
        lines.push_back(&t);
        break;
      default:
        break;  // listed above
    }
  }
  std::sort(gms.begin(), gms.end(), [](const FittedTerm* a, const FittedTerm* b) {
    return a->term.correlation_time_s < b->term.correlation_time_s;
  });
  std::sort(lines.begin(), lines.end(), [](const FittedTerm* a, const FittedTerm* b) {
    return a->term.frequency_hz < b->term.frequency_hz;
  });
  for (size_t i = 0; i < gms.size(); ++i) {
    const std::string p = "gauss_markov_" + std::to_string(i + 1);
    add(p + "_sigma", false, NoiseTerm::kBiasInstability, gms[i]->term.scale, gms[i]->scale_sigma);
    out.push_back({p + "_correlation_time", false, gms[i]->term.correlation_time_s,
                   gms[i]->correlation_time_sigma_s, "s", ""});
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string p = "sinusoid_" + std::to_string(i + 1);
    add(p + "_amplitude", false, NoiseTerm::kBiasInstability, lines[i]->term.scale,
        lines[i]->scale_sigma);
    out.push_back({p + "_frequency", false, lines[i]->term.frequency_hz,
                   lines[i]->frequency_sigma_hz, "Hz", ""});
  }
  return out;
}

}  // namespace imuqual::allan
