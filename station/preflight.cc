#include "station/preflight.h"

#include <cmath>
#include <memory>

#include "acquire/source_spec.h"
#include "common/strings.h"

namespace imuqual::station {
namespace {

// How long a unit records, when its source says before it runs: simulated
// and serial units (their duration=, else the station's --duration, else for
// serial units the plan's warm-up + minimum); NaN for recordings, whose
// length is the file's.
double KnownDuration(const acquire::SourceSpec& spec, const StationRunOptions& o,
                     const pb::TestPlan* plan) {
  if (spec.kind != "sim" && spec.kind != "serial") return NAN;
  const auto it = spec.options.find("duration");
  if (it != spec.options.end()) {
    char* end = nullptr;
    const double d = std::strtod(it->second.c_str(), &end);
    return end != it->second.c_str() && *end == '\0' ? d : NAN;  // MakeSource names a bad one
  }
  if (o.duration_s > 0) return o.duration_s;
  if (spec.kind == "serial" && plan) return plan->warmup_s() + plan->min_duration_s();
  return NAN;
}

}  // namespace

PreflightResult Preflight(const StationRunOptions& o, const pb::TestPlan* plan) {
  PreflightResult out;
  const double warmup = plan ? plan->warmup_s() : 0;
  const double minimum = plan ? plan->min_duration_s() : 0;
  // A soak shorter than the plan's warm-up plus minimum duration would burn
  // its time into runs judged too short.
  auto too_short = [&](double duration_s) -> std::string {
    if (!plan || o.short_soak || !(duration_s < warmup + minimum)) return "";
    return "a soak of " + ShortestReal(duration_s) + " s is shorter than the plan's warm-up (" +
           ShortestReal(warmup) + " s) plus minimum duration (" + ShortestReal(minimum) +
           " s): its runs would be judged too short (--short-soak runs it anyway)";
  };
  if (o.sim_units > 0) {
    if (std::string why = too_short(o.duration_s); !why.empty()) {
      out.problems.push_back("soak: --duration: " + why);
      out.station_problem = true;
    }
  }
  acquire::SourceDefaults defaults;
  if (plan) defaults.plan = *plan;
  defaults.lot = o.lot;
  defaults.duration_s = o.duration_s;
  defaults.rate_hz = o.rate_hz.value_or(0);
  for (size_t i = 0; i < o.units.size(); ++i) {
    const std::string& arg = o.units[i];
    const size_t eq = arg.find('=');
    const std::string serial = arg.substr(0, eq);
    const std::string slot = i < o.slots.size() && !o.slots[i].empty()
                                 ? o.slots[i]
                                 : std::to_string(o.sim_units + static_cast<int>(i) + 1);
    const std::string where =
        (i < o.unit_locations.size() && !o.unit_locations[i].empty() ? o.unit_locations[i] + ": "
                                                                     : std::string()) +
        "slot " + slot + " (unit " + serial + "): ";
    if (eq == std::string::npos || eq == 0) {
      out.problems.push_back(where + "'" + arg + "' must be SERIAL=SOURCE");
      out.failed_units.push_back(i);
      continue;
    }
    auto spec = acquire::ParseSourceSpec(arg.substr(eq + 1));
    if (!spec.ok()) {
      out.problems.push_back(where + spec.status().message());
      out.failed_units.push_back(i);
      continue;
    }
    acquire::SourceDefaults d = defaults;
    d.index = static_cast<int>(i);
    // Opened as acquire will open it, then closed again (a serial source's
    // reader stops and its port closes when it goes).
    auto source = acquire::MakeSource(*spec, d);
    if (!source.ok()) {
      out.problems.push_back(where + source.status().message());
      out.failed_units.push_back(i);
      continue;
    }
    (*source)->Stop();
    if (plan) {
      if (Status axes = acquire::CheckSourceAxes(serial, (*source)->info(), *plan); !axes.ok()) {
        // The unit is named in `where` already.
        std::string why = axes.message();
        if (const std::string own = "unit " + serial + ": "; why.rfind(own, 0) == 0) {
          why = why.substr(own.size());
        }
        out.problems.push_back(where + why);
        out.failed_units.push_back(i);
        continue;
      }
    }
    if (std::string why = too_short(KnownDuration(*spec, o, plan)); !why.empty()) {
      out.problems.push_back(where + why);
      out.station_problem = true;
    }
  }
  return out;
}

}  // namespace imuqual::station
