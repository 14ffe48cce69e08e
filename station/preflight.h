// Pre-flight of a station run, before any process starts: every unit's
// source opened here as acquire will open it (a serial port opened and
// closed again, a CSV file's header and first row read, a simulated unit
// built), and the soak's length held against the plan, so that every problem
// of the station is listed at once, each naming its slot, rather than the
// first one stopping a station whose store and analysis already run.
#ifndef IMUQUAL_STATION_PREFLIGHT_H_
#define IMUQUAL_STATION_PREFLIGHT_H_

#include <string>
#include <vector>

#include "imuqual/plan.pb.h"
#include "station/station_runner.h"

namespace imuqual::station {

struct PreflightResult {
  // One line each: "[FILE:LINE: ]slot NAME (unit SERIAL): problem" for a
  // unit, "soak: problem" for the whole station.
  std::vector<std::string> problems;
  // Indices into options.units of the units whose source cannot be opened
  // (what --skip-failed-slots leaves out); the other problems are the
  // station's and cannot be skipped.
  std::vector<size_t> failed_units;
  bool station_problem = false;
};

// `plan`: the run's plan (nullptr: none). options.short_soak waives the
// length check.
// `options.unit_locations` (when given) locates each unit's slot in the
// station file. Pure apart from opening the sources.
PreflightResult Preflight(const StationRunOptions& options, const pb::TestPlan* plan);

}  // namespace imuqual::station

#endif  // IMUQUAL_STATION_PREFLIGHT_H_
