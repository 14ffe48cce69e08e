// Lot profiles for the simulator: the typical unit of a product line (per
// axis IEEE 952 terms), the unit-to-unit spread, and planted failures, so a
// simulated lot looks like a production lot with known truth per unit.
#ifndef IMUQUAL_ACQUIRE_LOT_PROFILE_H_
#define IMUQUAL_ACQUIRE_LOT_PROFILE_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/sim.pb.h"

namespace imuqual::sim {

struct AxisProfile {
  std::string name;
  pb::AxisKind kind = pb::GYRO;
  // Typical unit (bias is the spread of the constant offset, +/-).
  pb::AxisTruth typical;
};

struct LotProfile {
  std::string name;
  std::string description;
  double nominal_rate_hz = 100;
  std::vector<AxisProfile> axes;
  double spread = 0.15;        // lognormal sigma of each noise term, unit to unit
  int planted_fail_every = 8;  // unit i is planted to fail when (i + 1) % every == 0; 0: none
  double fail_bias_instability_factor = 4.0;
  double fail_rate_random_walk_factor = 3.0;
};

// Built-in profiles: "vg700" (the seed's VG700CA-like rate-grade vertical
// gyro, 3 gyro axes, 100 Hz), "tactical" (MEMS IMU, 3 gyro + 3 accel,
// 200 Hz), "fog" (navigation-grade fibre-optic gyro, 1 axis, 100 Hz),
// "mems-lab" (consumer MEMS IMU on an open bench, 3 gyro + 3 accel, 100 Hz,
// with quantization, rate ramp, a sinusoidal line and a temperature
// coefficient: every IEEE 952 effect of the simulator on some axis),
// "mems-real" (an ADIS16405-class consumer MEMS IMU as read at 100 Hz,
// 3 gyro + 3 accel: band-limited white noise, Gauss-Markov terms, rate LSBs,
// rare spikes, a 24.7 Hz line on gz and the mems-lab temperature
// coefficients on z).
Result<LotProfile> LotProfileByName(std::string_view name);
std::vector<std::string> LotProfileNames();

// Truth for unit `index` (0-based) of a lot: every noise term of the typical
// unit (Q, N, B, K and, where the profile has them, R, the sine amplitude,
// the temperature coefficient, each Gauss-Markov sigma and correlation time,
// the spike amplitude and each extra line's amplitude) scaled by
// exp(spread * g), g standard normal from (lot_seed, index); the white
// bandwidth, rate LSB, spike rate and line frequencies are the profile's.
// Planted failures get their bias instability and rate random walk
// multiplied by the fail factors. `rate_hz` is the unit's true rate.
pb::SimTruth MakeUnitTruth(const LotProfile& profile, uint64_t lot_seed, int index, double rate_hz);

// A stable 64-bit seed from a lot name (FNV-1a), so a lot is reproducible.
uint64_t SeedFromName(std::string_view name);

}  // namespace imuqual::sim

#endif  // IMUQUAL_ACQUIRE_LOT_PROFILE_H_
