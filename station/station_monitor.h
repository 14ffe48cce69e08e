// A station as heard on its bus: the console's model (station_console.h)
// filled from run_t, status_t, decision_t, ack_t and unit_result_t, and the
// latest Allan curve of each unit's axes (allan_curve_t). One listener for
// two screens: `imuqual run`'s terminal console (its own units and runs; its
// supervisor knows its processes) and `imuqual serve --bus`'s live page (any
// station on the bus, started by `imuqual run` or by hand on other hosts:
// units appear as their runs are announced; the processes are what their
// status messages say).
//
// The handlers are plain functions of the messages (tests call them
// directly); Attach() subscribes them to a bus. Not thread-safe: one thread
// handles the bus and reads the model.
#ifndef IMUQUAL_STATION_STATION_MONITOR_H_
#define IMUQUAL_STATION_STATION_MONITOR_H_

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "common/lcm_bus.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/allan_curve_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "station/station_console.h"

namespace imuqual::station {

struct MonitorOptions {
  // Only runs "<run_prefix>-<serial>" ("": every run on the bus).
  std::string run_prefix;
  // A run of a serial not added with AddUnit adds its unit (slot from the
  // run); a newer run of a unit (a later start) replaces its older one. A
  // new run (announced by acquire) when every unit shown is done (archived
  // with its final result) starts a new soak: the done units and the last
  // soak's processes leave; a new unit in the fixture slot of a done one
  // takes its row. Off: runs of other serials are ignored.
  bool discover_units = false;
  // Keep each axis's latest curve (Curves()).
  bool keep_curves = false;
  // With discover_units: a unit whose run was archived with its final result
  // this long ago leaves the model (a monitor that runs for days); 0: never.
  double forget_after_s = 0;
};

// The latest curve of one axis of a run, in datasheet units (deg/h for a
// gyro, ug for an accelerometer), at most kMaxLiveCurvePoints points.
struct LiveCurve {
  std::string axis, estimator, unit;
  bool is_final = false;
  int64_t samples = 0;
  int64_t host_utime = 0;  // when the analysis published it
  std::vector<double> tau_s, dev, lo, hi;
};
inline constexpr size_t kMaxLiveCurvePoints = 120;

class StationMonitor {
 public:
  explicit StationMonitor(MonitorOptions options = {});

  // A unit expected on this station, in slot order of the calls;
  // `device_paced`: its source is a device that paces it (a serial line:
  // silence means no data even before its run is announced).
  void AddUnit(std::string slot, std::string serial, bool device_paced = false);
  // Subscribes the handlers below to `bus` (now: MonotonicSeconds()).
  void Attach(LcmBus& bus);

  // The messages. `now`: monotonic seconds when heard.
  void OnStatus(const imuqual::status_t& s, double now);
  void OnRun(const imuqual::run_t& r);
  void OnDecision(const imuqual::decision_t& d);
  void OnAck(const imuqual::ack_t& a);
  void OnResult(const imuqual::unit_result_t& r);
  void OnCurve(const imuqual::allan_curve_t& c);

  // Per unit at `now`: how long its samples have not grown (a unit paced by
  // its device, a serial source, only) and whether acquire is reconnecting
  // its device. With `processes_from_status`, model().processes is what the
  // status messages say (a station not supervised by this process).
  void Refresh(double now, bool processes_from_status);

  ConsoleModel& model() { return model_; }
  const ConsoleModel& model() const { return model_; }

  // Whether a process of `kind` ("store", "analyze", "acquire") with pid
  // `pid` has reported on the bus.
  bool Reported(const std::string& kind, int pid) const;
  // Its last complaint (unhealthy status) heard within kComplaintS of `now`.
  std::string Problem(const std::string& kind, double now) const;
  // Serial -> why its run ended early (run_t.end_reason), as last heard.
  const std::map<std::string, std::string>& end_reasons() const { return end_reasons_; }
  // Whether the store's latest word on `run_id` is that it is wholly archived.
  bool RunArchived(const std::string& run_id) const { return archived_runs_.count(run_id) > 0; }
  // The latest curve of each axis of `unit`'s run (keep_curves), axis order.
  std::vector<LiveCurve> Curves(const ConsoleUnit& unit) const;
  // Raised by every message that changed what is shown.
  uint64_t version() const { return version_; }
  // host_utime of the newest result, decision or store acknowledgement
  // applied (0: none yet): when what the model shows was analysed or archived.
  int64_t newest_utime() const { return newest_utime_; }

  // A complaint shows this long after it was last heard; a process silent
  // this long is gone (status_t comes about once a second).
  static constexpr double kComplaintS = 3;
  static constexpr double kGoneS = 3.5;
  static constexpr double kStatusPeriodS = 1.0;
  // Bounds: what a bus (flooded, or forged: its seal is a checksum, not a
  // signature) can make the monitor keep.
  static constexpr size_t kMaxUnits = 2000;       // discovered units
  static constexpr size_t kMaxInstances = 256;    // processes heard
  static constexpr size_t kMaxEstimators = 4;     // curves per axis
  static constexpr double kForgetProcessS = 600;  // a process silent this long is forgotten

 private:
  struct Track {
    int64_t samples = -1;       // published samples when they last grew
    double grew_at = -1;        // monotonic s (-1: not yet)
    bool device_paced = false;  // a serial source: silence means no data
    int64_t start_utime = 0;
    double done_at = -1;  // archived with its final result (monotonic s)
    std::string station;  // of its run (discovered units)
  };
  struct Instance {
    std::string kind;
    double first_heard = 0, last_heard = 0;
    bool gone = false;                   // silent kGoneS at the last Refresh
    std::set<std::string> reconnecting;  // acquire: run ids whose device it is reconnecting
    // Messages its bus refused as forged, and as replayed (its latest status).
    int64_t unauthenticated = 0, replayed = 0;
  };
  ConsoleUnit* UnitOfRun(const std::string& run_id, const std::string& serial,
                         const imuqual::run_t* announcement);
  void Changed(int64_t utime = 0);
  void RemoveUnits(const std::function<bool(const ConsoleUnit&)>& which);
  void Forget(const std::string& instance_key, const std::string& kind);

  MonitorOptions options_;
  ConsoleModel model_;
  std::map<std::string, size_t> index_;  // serial -> model_.units
  std::map<std::string, Track> tracks_;  // serial ->
  std::map<std::string, std::string> end_reasons_;
  std::set<std::string> archived_runs_;
  std::map<std::string, Instance> instances_;  // "kind/host:pid" ->
  std::map<std::string, int> most_alive_;      // kind -> most instances alive at once
  struct Complaint {
    std::string message;
    double heard_s = 0;
  };
  std::map<std::pair<std::string, std::string>, Complaint> problems_;  // (kind, instance) ->
  std::set<std::string> superseded_seen_;          // instance keys found superseded
  std::map<std::string, int> forgotten_restarts_;  // kind -> restarts of forgotten instances
  // (run id, axis) -> estimator -> curve
  std::map<std::pair<std::string, std::string>, std::map<std::string, LiveCurve>> curves_;
  uint64_t version_ = 0;
  int64_t newest_utime_ = 0;
};

}  // namespace imuqual::station

#endif  // IMUQUAL_STATION_STATION_MONITOR_H_
