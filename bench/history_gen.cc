// imuqual-history-gen: fills an archive with years of production history
// (lots x units of results, no raw samples) for query benchmarks and for
// trying the lot tools on a realistic archive. Each unit is a simulated
// unit of a lot profile; its Allan curve is the IEEE 952 model of its truth
// on the octave grid of a 2 h soak, each point scattered by its own
// 1/sqrt(2(K-1)) error; the read-offs and verdicts come from the same code
// as live runs, the noise-model terms from the truth (see SynthesizedModel). Lots drift slowly so
// that comparisons have something to find.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "acquire/lot_profile.h"
#include "acquire/random.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/judge.h"
#include "analyze/judge/measure.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan_file.h"
#include "common/clock.h"
#include "common/log.h"
#include "common/text_util.h"
#include "store/archive.h"
#include "store/outcome.h"
#include "store/run_record.h"

namespace {

using namespace imuqual;

constexpr double kSoakS = 7200;
constexpr double kDay = 86400e6;    // us
constexpr double kUnitGap = 180e6;  // us between units of a lot

double ModelAvar(const pb::AxisTruth& t, double tau) {
  return 3 * t.quantization() * t.quantization() / (tau * tau) +
         t.random_walk() * t.random_walk() / tau +
         allan::kBiasInstabilityFactor * allan::kBiasInstabilityFactor * t.bias_instability() *
             t.bias_instability() +
         t.rate_random_walk() * t.rate_random_walk() * tau / 3 +
         t.rate_ramp() * t.rate_ramp() * tau * tau / 2;
}

// The noise-model measurements of a unit axis, synthesized from its truth:
// a composite fit of every one of years of axes would take hours, and the
// synthetic curves' independent scatter is not what the fit's J test
// expects. Each term is its truth scattered by 5 % (its stated sigma), the
// bias instability the true model curve's minimum / 0.664 over the octave
// grid, and the model's p-value uniform; every note says where they came from.
std::vector<pb::Measurement> SynthesizedModel(const std::string& axis, pb::AxisKind kind,
                                              const pb::AxisTruth& t, const allan::Curve& curve,
                                              sim::Random& scatter) {
  constexpr double kRelSigma = 0.05;
  const allan::SensorKind sensor =
      kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
  double min_avar = INFINITY;
  for (const allan::CurvePoint& p : curve.points)
    min_avar = std::min(min_avar, ModelAvar(t, p.tau_s));
  const std::pair<std::string_view, std::pair<allan::NoiseTerm, double>> terms[] = {
      {judge::kFitQuantization, {allan::NoiseTerm::kQuantization, t.quantization()}},
      {kind == pb::ACCEL ? judge::kFitVelocityRandomWalk : judge::kFitAngleRandomWalk,
       {allan::NoiseTerm::kAngleRandomWalk, t.random_walk()}},
      {judge::kFitBiasInstability,
       {allan::NoiseTerm::kBiasInstability, std::sqrt(min_avar) / allan::kBiasInstabilityFactor}},
      {judge::kFitRateRandomWalk, {allan::NoiseTerm::kRateRandomWalk, t.rate_random_walk()}},
      {judge::kFitRateRamp, {allan::NoiseTerm::kRateRamp, t.rate_ramp()}}};
  std::vector<pb::Measurement> out;
  for (const auto& [name, term] : terms) {
    const allan::DatasheetValue v = allan::ToDatasheetUnits(
        term.first, sensor, term.second * (1 + kRelSigma * scatter.Gaussian()));
    pb::Measurement m;
    m.set_axis(axis);
    m.set_name(std::string(name));
    m.set_value(std::max(0.0, v.value));
    m.set_unit(std::string(v.unit));
    m.set_uncertainty(kRelSigma * std::abs(v.value));
    m.set_note("history-gen: the unit's truth, scattered");
    m.set_uncertainty_method("history-gen: the stated 5 % scatter of the truth");
    out.push_back(std::move(m));
  }
  pb::Measurement p;
  p.set_axis(axis);
  p.set_name(std::string(judge::kNoiseModelPValue));
  p.set_value(scatter.Uniform());
  p.set_unit("1");
  p.set_note("history-gen: no model was fitted");
  p.set_uncertainty_method("none: a p-value (history-gen: drawn uniform, no model fitted)");
  out.push_back(std::move(p));
  return out;
}

}  // namespace

// One finalised run of `truth` (its curve scaled by `gain`: a station that
// reads its units' noise that much higher), its measurements and verdict.
Status WriteRun(store::Archive& archive, const pb::TestPlan& plan, const std::string& plan_bytes,
                const std::vector<judge::AxisDesc>& axes,
                const std::vector<store::AxisInfo>& axis_info, const pb::SimTruth& truth,
                double rate, store::RunInfo run, double gain, sim::Random& scatter) {
  run.source = "history-gen:" + truth.profile();
  run.software_version = "history-gen";
  run.end_utime = run.start_utime + static_cast<int64_t>(kSoakS * 1e6);
  run.nominal_rate_hz = rate;
  run.axes = axis_info;
  run.plan = plan_bytes;
  run.plan_sha256 = Sha256Hex(plan_bytes);
  run.truth = truth.SerializeAsString();
  run.state = "complete";
  const int64_t samples = static_cast<int64_t>(kSoakS * rate);
  run.samples_announced = samples;
  run.first_sample = 0;
  run.end_sample = samples;
  auto key = archive.UpsertRun(run);
  if (!key.ok()) return key.status();
  std::vector<pb::Measurement> ms;
  for (size_t a = 0; a < axes.size(); ++a) {
    store::CurveRecord rec;
    rec.axis = axes[a].name;
    rec.curve.deviation = allan::Deviation::kOadev;
    rec.curve.ci = allan::CiMethod::kSimple;
    rec.curve.tau0_s = 1 / rate;
    rec.curve.n_phase = samples + 1;
    for (int64_t m = 1; m <= samples / 9; m *= 2) {
      const int64_t clusters = samples / m;
      const double err = 1 / std::sqrt(2.0 * (clusters - 1));
      allan::CurvePoint p;
      p.m = m;
      p.tau_s = m / rate;
      p.dev = gain * std::sqrt(ModelAvar(truth.axes(a), p.tau_s)) * (1 + err * scatter.Gaussian());
      p.lo = p.dev * (1 - err);
      p.hi = p.dev * (1 + err);
      p.edf = static_cast<double>(clusters - 1);
      p.n = samples + 1 - 2 * m;
      p.stride = 1;
      rec.curve.points.push_back(p);
    }
    rec.samples = samples;
    rec.valid_samples = samples;
    rec.computed_utime = run.end_utime.value();
    for (pb::Measurement& m :
         judge::MeasureAxis(axes[a].name, axes[a].kind, rec.curve, truth.axes(a).bias())) {
      ms.push_back(std::move(m));
    }
    for (pb::Measurement& m :
         SynthesizedModel(axes[a].name, axes[a].kind, truth.axes(a), rec.curve, scatter)) {
      ms.push_back(std::move(m));
    }
    IMUQUAL_RETURN_IF_ERROR(archive.PutCurve(*key, rec));
  }
  for (pb::Measurement& m : judge::MeasureRun(kSoakS, samples, 0, 0, static_cast<int>(axes.size()))) {
    ms.push_back(std::move(m));
  }
  // The simulated devices keep their nominal rate on a perfect clock.
  for (pb::Measurement& m : judge::MeasureTiming(rate, truth.actual_rate_hz(), 0, 0)) {
    ms.push_back(std::move(m));
  }
  const judge::Judgement j = judge::Judge(plan, axes, &ms);
  store::ResultRecord res;
  res.verdict = store::OutcomeText(j.verdict);
  res.reasons = j.reasons;
  res.samples = samples;
  res.axis_invalid_samples.assign(axes.size(), 0);
  res.measurements = std::move(ms);
  res.result_utime = run.end_utime.value();
  res.record = store::BuildRunRecord(run, res, 0).SerializeAsString();
  IMUQUAL_RETURN_IF_ERROR(archive.PutResult(*key, res));
  return archive.MarkFinalized(*key, res.result_utime);
}

int main(int argc, char** argv) {
  std::string db, profile_name = "tactical", plan_spec = "builtin:tactical", prefix = "HIST";
  int lots = 100, units = 100;
  double drift = 0.003;
  uint64_t seed = 1;
  CLI::App app{"imuqual-history-gen: fill an archive with simulated production history"};
  app.add_option("--db", db, "archive file (created if missing)")->required();
  app.add_option("--lots", lots, "number of lots")->capture_default_str();
  app.add_option("--units", units, "units per lot")->capture_default_str();
  app.add_option("--profile", profile_name, "lot profile")->capture_default_str();
  app.add_option("--plan", plan_spec, "test plan")->capture_default_str();
  app.add_option("--prefix", prefix, "lot name prefix")->capture_default_str();
  app.add_option("--seed", seed, "seed")->capture_default_str();
  app.add_option("--drift", drift, "per lot, relative worsening of ARW and bias instability")
      ->capture_default_str();
  // A station agreement study (imuqual msa): lot PREFIX-GOLDEN, --units
  // golden units each soaked --golden-trials times on each of
  // --golden-stations stations (station-1, ...), a station's noise read
  // --station-gain times higher. With --only-station, that station's runs
  // alone (its own archive, to ship to a plant).
  int golden_stations = 0, golden_trials = 3;
  std::vector<std::string> gains;
  std::string only_station;
  app.add_option("--golden-stations", golden_stations, "stations of a golden-unit study (0: none)");
  app.add_option("--golden-trials", golden_trials, "soaks of each golden unit on each station")
      ->capture_default_str();
  app.add_option("--station-gain", gains, "STATION=G: that station reads noise G times higher");
  app.add_option("--only-station", only_station, "write that station's runs only");
  int golden_operators = 0;
  std::vector<std::string> operator_gains;
  app.add_option("--golden-operators", golden_operators,
                 "operators of the golden study (op-1, ...): trial t of each unit on each "
                 "station by op-(t mod N + 1) (0: one operator, 'golden')");
  app.add_option("--operator-gain", operator_gains,
                 "OP=G: that operator's soaks read noise G times higher (a unit mounted badly)");
  CLI11_PARSE(app, argc, argv);
  SetLogProgramName("imuqual-history-gen");

  auto profile = sim::LotProfileByName(profile_name);
  auto plan = judge::LoadPlan(plan_spec);
  auto archive = store::Archive::Open(db, store::Archive::Mode::kWrite);
  for (const Status& st : {profile.status(), plan.status(), archive.status()}) {
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
  }
  const double rate = profile->nominal_rate_hz;
  const std::string plan_bytes = plan->SerializeAsString();
  std::vector<judge::AxisDesc> axes;
  std::vector<store::AxisInfo> axis_info;
  for (const sim::AxisProfile& a : profile->axes) {
    axes.push_back({a.name, a.kind});
    axis_info.push_back({a.name, a.kind});
  }
  const int64_t base_utime = NowUtime() - static_cast<int64_t>(lots * 3 * kDay);
  sim::Random scatter(seed);
  for (int l = 0; l < lots; ++l) {
    char lot[64];
    std::snprintf(lot, sizeof lot, "%s-L%03d", prefix.c_str(), l + 1);
    // A slow process drift: each lot's noise `drift` worse than the first's.
    sim::LotProfile drifted = *profile;
    for (sim::AxisProfile& a : drifted.axes) {
      a.typical.set_bias_instability(a.typical.bias_instability() * (1 + drift * l));
      a.typical.set_random_walk(a.typical.random_walk() * (1 + drift * l));
    }
    if (!(*archive)->Begin().ok()) return 1;
    for (int u = 0; u < units; ++u) {
      const pb::SimTruth truth =
          sim::MakeUnitTruth(drifted, sim::SeedFromName(lot) ^ seed, u, rate);
      store::RunInfo run;
      char serial[64], run_id[96];
      std::snprintf(serial, sizeof serial, "%s-U%03d", lot, u + 1);
      std::snprintf(run_id, sizeof run_id, "%s-R1", serial);
      run.run_id = run_id;
      run.serial = serial;
      run.lot = lot;
      run.station = "station-" + std::to_string(1 + u % 4);
      run.slot = std::to_string(1 + u % 16);
      run.operator_name = u % 2 ? "ana" : "ben";  // two shifts
      run.start_utime = base_utime + static_cast<int64_t>(l * 3 * kDay + u * kUnitGap);
      if (Status st = WriteRun(**archive, *plan, plan_bytes, axes, axis_info, truth, rate, run, 1.0,
                               scatter);
          !st.ok()) {
        LogError(st.message());
        return 1;
      }
    }
    if (!(*archive)->Commit().ok()) return 1;
  }
  if (golden_stations > 0) {
    std::map<std::string, double> gain;
    for (const std::string& g : gains) {
      const size_t eq = g.find('=');
      if (eq == std::string::npos) {
        LogError("--station-gain " + g + ": must be STATION=G");
        return 2;
      }
      gain[g.substr(0, eq)] = std::stod(g.substr(eq + 1));
    }
    std::map<std::string, double> operator_gain;
    for (const std::string& g : operator_gains) {
      const size_t eq = g.find('=');
      if (eq == std::string::npos) {
        LogError("--operator-gain " + g + ": must be OP=G");
        return 2;
      }
      operator_gain[g.substr(0, eq)] = std::stod(g.substr(eq + 1));
    }
    const std::string lot = prefix + "-GOLDEN";
    if (!(*archive)->Begin().ok()) return 1;
    for (int st = 1; st <= golden_stations; ++st) {
      const std::string station = "station-" + std::to_string(st);
      if (!only_station.empty() && station != only_station) continue;
      for (int u = 0; u < units; ++u) {
        const pb::SimTruth truth = sim::MakeUnitTruth(*profile, sim::SeedFromName(lot) ^ seed, u, rate);
        for (int t = 0; t < golden_trials; ++t) {
          store::RunInfo run;
          char serial[192], run_id[256];
          std::snprintf(serial, sizeof serial, "%s-U%03d", lot.c_str(), u + 1);
          std::snprintf(run_id, sizeof run_id, "%s-%s-T%d", serial, station.c_str(), t + 1);
          run.run_id = run_id;
          run.serial = serial;
          run.lot = lot;
          run.station = station;
          run.slot = "1";
          run.operator_name =
              golden_operators > 0 ? "op-" + std::to_string(t % golden_operators + 1) : "golden";
          run.start_utime = base_utime + static_cast<int64_t>(((st - 1) * golden_trials + t) * kDay +
                                                              u * kUnitGap);
          // Each soak its own realization, whichever file it is written to.
          sim::Random soak(seed ^ sim::SeedFromName(run.run_id));
          const auto g = gain.find(station);
          const auto og = operator_gain.find(run.operator_name);
          const double run_gain = (g == gain.end() ? 1.0 : g->second) *
                                  (og == operator_gain.end() ? 1.0 : og->second);
          if (Status s2 = WriteRun(**archive, *plan, plan_bytes, axes, axis_info, truth, rate, run,
                                   run_gain, soak);
              !s2.ok()) {
            LogError(s2.message());
            return 1;
          }
        }
      }
    }
    if (!(*archive)->Commit().ok()) return 1;
  }
  std::printf("%d lots x %d units x %zu axes written to %s\n", lots, units, axes.size(),
              db.c_str());
  return 0;
}
