// The live station page's data: a thread that listens to a station bus
// (station/station_monitor.h: units discovered from their runs, processes
// from their status messages, each axis's latest Allan curve) and keeps the
// latest snapshot as JSON for the server to push (server-sent events).
//
//   status event: the console's content, one JSON object:
//     {"station","lot","plan","operator","bus","archive","wall_s","progress",
//      "processes_line","processes":[{"name","running","expected","restarts","problem"}],
//      "tally","newest_utime","sent_utime","all_done",
//      "units":[{"slot","serial","run_id","verdict","outcome","final","reason",
//                "state","elapsed","samples","gap_samples","archived","attention",
//                "axes":[{"name","verdict","bias_instability"}]}]}
//     verdict/state/elapsed/axes are the console's words (DescribeUnit);
//     outcome is the verdict's word (PASS, FAIL, ...; "" before one);
//     newest_utime is when the newest result or acknowledgement shown was
//     published (the page measures its update latency from it).
//   curve event: one axis of one run, in datasheet units:
//     {"serial","run_id","axis","estimator","unit","final","samples",
//      "tau_s":[],"dev":[],"lo":[],"hi":[]}   (null where a bound is missing)
#ifndef IMUQUAL_WEB_LIVE_FEED_H_
#define IMUQUAL_WEB_LIVE_FEED_H_

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/status.h"
#include "station/station_console.h"
#include "station/station_monitor.h"

namespace imuqual::web {

// The JSON documents above, from a model (pure).
std::string LiveStatusJson(const station::ConsoleModel& model, int64_t newest_utime);
std::string LiveCurveJson(const std::string& serial, const std::string& run_id,
                          const station::LiveCurve& curve);

class LiveFeed {
 public:
  // Listens on `bus_url` (an LCM URL) with `security`'s keys (as the
  // monitor role); `archive_label` names the archive on the page. The error
  // names the URL.
  static Result<std::unique_ptr<LiveFeed>> Open(const std::string& bus_url,
                                                const std::string& archive_label,
                                                BusSecurity security = {});
  ~LiveFeed();  // stops the thread

  // What one reader (an event stream) has seen.
  struct Cursor {
    uint64_t status_seq = 0;
    std::map<std::string, int64_t> curve_stamps;  // "run\naxis" -> stamp sent
    std::map<std::string, double> curve_sent_at;  // "run\naxis" -> monotonic s
  };
  // Waits up to `timeout` for something newer than `cursor` has seen, then
  // returns the events to send ("event: status\ndata: ...\n\n", "event:
  // curve..."), advancing `cursor`; "" when nothing came (or stopping). An
  // interim curve is re-sent at most every kCurvePeriodS per axis.
  std::string NextEvents(Cursor* cursor, std::chrono::milliseconds timeout);
  // The latest status document, and the latest curves of a run (a JSON array).
  std::string StatusJson() const;
  std::string CurvesJson(const std::string& run_id) const;
  bool stopping() const;
  // The lot of the latest snapshot when every unit shown is archived with
  // its final result (the soak is over), else "".
  std::string DoneLot() const;

  static constexpr double kSnapshotS = 0.2;  // at most this often
  static constexpr double kCurvePeriodS = 2.0;

 private:
  struct Impl;
  explicit LiveFeed(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_LIVE_FEED_H_
