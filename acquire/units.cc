#include "acquire/units.h"

#include <cstdio>

#include "acquire/lot_profile.h"
#include "acquire/sim_source.h"

namespace imuqual::acquire {

std::string SimSerial(const std::string& lot, int index) {
  char suffix[16];
  std::snprintf(suffix, sizeof suffix, "-U%02d", index + 1);
  return lot.substr(0, 40) + suffix;
}

Result<std::vector<UnitSpec>> MakeSimUnits(const SimLotSpec& spec) {
  if (spec.count < 1 || spec.count > 1000) {
    return Status::InvalidArgument("--sim: number of simulated units must be 1..1000");
  }
  auto profile = sim::LotProfileByName(spec.profile);
  if (!profile.ok()) return profile.status();
  const uint64_t seed = spec.seed != 0 ? spec.seed : sim::SeedFromName(spec.lot);
  std::vector<UnitSpec> units;
  for (int i = 0; i < spec.count; ++i) {
    auto source = SimSource::Create(*profile, seed, i, spec.rate_hz, spec.duration_s);
    if (!source.ok()) return source.status();
    units.push_back({SimSerial(spec.lot, i), std::to_string(i + 1), std::move(*source)});
  }
  return units;
}

Result<std::vector<UnitSpec>> MakeNamedUnits(const std::vector<std::string>& unit_args,
                                             const SourceDefaults& defaults, int first_slot) {
  std::vector<UnitSpec> units;
  for (size_t i = 0; i < unit_args.size(); ++i) {
    const std::string& arg = unit_args[i];
    const size_t eq = arg.find('=');
    if (eq == std::string::npos || eq == 0) {
      return Status::InvalidArgument("--unit '" + arg + "' must be SERIAL=SOURCE");
    }
    auto spec = ParseSourceSpec(arg.substr(eq + 1));
    if (!spec.ok()) return spec.status().WithContext("--unit " + arg.substr(0, eq));
    SourceDefaults d = defaults;
    d.index = static_cast<int>(i);
    auto source = MakeSource(*spec, d);
    if (!source.ok()) return source.status().WithContext("--unit " + arg.substr(0, eq));
    units.push_back({arg.substr(0, eq), std::to_string(first_slot + i), std::move(*source)});
  }
  return units;
}

}  // namespace imuqual::acquire
