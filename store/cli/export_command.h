// `imuqual export`: archived results in the formats other systems read.
//   json           run records (imuqual.pb.RunRecords, protobuf JSON with the
//                  proto field names): what an MES takes
//   measurements   CSV, one row per judged value
//   curves         CSV, one row per Allan curve point
//   kalibr         YAML noise parameters in the Kalibr / allan_variance_ros
//                  convention (gyroscope_noise_density, gyroscope_random_walk,
//                  accelerometer_noise_density, accelerometer_random_walk, in
//                  rad and m units), from the IEEE 952 fit; one document per run
//   samples        CSV of one run's raw samples as archived (for allantools,
//                  Stable32, a notebook): one row per device sample counter,
//                  sample, device_time_s (counter from the first archived
//                  sample / nominal rate: the time base of the analysis),
//                  arrival_utime (host arrival of the sample's batch plus
//                  its index / nominal rate; empty when not recorded), one
//                  column per axis named <axis>_deg_s or <axis>_m_s2 (the
//                  float32 value archived, shortest text that reads back
//                  bit for bit), temperature_c (the batch's, empty when
//                  none), flags ("x:saturated y:invalid"; "missing" for a
//                  counter no chunk holds, whose values are empty). Warm-up
//                  samples are included: the analysis discards the first
//                  plan warmup_s of device time. Streamed, any length.
#ifndef IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_
#define IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_

#include <string>

namespace imuqual::cli {

struct ExportOptions {
  std::string db_path;
  std::string lot;          // every run of the lot, or
  std::string run_id;       // one run
  std::string as = "json";  // json, measurements, curves, kalibr, samples
  std::string output;       // file; "" or "-" for standard output
};

int ExportCommand(const ExportOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_
