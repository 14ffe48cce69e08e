// Building the units of an acquire process from its command line.
#ifndef IMUQUAL_ACQUIRE_UNITS_H_
#define IMUQUAL_ACQUIRE_UNITS_H_

#include <string>
#include <vector>

#include "acquire/acquire_service.h"
#include "acquire/source_spec.h"

namespace imuqual::acquire {

struct SimLotSpec {
  int count = 0;                 // simulated units
  std::string profile = "vg700"; // lot profile (sim::LotProfileByName)
  std::string lot;               // serials are <lot>-U01, <lot>-U02, ... (lot cut to 40 chars)
  double duration_s = 0;         // simulated seconds per unit
  double rate_hz = 0;            // 0: the profile's nominal rate
  uint64_t seed = 0;             // 0: derived from the lot name (reproducible lots)
};

// Simulated units of a lot; slots are "1", "2", ...
Result<std::vector<UnitSpec>> MakeSimUnits(const SimLotSpec& spec);

// The serial of simulated unit `index` (0-based) of `lot`.
std::string SimSerial(const std::string& lot, int index);

// Units named SERIAL=SOURCE (see source_spec.h), in order; slots continue
// after `first_slot`. Errors name the argument.
Result<std::vector<UnitSpec>> MakeNamedUnits(const std::vector<std::string>& unit_args,
                                             const SourceDefaults& defaults, int first_slot);

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_UNITS_H_
