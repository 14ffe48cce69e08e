// The stationarity scan's error rates on every built-in simulator profile
// (analyze/allan/stationarity.h): over many seeds of stationary records (the
// profile's own noise model; its temperature coefficients set to 0, since
// the warm-up they follow is itself a non-stationarity), the fraction of
// records with any event (false alarm, with its Monte Carlo standard error);
// then the same records with a step planted on one axis of size
// `--step-sigmas` times the standard deviation of that axis's 100 s bin
// means (measured on the stationary record), at a random time in the middle
// 60 %, the fraction found (an event named on that axis within its window,
// or 5 % of the record, of the planted time).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "acquire/random.h"
#include "analyze/allan/stationarity.h"
#include "analyze/judge/stationarity_measure.h"
#include "bench/bench_summary.h"
#include "bench/planted_steps.h"

namespace imuqual {
namespace {

struct Rates {
  int records = 0, alarms = 0, planted = 0, found = 0, misplaced = 0;
  // Per group of axes of one kind (the level the plan states): groups
  // scanned and those with an event, of the units counted in `records`.
  int groups = 0, group_alarms = 0;
  // With --envelope: records of units with a term above the reference (the
  // profile's planted failures), whose rate the reference does not bound.
  int above_records = 0, above_alarms = 0;
  // Of those, the profile's planted failures (bias instability x4, K x3).
  int failing_records = 0, failing_alarms = 0;
  // The noise-level scan (no model) of every stationary record's groups, at
  // 1 % per group (split over its axes): groups with a significant change,
  // and with one beyond the default 5 % tolerance (an event).
  int noise_groups = 0, noise_significant = 0, noise_events = 0;
};

// 'g' for a gyro axis (gx, gy, gz, or any other name), 'a' for an accelerometer (ax, ay, az).
char KindOf(const pb::AxisTruth& a) { return a.axis().starts_with("a") ? 'a' : 'g'; }

// The axis's true noise model (what the simulator draws, less the MEMS
// filter, LSB rounding and spikes, which the scan's bins average away).
allan::CompositeModel TrueModel(const pb::AxisTruth& a) {
  allan::CompositeModel m = judge::CompositeModelOf(a);
  if (a.sine_amplitude() > 0 && a.sine_frequency_hz() > 0) {
    m.terms.push_back({allan::TermKind::kSinusoid, a.sine_amplitude(), 0, a.sine_frequency_hz()});
  }
  return m;
}

Rates Run(const std::string& profile_name, int seeds, double duration_s, double step_sigmas,
          bool verbose, bool true_models, bool typical_models, bool most_wander, double envelope) {
  Rates r;
  auto profile = sim::LotProfileByName(profile_name);
  if (!profile.ok()) return r;
  for (int seed = 0; seed < seeds; ++seed) {
    pb::SimTruth truth =
        sim::MakeUnitTruth(*profile, 7000 + seed, seed % 8, profile->nominal_rate_hz);
    truth.set_seed(91000 + seed);
    for (pb::AxisTruth& a : *truth.mutable_axes()) a.set_temp_coefficient(0);
    auto simulator = sim::ImuSimulator::Create(truth);
    if (!simulator.ok()) continue;
    const int axes = simulator->num_axes();
    const double tau0 = 1.0 / truth.actual_rate_hz();
    const int n = static_cast<int>(duration_s * truth.actual_rate_hz());
    std::vector<std::vector<float>> raw(axes);
    simulator->Generate(n, raw);
    std::vector<std::vector<double>> y(axes);
    for (int a = 0; a < axes; ++a) y[a].assign(raw[a].begin(), raw[a].end());
    // One group per kind of axis, as the station scans them.
    auto scan_groups = [&](const std::vector<std::vector<double>>& data,
                           std::vector<allan::StationarityScan>* out) {
      out->clear();
      for (char kind : {'g', 'a'}) {
        std::vector<std::span<const double>> group;
        std::vector<allan::CompositeModel> models;
        for (int a = 0; a < axes; ++a) {
          if (KindOf(truth.axes(a)) != kind) continue;
          group.emplace_back(data[a]);
          models.push_back(TrueModel(typical_models ? profile->axes[a].typical : truth.axes(a)));
          // A plan's reference: the typical unit with every term scaled up.
          if (envelope > 0) {
            for (allan::ModelTerm& t : models.back().terms) t.scale *= envelope;
          }
        }
        if (group.empty()) continue;
        auto s = true_models || typical_models
                     ? allan::ScanStationarity(group, models, tau0)
                     : allan::ScanStationarityRefitting(
                           group, tau0, {}, [&](std::span<const double> r, double t) {
                             return allan::FitModelForScan(r, t, most_wander);
                           });
        if (s.ok()) out->push_back(*s);
      }
    };
    std::vector<allan::StationarityScan> scans;
    scan_groups(y, &scans);
    ++r.records;
    // Each group's noise level, axis by axis, over the level scan's bins.
    for (const char kind : {'g', 'a'}) {
      std::vector<int> members;
      for (int a = 0; a < axes; ++a) {
        if (KindOf(truth.axes(a)) == kind) members.push_back(a);
      }
      if (members.empty() || scans.empty() || !scans.front().scanned) continue;
      const double bin_s = scans.front().bin_s;
      const int64_t bin_samples = std::llround(bin_s / tau0);
      bool significant = false, event = false;
      for (int a : members) {
        auto noise = allan::ScanNoiseLevel(
            allan::BinMeanSquareDifferences(y[a], bin_samples, scans.front().bins), bin_s,
            0.01 / static_cast<double>(members.size()), judge::kDefaultNoiseLevelTolerance);
        if (!noise.ok() || !noise->scanned) continue;
        significant = significant || noise->significant;
        event = event || noise->found();
      }
      ++r.noise_groups;
      r.noise_significant += significant ? 1 : 0;
      r.noise_events += event ? 1 : 0;
    }
    bool alarm = false;
    for (const auto& s : scans) alarm = alarm || !s.events.empty();
    // A unit above the envelope in some term: its rate is not bounded.
    bool above = false;
    if (envelope > 0) {
      for (int a = 0; a < axes; ++a) {
        const allan::CompositeModel unit = TrueModel(truth.axes(a));
        const allan::CompositeModel typical = TrueModel(profile->axes[a].typical);
        // Term by term of one kind, in order (Gauss-Markov and sinusoid terms
        // come in the profile's order).
        for (const allan::TermKind kind :
             {allan::TermKind::kQuantization, allan::TermKind::kWhite, allan::TermKind::kFlicker,
              allan::TermKind::kRandomWalk, allan::TermKind::kDrift, allan::TermKind::kGaussMarkov,
              allan::TermKind::kSinusoid}) {
          std::vector<double> u, ty;
          for (const auto& t : unit.terms)
            if (t.kind == kind) u.push_back(t.scale);
          for (const auto& t : typical.terms)
            if (t.kind == kind) ty.push_back(t.scale);
          for (size_t t = 0; t < u.size(); ++t) {
            above = above || t >= ty.size() || u[t] > envelope * ty[t];
          }
        }
      }
    }
    if (above && truth.profile().ends_with("planted-fail")) {
      --r.records;
      ++r.failing_records;
      r.failing_alarms += alarm ? 1 : 0;
    } else if (above) {
      --r.records;
      ++r.above_records;
      r.above_alarms += alarm ? 1 : 0;
    } else {
      r.alarms += alarm ? 1 : 0;
      for (const auto& sc : scans) {
        ++r.groups;
        r.group_alarms += sc.events.empty() ? 0 : 1;
      }
    }
    if (alarm && verbose) {
      for (const auto& sc : scans) {
        std::printf("# %s seed %d: %d passes, models", profile_name.c_str(), seed, sc.passes);
        for (const auto& m : sc.models) std::printf(" %s", m.c_str());
        std::printf("\n");
        for (const auto& e : sc.events) {
          std::printf("#   %s at %.0f s window %.0f s p %.2g:",
                      std::string(allan::EventKindName(e.kind)).c_str(), e.time_s, e.window_s,
                      e.p_adjusted);
          for (const auto& ea : e.axes)
            std::printf(" [%s%.3g +- %.3g z %.1f]", ea.named ? "*" : "", ea.size, ea.sigma, ea.z);
          std::printf("\n");
        }
      }
    }
    if (step_sigmas <= 0) continue;
    // Plant a step on one axis.
    sim::Random rng(555 + seed);
    const int axis = seed % axes;
    const double at_s = duration_s * (0.2 + 0.6 * rng.Uniform());
    const double size = step_sigmas * bench::BinMeanSd(y[axis], tau0, 100.0) * (seed % 2 ? 1 : -1);
    for (int i = static_cast<int>(at_s / tau0); i < n; ++i) y[axis][i] += size;
    scan_groups(y, &scans);
    ++r.planted;
    // The axis's index within its group.
    int in_group = 0;
    for (int a = 0; a < axis; ++a) in_group += KindOf(truth.axes(a)) == KindOf(truth.axes(axis));
    const allan::StationarityScan& s =
        scans[KindOf(truth.axes(axis)) == 'g' || scans.size() == 1 ? 0 : 1];
    bool found = false, misplaced = false;
    for (const allan::StationarityEvent& e : s.events) {
      if (!e.axes[in_group].named) continue;
      // A step's place is known to a few bins only when it is large: found
      // within 5 % of the record (or the event's window) of the planted time.
      const double slack = std::max(e.window_s, 0.05 * duration_s);
      const double lo = e.time_s - slack, hi = e.time_s + slack;
      if (at_s >= lo && at_s <= hi) {
        found = true;
      } else {
        misplaced = true;
      }
    }
    if (verbose) {
      std::printf("## %s seed %d planted %.3g at %.0f s on axis %d: %zu events, found %d\n",
                  profile_name.c_str(), seed, size, at_s, axis, s.events.size(), found);
      for (const auto& e : s.events) {
        std::printf("##   %s at %.0f s window %.0f s p %.2g z %.1f\n",
                    std::string(allan::EventKindName(e.kind)).c_str(), e.time_s, e.window_s,
                    e.p_adjusted, e.axes[in_group].z);
      }
    }
    r.found += found ? 1 : 0;
    r.misplaced += (!found && misplaced) ? 1 : 0;
  }
  return r;
}

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  int seeds = 200;
  double duration_s = 3600, step_sigmas = 3;
  bool verbose = false, true_models = false, typical_models = false, most_wander = true;
  double envelope = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--selected-model") {  // the fit's selected model, not the one with the most wander
      most_wander = false;
      continue;
    }
    if (flag == "--typical-models") {  // the profile's typical unit's model (a lot's model)
      typical_models = true;
      continue;
    }
    // Scan with each axis's true model, not one fitted to the record.
    if (flag == "--true-models") {
      true_models = true;
      continue;
    }
    if (flag == "--verbose") {  // every alarm's and planted step's events, as comments
      verbose = true;
      continue;
    }
    if (i + 1 >= argc) break;
    if (flag == "--seeds") seeds = std::atoi(argv[i + 1]);
    if (flag == "--duration") duration_s = std::atof(argv[i + 1]);
    if (flag == "--step-sigmas") step_sigmas = std::atof(argv[i + 1]);
    // The typical unit's model with every term x F (a plan's envelope
    // reference, plan.proto Stationarity), e.g. 1.35.
    if (flag == "--envelope") {
      envelope = std::atof(argv[i + 1]);
      typical_models = envelope > 0;
    }
    ++i;
  }
  for (const std::string& p : imuqual::sim::LotProfileNames()) {
    const imuqual::Rates r = imuqual::Run(p, seeds, duration_s, step_sigmas, verbose, true_models,
                                          typical_models, most_wander, envelope);
    const double fa = static_cast<double>(r.alarms) / r.records;
    const double se = std::sqrt(fa * (1 - fa) / r.records);
    std::printf("stationarity_false_alarm_%s %.4f fraction (+- %.4f, %d records of %.0f s%s)\n",
                p.c_str(), fa, se, r.records, duration_s,
                envelope > 0 ? " of units below the reference" : "");
    if (r.groups > 0) {
      const double g = static_cast<double>(r.group_alarms) / r.groups;
      std::printf(
          "stationarity_false_alarm_per_group_%s %.4f fraction (+- %.4f, %d groups; "
          "stated 0.01)\n",
          p.c_str(), g, std::sqrt(0.01 * 0.99 / r.groups), r.groups);
    }
    if (r.above_records > 0) {
      std::printf(
          "stationarity_false_alarm_above_reference_%s %.4f fraction (%d records of units "
          "with a term above the reference, not planted failures)\n",
          p.c_str(), static_cast<double>(r.above_alarms) / r.above_records, r.above_records);
    }
    if (r.failing_records > 0) {
      std::printf(
          "stationarity_false_alarm_planted_failures_%s %.4f fraction (%d records of the "
          "profile's planted failures, far above the reference)\n",
          p.c_str(), static_cast<double>(r.failing_alarms) / r.failing_records, r.failing_records);
    }
    if (r.noise_groups > 0) {
      std::printf(
          "stationarity_noise_level_false_alarm_per_group_%s %.4f fraction (+- %.4f, %d groups "
          "of every unit; stated 0.01); beyond the 5 %% tolerance %.4f\n",
          p.c_str(), static_cast<double>(r.noise_significant) / r.noise_groups,
          std::sqrt(0.01 * 0.99 / r.noise_groups), r.noise_groups,
          static_cast<double>(r.noise_events) / r.noise_groups);
    }
    if (r.planted > 0) {
      std::printf(
          "stationarity_step_found_%s %.4f fraction (%d of %d steps of %.1f sigma; %d found "
          "elsewhere only)\n",
          p.c_str(), static_cast<double>(r.found) / r.planted, r.found, r.planted, step_sigmas,
          r.misplaced);
    }
  }
  return 0;
}
