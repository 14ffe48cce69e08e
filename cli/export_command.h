// `imuqual export`: archived results in the formats other systems read.
//   json           run records (imuqual.pb.RunRecords, protobuf JSON with the
//                  proto field names): what an MES takes
//   measurements   CSV, one row per judged value
//   curves         CSV, one row per Allan curve point
//   kalibr         Kalibr's imu.yaml (allan_variance_ros convention:
//                  gyroscope_noise_density, gyroscope_random_walk,
//                  accelerometer_noise_density, accelerometer_random_walk in
//                  rad and m units, rostopic, update_rate) from the composite
//                  noise model: one run to -o FILE or standard output, a lot as
//                  one file per unit (its latest run) in -o DIR/. Refused,
//                  naming the run and axis: an inadequate model, a term not
//                  measured, a term the model only bounds (unless
//                  kalibr_upper_bounds), a unit without gyros or accelerometers
//   samples        CSV of one run's raw samples as archived (for allantools,
//                  Stable32, a notebook): one row per device sample counter,
//                  sample, device_time_s (counter from the first archived
//                  sample / nominal rate: the time base of the analysis),
//                  arrival_utime (host arrival of the sample's batch plus
//                  its index / nominal rate; empty when not recorded), one
//                  column per axis named <axis>_deg_s or <axis>_m_s2 (the
//                  float32 value archived, shortest text that reads back
//                  bit for bit), temperature_c (the batch's, empty when
//                  none), flags ("x:saturated y:invalid": what the source
//                  flagged, and every value that is not a finite number (a
//                  bad cell or reading) or is out of the plan's
//                  sensor_range, as the analysis counts it;
//                  "missing" for a counter no chunk holds, whose values are
//                  empty). Warm-up
//                  samples are included: the analysis discards the first
//                  plan warmup_s of device time. Streamed, any length.
#ifndef IMUQUAL_CLI_EXPORT_COMMAND_H_
#define IMUQUAL_CLI_EXPORT_COMMAND_H_

#include <string>

namespace imuqual::cli {

struct ExportOptions {
  std::string db_path;
  std::string lot;                   // every run of the lot, or
  std::string run_id;                // one run
  std::string as = "json";           // json, measurements, curves, kalibr, samples
  std::string output;                // file; "" or "-" for standard output; kalibr of a lot: DIR/
  std::string rostopic = "/imu0";    // kalibr: the IMU topic the YAML names
  bool kalibr_upper_bounds = false;  // kalibr: export a term the model bounds only
};

int ExportCommand(const ExportOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_EXPORT_COMMAND_H_
