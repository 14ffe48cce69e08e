// A station assembled by hand for fault tests: each process started (and
// killed) on its own, and a listener on the bus that follows status reports
// and run completions. Bounded waits only, never sleeps that hope.
#ifndef IMUQUAL_TESTS_STATION_HARNESS_H_
#define IMUQUAL_TESTS_STATION_HARNESS_H_

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "common/lcm_bus.h"
#include "common/subprocess.h"
#include "tests/test_util.h"

namespace imuqual::testing {

// What a harness station authenticates its bus with.
enum class HarnessKeys {
  kNone,             // no station key (one host, ttl=0)
  kStation,          // a station key for every process
  kStationAndRoles,  // and a signing key per role, with the trust file
};

class StationHarness {
 public:
  // A temp dir (archive, logs) and a bus of its own (fresh port, ttl=0).
  // With keys, they are made in the temp dir, every imuqual-acquire,
  // -analyze and -store started here gets its flags, and the harness's bus
  // listens with them.
  // `keys_of`: take that station's keys instead of making new ones (a
  // station whose recorded traffic is played to this one).
  explicit StationHarness(const std::string& tag, HarnessKeys keys = HarnessKeys::kNone,
                          const StationHarness* keys_of = nullptr);

  const std::string& url() const { return url_; }
  const std::string& db() const { return db_; }
  std::string log() const { return dir_.path("processes.log"); }
  std::string path(const std::string& name) const { return dir_.path(name); }

  Subprocess Start(const std::string& program, const std::vector<std::string>& args);
  // Starts imuqual-store / imuqual-analyze with short recovery timers (which
  // `extra` may set otherwise) and waits until each reports on the bus.
  Subprocess StartStore(const std::vector<std::string>& extra = {});
  Subprocess StartAnalyze(const std::vector<std::string>& extra = {});

  // Dispatches bus messages for up to `ms`.
  void Pump(int ms);
  // Waits (bounded) until `n` runs are archived with their final result
  // (store run_done acks). True if they were.
  bool WaitRunsDone(size_t n, double timeout_s);
  // Waits until `process` has reported (status_t) from pid `pid`.
  bool WaitReported(const std::string& process, pid_t pid, double timeout_s);
  // Last status counter of a process ("store", "analyze", "acquire"); -1 if none.
  int64_t Counter(const std::string& process, const std::string& name) const;
  // The last value of a counter of the process with pid `pid` (-1 if none).
  int64_t CounterOf(pid_t pid, const std::string& name) const;
  // Waits (bounded) until that counter reaches `at_least`; its last value.
  int64_t WaitCounter(const std::string& process, const std::string& name, int64_t at_least,
                      double timeout_s);
  const std::set<std::string>& runs_done() const { return runs_done_; }
  const std::set<std::string>& runs_seen() const { return runs_seen_; }
  // The processes' combined output, for failure messages.
  std::string Logs() const;
  // The harness's own connection to the bus (a tool: it listens, and may
  // publish on channels outside the station's contract).
  LcmBus& bus() { return *bus_; }
  // A connection that plays `role` with the station's keys (that role's
  // signing key too): an insider, or a test's stand-in for a process.
  LcmBus& BusAs(BusRole role);
  // The key files ("" without keys) and the flags a process of `role` gets.
  std::string key_file() const;
  std::string trust_file() const;
  std::string sign_key(BusRole role) const;
  std::vector<std::string> SecurityArgs(BusRole role) const;
  // This station's keys as a process of `role` holds them.
  BusSecurity Security(BusRole role) const;
  // Highest next_seq the store acknowledged for a run (-1 if none).
  int64_t StoreAcked(const std::string& run_id) const {
    auto it = store_acked_.find(run_id);
    return it == store_acked_.end() ? -1 : it->second;
  }

 private:
  TempDir dir_;
  HarnessKeys keys_;
  std::string url_;
  std::map<BusRole, std::unique_ptr<LcmBus>> role_buses_;
  std::string db_;
  std::unique_ptr<LcmBus> bus_;
  std::set<std::string> runs_done_;
  std::set<std::string> runs_seen_;
  std::map<std::string, int64_t> store_acked_;
  std::map<std::string, std::string> instance_;  // process -> last instance
  std::map<std::string, std::map<std::string, int64_t>> counters_;
  std::map<std::string, std::map<std::string, int64_t>> instance_counters_;  // by host:pid
};

}  // namespace imuqual::testing

#endif  // IMUQUAL_TESTS_STATION_HARNESS_H_
