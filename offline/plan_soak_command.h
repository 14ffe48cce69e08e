// `imuqual plan-soak`: how long a plan's soak must be to decide a unit early
// (early_decision, analyze/judge/early_decision.h), predicted by Monte Carlo
// through the station's own analysis: records are simulated from noise
// models (acquire/imu_simulator.h) and fed to the run analysis with the
// plan's early decisions until each unit is decided or reaches the horizon.
// The noise models come from one of
//   --model FILE   a typical unit: CSV "axis,name,value,unit" of its model
//                  terms (names and datasheet units of the archived model_*
//                  parameters: white_noise, flicker_floor, rate_random_walk,
//                  quantization, rate_ramp, gauss_markov_<i>_sigma,
//                  gauss_markov_<i>_correlation_time, sinusoid_<i>_amplitude,
//                  sinusoid_<i>_frequency; "model_" prefix allowed); every
//                  record is a new noise realisation of that unit;
//   --lot LOT --db FILE  the archived noise models of a past lot (each unit's
//                  latest run); records cycle through the units, so the
//                  figures are the lot's distribution;
//   --profile NAME a simulator lot profile (typical unit and spread).
// Prints the looks, the fraction decided by the horizon and how, the time to
// decide (percentiles, with the Monte Carlo standard error of the median),
// the slot time per unit against the full soak, and what keeps units
// pending. Exit 0; 1 on an error (one line on stderr); 2 on a usage error.
#ifndef IMUQUAL_OFFLINE_PLAN_SOAK_COMMAND_H_
#define IMUQUAL_OFFLINE_PLAN_SOAK_COMMAND_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "acquire/imu_simulator.h"
#include "analyze/service/run_analyzer.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/sim.pb.h"

namespace imuqual::offline {

struct PlanSoakOptions {
  std::string plan;   // "builtin:NAME" or a .textproto file (must have early_decision)
  std::string model;  // --model FILE
  std::string lot;    // --lot LOT (with db)
  std::string db;
  std::string profile;  // --profile NAME
  int records = 40;     // simulated records
  uint64_t seed = 1;
  int threads = 2;
};

// What one simulated record showed.
struct SoakRecord {
  std::string unit;  // the model's source (serial, "typical", profile unit index)
  bool decided = false;
  bool fail = false;                 // decided FAIL
  double decided_at_s = 0;           // analysed device time (the horizon when pending)
  std::vector<std::string> pending;  // "axis name" still pending at the last look
};

// Simulates `records` records of the units `truths` (cycled) under `plan`.
// Errors: the plan has no early_decision, a truth the simulator refuses.
Result<std::vector<SoakRecord>> SimulateSoaks(const pb::TestPlan& plan,
                                              const std::vector<pb::SimTruth>& truths,
                                              const std::vector<std::string>& names, int records,
                                              uint64_t seed, int threads);

// Feeds up to `total` samples of `simulator` in batches of one second at
// `rate_hz` (device counter from 0) to `consume`, which returns false to
// stop (e.g. once its analysis is decided). Returns the samples fed.
int64_t FeedSimulatedRecord(sim::ImuSimulator& simulator, double rate_hz, int64_t total,
                            const std::function<bool(const analyze::BatchView&)>& consume);

int PlanSoakCommand(const PlanSoakOptions& options);

}  // namespace imuqual::offline

#endif  // IMUQUAL_OFFLINE_PLAN_SOAK_COMMAND_H_
