#include "analyze/allan/model_quantities.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

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
    case TermKind::kRandomWalk:
      return "rate_random_walk";
    case TermKind::kDrift:
      return "rate_ramp";
    default:
      return "";
  }
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// "not in the selected model" with its bound, if any (value already in the
// quantity's unit).
std::string AbsentNote(double bound, const std::string& unit) {
  if (!std::isfinite(bound)) return "not in the selected model; no bound from the analysed taus";
  return "not in the selected model; at most " + Num(bound) + " " + unit + " (95 %)";
}

// The selected model's terms of `kind`, in order of increasing correlation
// time / frequency.
std::vector<const FittedTerm*> TermsOf(const CompositeFit& fit, TermKind kind) {
  std::vector<const FittedTerm*> out;
  for (const FittedTerm& t : fit.terms) {
    if (t.term.kind == kind) out.push_back(&t);
  }
  std::sort(out.begin(), out.end(), [](const FittedTerm* a, const FittedTerm* b) {
    return a->term.correlation_time_s != b->term.correlation_time_s
               ? a->term.correlation_time_s < b->term.correlation_time_s
               : a->term.frequency_hz < b->term.frequency_hz;
  });
  return out;
}

constexpr TermKind kIeee[] = {TermKind::kQuantization, TermKind::kWhite, TermKind::kFlicker,
                              TermKind::kRandomWalk, TermKind::kDrift};

}  // namespace

std::vector<ModelQuantity> DescribeCompositeFit(const CompositeFit& fit,
                                                std::optional<SensorKind> kind) {
  std::vector<ModelQuantity> out;
  auto add = [&](std::string name, bool figure, NoiseTerm analog, double value, double sigma,
                 std::string note = "", double bound = kNaN) {
    const UnitOf u = Unit(analog, kind);
    const bool absent = note == "absent";
    if (absent) note = AbsentNote(bound * u.factor, u.unit);
    out.push_back({std::move(name), figure, value * u.factor, sigma * u.factor, u.unit,
                   std::move(note), absent, bound * u.factor});
  };
  const bool accel = kind == SensorKind::kAccelerometer;
  const char* arw_name = accel ? "velocity_random_walk" : "angle_random_walk";
  if (!(fit.white_asymptote.value > 0)) {
    // No white noise and no fast Gauss-Markov term in the model: what the
    // data allow of N, not a confident 0.
    add(arw_name, true, NoiseTerm::kAngleRandomWalk, 0.0, kNaN, "absent",
        fit.ieee_terms[1].upper_bound);
  } else {
    add(arw_name, true, NoiseTerm::kAngleRandomWalk, fit.white_asymptote.value,
        fit.white_asymptote.sigma,
        fit.has_white_region ? "-1/2 asymptote of the model at 1 s"
                             : "-1/2 asymptote only: the model has no -1/2 region");
  }
  const UnitOf k_unit = Unit(NoiseTerm::kRateRandomWalk, kind);
  const std::string tau_edge =
      fit.minimum_at_edge ? "minimum at the edge of the analysed taus (the model has not turned up "
                            "there)"
                          : "";
  const std::string edge =
      !fit.minimum_at_edge ? ""
      : fit.edge_half_span > 0
          ? tau_edge +
                ": the model has no random walk; the midpoint between that minimum and the one "
                "with the random walk the data allow at 1 sigma (K " +
                Num(fit.edge_rate_random_walk * k_unit.factor) + " " + k_unit.unit +
                "), the half-span in the u"
          : tau_edge + ": reads low, not a bound on the truth's";
  add("bias_instability", true, NoiseTerm::kBiasInstability, fit.curve_minimum.value,
      fit.curve_minimum.sigma, edge.empty() ? "minimum of the model curve" : edge);
  add("bias_instability_ieee", true, NoiseTerm::kBiasInstability, fit.bias_instability_ieee.value,
      fit.bias_instability_ieee.sigma, edge.empty() ? "model-curve minimum / 0.664" : edge);
  out.push_back(
      {"tau_at_minimum", true, fit.tau_at_minimum.value, fit.tau_at_minimum.sigma, "s", tau_edge});
  const bool has_k = fit.model.CountOf(TermKind::kRandomWalk) > 0;
  if (has_k) {
    const UnitOf b_unit = Unit(NoiseTerm::kBiasInstability, kind);
    add("rate_random_walk", true, NoiseTerm::kRateRandomWalk, fit.rate_random_walk.value,
        fit.rate_random_walk.sigma,
        fit.rate_random_walk_half_span > 0
            ? "averaged over the plausible models; the model has no flicker term: the midpoint "
              "down to K with the flicker the data allow at 1 sigma (B " +
                  Num(fit.flicker_for_rate_random_walk * b_unit.factor) + " " + b_unit.unit +
                  ") fixed beside it, the span (rectangular) in the u"
            : "averaged over the plausible models");
  } else {
    add("rate_random_walk", true, NoiseTerm::kRateRandomWalk, 0.0, kNaN, "absent",
        fit.rate_random_walk.upper_bound);
  }

  // The IEEE 952 term parameters, model-averaged, always listed (0 when no
  // plausible candidate has the term), so a plan limit on one always meets a
  // value.
  for (int i = 0; i < 5; ++i) {
    if (kIeee[i] == TermKind::kRandomWalk) continue;  // a figure above
    const ModelFigure& f = fit.ieee_terms[i];
    if (fit.model.CountOf(kIeee[i]) == 0) {
      add(ParameterName(kIeee[i]), false, Analog(kIeee[i]), 0.0, kNaN, "absent", f.upper_bound);
      continue;
    }
    add(ParameterName(kIeee[i]), false, Analog(kIeee[i]), f.value, f.sigma,
        "averaged over the plausible models");
  }
  const std::vector<const FittedTerm*> gms = TermsOf(fit, TermKind::kGaussMarkov);
  const std::vector<const FittedTerm*> lines = TermsOf(fit, TermKind::kSinusoid);
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

namespace imuqual::allan {

std::vector<ModelQuantity> DescribeModelTerms(const CompositeFit& fit,
                                              std::optional<SensorKind> kind) {
  std::vector<ModelQuantity> out;
  auto add = [&](std::string name, NoiseTerm analog, double value, double sigma) {
    const UnitOf u = Unit(analog, kind);
    out.push_back({std::move(name), false, value * u.factor, sigma * u.factor, u.unit, ""});
  };
  for (TermKind k : kIeee) {
    for (const FittedTerm* t : TermsOf(fit, k)) {
      add(ParameterName(k), Analog(k), t->term.scale, t->scale_sigma);
    }
  }
  const std::vector<const FittedTerm*> gms = TermsOf(fit, TermKind::kGaussMarkov);
  for (size_t i = 0; i < gms.size(); ++i) {
    const std::string p = "gauss_markov_" + std::to_string(i + 1);
    add(p + "_sigma", NoiseTerm::kBiasInstability, gms[i]->term.scale, gms[i]->scale_sigma);
    out.push_back({p + "_correlation_time", false, gms[i]->term.correlation_time_s,
                   gms[i]->correlation_time_sigma_s, "s", ""});
  }
  const std::vector<const FittedTerm*> lines = TermsOf(fit, TermKind::kSinusoid);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string p = "sinusoid_" + std::to_string(i + 1);
    add(p + "_amplitude", NoiseTerm::kBiasInstability, lines[i]->term.scale, lines[i]->scale_sigma);
    out.push_back({p + "_frequency", false, lines[i]->term.frequency_hz,
                   lines[i]->frequency_sigma_hz, "Hz", ""});
  }
  return out;
}

Result<CompositeModel> ModelFromTerms(const std::vector<ModelQuantity>& terms,
                                      std::optional<SensorKind> kind) {
  CompositeModel model;
  // Indexed Gauss-Markov terms and sinusoids: (first parameter, second).
  std::map<int, std::pair<double, double>> gms, lines;
  auto base = [&](const ModelQuantity& q, NoiseTerm analog,
                  const std::string& unit) -> Result<double> {
    const UnitOf u = unit.empty() ? Unit(analog, kind) : UnitOf{1.0, unit};
    if (q.unit != u.unit) {
      return Status::InvalidArgument("noise model parameter " + q.name + " in '" + q.unit +
                                     "', expected '" + u.unit + "'");
    }
    if (!std::isfinite(q.value) || q.value < 0) {
      return Status::InvalidArgument("noise model parameter " + q.name + " is " + Num(q.value));
    }
    return q.value / u.factor;
  };
  for (const ModelQuantity& q : terms) {
    bool ieee = false;
    for (TermKind k : kIeee) {
      if (q.name != ParameterName(k)) continue;
      auto v = base(q, Analog(k), "");
      if (!v.ok()) return v.status();
      if (*v > 0) model.terms.push_back(ModelTerm{k, *v});
      ieee = true;
    }
    if (ieee) continue;
    int index = 0;
    char param[32] = {};
    const bool gm = std::sscanf(q.name.c_str(), "gauss_markov_%d_%31s", &index, param) == 2;
    const bool line = !gm && std::sscanf(q.name.c_str(), "sinusoid_%d_%31s", &index, param) == 2;
    if (!gm && !line) continue;
    const std::string p = param;
    const bool first = p == "sigma" || p == "amplitude";
    const bool second = (gm && p == "correlation_time") || (line && p == "frequency");
    if (!first && !second) continue;
    auto v = base(q, NoiseTerm::kBiasInstability, first ? "" : (gm ? "s" : "Hz"));
    if (!v.ok()) return v.status();
    auto& slot = (gm ? gms : lines).try_emplace(index, kNaN, kNaN).first->second;
    (first ? slot.first : slot.second) = *v;
  }
  for (const auto* group : {&gms, &lines}) {
    for (const auto& [index, v] : *group) {
      const bool gm = group == &gms;
      if (!std::isfinite(v.first) || !std::isfinite(v.second)) {
        return Status::InvalidArgument(std::string(gm ? "gauss_markov_" : "sinusoid_") +
                                       std::to_string(index) + " lacks one of its parameters");
      }
      ModelTerm t{gm ? TermKind::kGaussMarkov : TermKind::kSinusoid, v.first};
      if (gm)
        t.correlation_time_s = v.second;
      else
        t.frequency_hz = v.second;
      model.terms.push_back(t);
    }
  }
  return model;
}

}  // namespace imuqual::allan
