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
  add("rate_random_walk", true, NoiseTerm::kRateRandomWalk, fit.rate_random_walk.value,
      fit.rate_random_walk.sigma, has_k ? "" : "not in the selected model");

  std::vector<const FittedTerm*> gms, lines;
  for (const FittedTerm& t : fit.terms) {
    switch (t.term.kind) {
      case TermKind::kGaussMarkov:
        gms.push_back(&t);
        break;
      case TermKind::kSinusoid:
        lines.push_back(&t);
        break;
      case TermKind::kRandomWalk:
        break;  // a figure above
      default:
        add(ParameterName(t.term.kind), false, Analog(t.term.kind), t.term.scale, t.scale_sigma);
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

CompositeModel ModelFromQuantities(const std::vector<std::pair<std::string, double>>& values,
                                   SensorKind kind) {
  CompositeModel model;
  auto base = [&](NoiseTerm analog, double v) { return v / Unit(analog, kind).factor; };
  auto find = [&](const std::string& name) -> std::optional<double> {
    for (const auto& [n, v] : values) {
      if (n == name) return v;
    }
    return std::nullopt;
  };
  const std::pair<TermKind, const char*> simple[] = {{TermKind::kQuantization, "quantization"},
                                                     {TermKind::kWhite, "white_noise"},
                                                     {TermKind::kFlicker, "flicker_floor"},
                                                     {TermKind::kRandomWalk, "rate_random_walk"},
                                                     {TermKind::kDrift, "rate_ramp"}};
  for (const auto& [term_kind, name] : simple) {
    const std::optional<double> v = find(name);
    if (v.has_value() && *v > 0) {
      model.terms.push_back({term_kind, base(Analog(term_kind), *v), 0, 0});
    }
  }
  for (int i = 1;; ++i) {
    const std::string p = "gauss_markov_" + std::to_string(i);
    const std::optional<double> s = find(p + "_sigma"), t = find(p + "_correlation_time");
    if (!s.has_value() || !t.has_value()) break;
    model.terms.push_back({TermKind::kGaussMarkov, base(NoiseTerm::kBiasInstability, *s), *t, 0});
  }
  for (int i = 1;; ++i) {
    const std::string p = "sinusoid_" + std::to_string(i);
    const std::optional<double> a = find(p + "_amplitude"), f = find(p + "_frequency");
    if (!a.has_value() || !f.has_value()) break;
    model.terms.push_back({TermKind::kSinusoid, base(NoiseTerm::kBiasInstability, *a), 0, *f});
  }
  return model;
}

}  // namespace imuqual::allan
