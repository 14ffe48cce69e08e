// `imuqual export`: archived results in the formats other systems read.
//   json           run records (imuqual.pb.RunRecords, protobuf JSON with the
//                  proto field names): what an MES takes
//   measurements   CSV, one row per judged value
//   curves         CSV, one row per Allan curve point
//   kalibr         YAML noise parameters in the Kalibr / allan_variance_ros
//                  convention (gyroscope_noise_density, gyroscope_random_walk,
//                  accelerometer_noise_density, accelerometer_random_walk, in
//                  rad and m units), from the IEEE 952 fit; one document per run
#ifndef IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_
#define IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_

#include <string>

namespace imuqual::cli {

struct ExportOptions {
  std::string db_path;
  std::string lot;     // every run of the lot, or
  std::string run_id;  // one run
  std::string as = "json";  // json, measurements, curves, kalibr
  std::string output;  // file; "" or "-" for standard output
};

int ExportCommand(const ExportOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_STORE_CLI_EXPORT_COMMAND_H_
