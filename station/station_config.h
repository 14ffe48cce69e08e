// `imuqual run --station FILE`: the station configuration file (protobuf
// text format, proto/imuqual/station.proto) read, checked and turned into a
// station run. Errors are one line, "FILE:LINE: field: problem".
#ifndef IMUQUAL_STATION_STATION_CONFIG_H_
#define IMUQUAL_STATION_STATION_CONFIG_H_

#include <string>
#include <vector>

#include "common/status.h"
#include "imuqual/station.pb.h"
#include "station/station_runner.h"

namespace imuqual::station {

// Parses and checks the configuration text; `path` names it in errors and
// anchors its relative paths (archive, plan, report, csv: and archive:
// sources), which come back resolved.
// `slot_lines` (optional) receives each slot's line in the text (0 when
// not known).
Result<pb::StationConfig> ParseStationConfig(const std::string& text, const std::string& path,
                                             std::vector<int>* slot_lines = nullptr);
Result<pb::StationConfig> LoadStationConfig(const std::string& path,
                                            std::vector<int>* slot_lines = nullptr);

// The station run the (checked) configuration describes; with the file's
// path and its slot lines, each unit's location ("FILE:LINE") for the
// pre-flight's problems.
StationRunOptions StationRunFromConfig(const pb::StationConfig& config,
                                       const std::string& path = "",
                                       const std::vector<int>& slot_lines = {});

}  // namespace imuqual::station

#endif  // IMUQUAL_STATION_STATION_CONFIG_H_
