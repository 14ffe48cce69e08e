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

}  // namespace imuqual::acquire
