// What the analyze process computes per run, without the bus: simulated
// tactical units (3 gyro + 3 accel axes) fed to RunAnalyzer in batches as
// acquire sends them, an interim outcome (the published curves, the
// read-offs and a provisional verdict) every `interim_batches` batches, as
// analyze does every interim period, and the final outcome (dense curves
// with chi-square intervals, the composite noise model with its bootstrap
// sigmas, the verdict). CPU seconds of the process, per phase:
//   outcome_LOAD_append_ns_per_value  AddBatch (the streaming engines), per value
//   outcome_LOAD_interim_ms           one interim outcome of a 6-axis run
//   outcome_LOAD_final_ms             one final outcome of a 6-axis run (every thread)
//   outcome_LOAD_final_wall_ms        its wall time (the axes are fitted in parallel)
// Loads: "realtime" (2 kHz, 30 s: the station bench's real-time soak, whose
// 64 runs end together) and "sustained" (1 kHz, 600 s).
//
// --digest prints one line per run instead: a hash of every number and text
// of every outcome (interim and final: curves, measurements, verdicts), so
// that two builds can be checked for bit-identical results.
// Usage: run_outcome_bench [--units N] [--digest] [--load realtime|sustained]
//                          [--profile NAME] (a lot profile of acquire/lot_profile.h)
#include <time.h>

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/service/run_analyzer.h"

namespace {

using namespace imuqual;

struct Load {
  const char* name;
  double rate_hz;
  double duration_s;
  int batch_samples;    // acquire's batch at that rate (time-warped: 675)
  int interim_batches;  // batches between interim outcomes (about 2 s of data)
};

constexpr Load kLoads[] = {{"realtime", 2000, 30, 334, 12}, {"sustained", 1000, 600, 675, 150}};

// CPU of the whole process (the final outcome fits axes on several
// threads), and the wall clock.
double CpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
double WallSeconds() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// FNV-1a over the bytes of every value (doubles by their bits).
struct Digest {
  uint64_t h = 0xcbf29ce484222325ULL;
  void Bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ULL;
  }
  void Double(double v) { Bytes(&v, sizeof v); }
  void Int(int64_t v) { Bytes(&v, sizeof v); }
  void Text(const std::string& s) {
    Int(static_cast<int64_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  void Outcome(const analyze::RunOutcome& out) {
    for (const auto& [axis, curve] : out.curves) {
      Text(axis);
      Int(curve.n_phase);
      Int(curve.invalid_rate_samples);
      for (const allan::CurvePoint& p : curve.points) {
        Int(p.m);
        Double(p.tau_s);
        Double(p.dev);
        Double(p.lo);
        Double(p.hi);
        Double(p.edf);
        Int(p.n);
        Int(p.stride);
        Int(p.alpha ? *p.alpha : 99);
        Int(p.alpha_inherited);
      }
    }
    for (const pb::Measurement& m : out.measurements) Text(m.SerializeAsString());
    Int(out.judgement.verdict);
    for (const std::string& r : out.judgement.reasons) Text(r);
    Int(out.samples);
    Int(out.gap_samples);
    Int(out.invalid_samples);
  }
};

}  // namespace

int main(int argc, char** argv) {
  int units = 4;
  bool digest = false;
  const Load* load = &kLoads[0];
  std::string profile_name = "tactical";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--units") && i + 1 < argc) {
      units = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--digest")) {
      digest = true;
    } else if (!std::strcmp(argv[i], "--profile") && i + 1 < argc) {
      profile_name = argv[++i];
    } else if (!std::strcmp(argv[i], "--load") && i + 1 < argc) {
      const char* name = argv[++i];
      load = nullptr;
      for (const Load& l : kLoads) {
        if (!std::strcmp(l.name, name)) load = &l;
      }
      if (load == nullptr) {
        std::fprintf(stderr, "run_outcome_bench: unknown load %s\n", name);
        return 2;
      }
    } else {
      std::fprintf(stderr,
                   "usage: run_outcome_bench [--units N] [--digest] [--load L] [--profile P]\n");
      return 2;
    }
  }
  const auto profile = sim::LotProfileByName(profile_name);
  if (!profile.ok()) {
    std::fprintf(stderr, "%s\n", profile.status().message().c_str());
    return 2;
  }
  const uint64_t lot_seed = sim::SeedFromName("run_outcome_bench");
  const int64_t total = static_cast<int64_t>(load->rate_hz * load->duration_s);
  double append_s = 0, interim_s = 0, final_s = 0, final_wall_s = 0;
  int64_t values = 0, interims = 0;
  for (int u = 0; u < units; ++u) {
    const pb::SimTruth truth = sim::MakeUnitTruth(*profile, lot_seed, u, load->rate_hz);
    auto simulator = sim::ImuSimulator::Create(truth);
    if (!simulator.ok()) {
      std::fprintf(stderr, "%s\n", simulator.status().message().c_str());
      return 1;
    }
    analyze::RunDescription desc;
    desc.run_id = "R" + std::to_string(u);
    desc.serial = "U" + std::to_string(u);
    desc.nominal_rate_hz = load->rate_hz;
    for (const sim::AxisProfile& a : profile->axes) desc.axes.push_back({a.name, a.kind});
    auto analyzer = analyze::RunAnalyzer::Create(desc);
    if (!analyzer.ok()) {
      std::fprintf(stderr, "%s\n", analyzer.status().message().c_str());
      return 1;
    }
    Digest d;
    std::vector<std::vector<float>> samples(profile->axes.size());
    int64_t seq = 0;
    for (int64_t first = 0; first < total; first += load->batch_samples, ++seq) {
      const int n = static_cast<int>(std::min<int64_t>(load->batch_samples, total - first));
      for (auto& s : samples) s.clear();
      simulator->Generate(n, samples);
      analyze::BatchView view;
      view.seq = seq;
      view.first_sample = first;
      view.nominal_rate_hz = load->rate_hz;
      // Arrival times on the nominal clock: the timing measurements are
      // deterministic too.
      view.sample_utime =
          1000000 + static_cast<int64_t>(static_cast<double>(first) * 1e6 / load->rate_hz);
      for (const auto& s : samples) view.samples.emplace_back(s);
      const double t0 = CpuSeconds();
      const Status st = analyzer->AddBatch(view);
      append_s += CpuSeconds() - t0;
      if (!st.ok()) {
        std::fprintf(stderr, "%s\n", st.message().c_str());
        return 1;
      }
      values += static_cast<int64_t>(n) * static_cast<int64_t>(samples.size());
      if ((seq + 1) % load->interim_batches == 0) {
        const double t1 = CpuSeconds();
        const analyze::RunOutcome out = analyzer->Outcome(false);
        interim_s += CpuSeconds() - t1;
        ++interims;
        d.Outcome(out);
      }
    }
    analyzer->Finish(0, total);
    const double t2 = CpuSeconds(), w2 = WallSeconds();
    const analyze::RunOutcome out = analyzer->Outcome(true);
    final_s += CpuSeconds() - t2;
    final_wall_s += WallSeconds() - w2;
    d.Outcome(out);
    if (digest) {
      std::printf("run %d %s %s digest %016" PRIx64 "\n", u, profile_name.c_str(), load->name, d.h);
    }
  }
  if (!digest) {
    const std::string prefix = std::string("outcome_") + load->name + "_";
    std::printf("%sappend_ns_per_value %.3g ns\n", prefix.c_str(),
                1e9 * append_s / static_cast<double>(values));
    std::printf("%sinterim_ms %.3g ms\n", prefix.c_str(),
                1e3 * interim_s / static_cast<double>(interims));
    std::printf("%sfinal_ms %.4g ms\n", prefix.c_str(), 1e3 * final_s / units);
    std::printf("%sfinal_wall_ms %.4g ms\n", prefix.c_str(), 1e3 * final_wall_s / units);
  }
  return 0;
}
