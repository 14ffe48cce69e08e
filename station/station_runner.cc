#include "station/station_runner.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include "acquire/lot_profile.h"
#include "acquire/units.h"
#include "analyze/judge/early_decision.h"
#include "analyze/judge/plan_file.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/keys.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/strings.h"
#include "common/subprocess.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "station/preflight.h"
#include "station/station_console.h"
#include "station/station_monitor.h"
#include "store/archive.h"
#include "store/outcome.h"
#include "store/query.h"
#include "store/store_service.h"

namespace imuqual::station {
namespace {

constexpr double kStartTimeoutS = 20;    // store/analyze must report by then
constexpr double kStopTimeoutS = 15;     // SIGTERM -> SIGKILL
constexpr double kAbortDrainS = 30;      // after Ctrl-C: time for aborted runs to be archived
constexpr double kAcquireEndS = 5;       // all archived: time for acquire's final acks
constexpr double kSettleLeftOpenS = 60;  // beyond the silence timer: runs left open earlier
constexpr double kRestartDelayS = 1;     // a dead store/analyze is restarted after this
constexpr double kCrashWindowS = 60;     // restarts counted over this window
constexpr double kRedrawS = 0.25;        // live console refresh
constexpr double kLogLineS = 10;         // progress line when not on a terminal

// The source of a unit given as SERIAL=SOURCE.
Result<acquire::SourceSpec> UnitSourceSpec(const std::string& unit) {
  const size_t eq = unit.find('=');
  return acquire::ParseSourceSpec(eq == std::string::npos ? "" : unit.substr(eq + 1));
}

std::string CompactUtc(int64_t utime) {
  std::string out;
  for (char c : FormatUtimeIso(utime)) {
    if (c != '-' && c != ':') out += c;
  }
  return out;
}

// A rate as text, exactly (it is passed on to imuqual-acquire).
std::string FormatRate(double hz) { return ShortestReal(hz); }

// A port of its own for this station run (20000..59999).
int PickPort() {
  std::random_device rd;
  std::mt19937 gen(rd() ^ static_cast<unsigned>(::getpid()));
  return 20000 + static_cast<int>(gen() % 40000);
}

std::string LogTail(const std::string& path, int lines) {
  auto text = ReadFileToString(path);
  if (!text.ok()) return "";
  const std::string& t = *text;
  size_t pos = t.size();
  for (int n = 0; n <= lines && pos > 0; ++n) {
    pos = t.rfind('\n', pos - 1);
    if (pos == std::string::npos) {
      pos = 0;
      break;
    }
  }
  return t.substr(pos == 0 ? 0 : pos + 1);
}

// A store or analyze process under supervision: restarted when it dies.
struct Supervised {
  std::string name;  // "imuqual-store", "imuqual-analyze 1/3"
  std::string kind;  // "store", "analyze" (status_t.process)
  std::vector<std::string> argv;
  std::optional<Subprocess> proc;
  double restart_at = -1;  // > 0: dead, restart due then
  int restarts = 0;
  std::vector<double> crashes;  // when it died, within kCrashWindowS
};

// The station's processes. However RunStation ends, they are stopped in
// order (source, analysis, archive), each given time to drain.
struct Children {
  std::optional<Subprocess> acquire;
  std::vector<Supervised> analyze;
  std::optional<Supervised> store;
  ~Children() {
    if (acquire) acquire->Stop(kStopTimeoutS);
    for (Supervised& a : analyze) {
      if (a.proc) a.proc->Stop(kStopTimeoutS);
    }
    if (store && store->proc) store->proc->Stop(kStopTimeoutS);
  }
};

// The live console on a terminal: drawn over the screen from the top,
// cursor hidden; restored however the run ends.
class LiveScreen {
 public:
  // Colour unless NO_COLOR is set to anything but "" (no-color.org).
  explicit LiveScreen(bool on) : on_(on) {
    const char* no_color = std::getenv("NO_COLOR");
    color_ = no_color == nullptr || *no_color == '\0';
    if (on_) std::fputs("\x1b[?25l\x1b[H\x1b[2J", stderr);
  }
  ~LiveScreen() { Close(); }
  void Draw(const ConsoleModel& model) {
    if (!on_) return;
    struct winsize ws {};
    int width = 100, height = 40;
    if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0 && ws.ws_row > 0) {
      width = ws.ws_col;
      height = ws.ws_row;
    }
    std::string frame = "\x1b[H";
    for (const std::string& line : RenderConsole(model, width, height - 1, color_))
      frame += line + "\x1b[K\n";
    frame += "\x1b[J";
    std::fputs(frame.c_str(), stderr);
    std::fflush(stderr);
  }
  // Clears the console for the final report.
  void Close() {
    if (!on_) return;
    std::fputs("\x1b[H\x1b[J\x1b[?25h", stderr);
    std::fflush(stderr);
    on_ = false;
  }

 private:
  bool on_;
  bool color_ = false;
};

}  // namespace

namespace {

// The station's own keys on its bus (it listens as "station"), after every
// role's keys were read and checked against the trust file: a bad key file
// stops the station before any process starts.
Result<BusSecurity> LoadStationSecurity(const StationRunOptions& o) {
  BusSecurityFiles files;
  files.key_file = o.key_file;
  files.trust_file = o.trust_file;
  files.insecure_bus = o.insecure_bus;
  const std::pair<BusRole, const std::string*> roles[] = {{BusRole::kAcquire, &o.acquire_sign_key},
                                                          {BusRole::kAnalyze, &o.analyze_sign_key},
                                                          {BusRole::kStore, &o.store_sign_key}};
  for (const auto& [role, key] : roles) {
    if (key->empty()) {
      if (!o.trust_file.empty()) {
        return Status::InvalidArgument(std::string("a trust file is given (") + o.trust_file + "): the " +
                                       RoleName(role) + " process needs its signing key too (" +
                                       RoleName(role) + "_sign_key, or --sign-key " + RoleName(role) +
                                       "=FILE)");
      }
      continue;
    }
    files.sign_key = *key;
    auto loaded = files.Load(role);
    if (!loaded.ok()) return loaded.status();
  }
  files.sign_key.clear();
  return files.Load(BusRole::kStation);
}

// The flags that give a child process its keys and choices on the bus.
std::vector<std::string> SecurityArgs(const StationRunOptions& o, const std::string& sign_key) {
  std::vector<std::string> args;
  if (!o.key_file.empty()) args.insert(args.end(), {"--key-file", o.key_file});
  if (!o.trust_file.empty()) args.insert(args.end(), {"--trust", o.trust_file});
  if (!sign_key.empty()) args.insert(args.end(), {"--sign-key", sign_key});
  if (o.insecure_bus) args.push_back("--insecure-bus");
  return args;
}

}  // namespace

Status StationRunOptions::Validate() const {
  if (sim_units < 0 || sim_units > 1000) return Status::InvalidArgument("--sim must be 0..1000");
  if (sim_units == 0 && units.empty()) {
    return Status::InvalidArgument("no units: give --sim N and/or --unit SERIAL=SOURCE");
  }
  if (sim_units > 0 && (!(duration_s > 0) || !std::isfinite(duration_s))) {
    return Status::InvalidArgument("--duration must be > 0 s");
  }
  if (rate_hz && !(*rate_hz > 0 && std::isfinite(*rate_hz))) {
    return Status::InvalidArgument("--rate " + FormatRate(*rate_hz) +
                                   ": must be a positive, finite rate in Hz");
  }
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("--lot", lot));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("--station", station));
  if (db_path.empty()) return Status::InvalidArgument("--db is required");
  if (!(inject_drop >= 0 && inject_drop < 1)) {
    return Status::InvalidArgument("--inject-drop must be in [0, 1)");
  }
  if (!(pace >= 0) || !std::isfinite(pace)) return Status::InvalidArgument("--pace must be >= 0");
  if (!(archive_timeout_s > 0)) return Status::InvalidArgument("--archive-timeout must be > 0");
  if (!(give_up_s > 0)) return Status::InvalidArgument("--give-up must be > 0");
  if (analyze_shards < 1 || analyze_shards > 64)
    return Status::InvalidArgument("--analyze-shards must be 1..64");
  if (!slots.empty() && slots.size() != units.size()) {
    return Status::InvalidArgument("slots: one per --unit");
  }
  if (!unit_locations.empty() && unit_locations.size() != units.size()) {
    return Status::InvalidArgument("unit_locations: one per --unit");
  }
  return Status::Ok();
}

namespace {

// A station key made for one soak when none is configured (and the bus is
// this host's): LCM's socket takes datagrams from any host that can reach
// its port, whatever the ttl, so even a one-host station authenticates its
// messages. Kept in a directory only this user can read, removed with it.
class SoakKey {
 public:
  static Result<SoakKey> Make() {
    char tmpl[] = "/tmp/imuqual-soak-key-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) {
      return Status::IoError(std::string("cannot make a directory for the soak's key: ") +
                             std::strerror(errno));
    }
    SoakKey k(tmpl);
    auto key = GenerateStationKey();
    if (!key.ok()) return key.status();
    IMUQUAL_RETURN_IF_ERROR(WriteStationKeyFile(k.path(), *key));
    return k;
  }
  SoakKey(SoakKey&& o) noexcept : dir_(std::move(o.dir_)) { o.dir_.clear(); }
  SoakKey(const SoakKey&) = delete;
  ~SoakKey() {
    if (dir_.empty()) return;
    ::unlink(path().c_str());
    ::rmdir(dir_.c_str());
  }
  std::string path() const { return dir_ + "/station.key"; }

 private:
  explicit SoakKey(std::string dir) : dir_(std::move(dir)) {}
  std::string dir_;
};

}  // namespace

Result<StationRunResult> RunStation(const StationRunOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  StationRunOptions given = options;
  std::optional<SoakKey> soak_key;
  if (given.key_file.empty() && !given.insecure_bus &&
      (given.lcm_url.empty() || BusTtl(given.lcm_url) == 0)) {
    auto key = SoakKey::Make();
    if (!key.ok()) return key.status();
    soak_key.emplace(std::move(*key));
    given.key_file = soak_key->path();
  }
  auto security = LoadStationSecurity(given);
  if (!security.ok()) return security.status();
  auto profile = sim::LotProfileByName(given.profile);
  if (!profile.ok()) return profile.status();
  std::string plan_spec = given.plan_spec;
  if (plan_spec.empty() && given.profile == "vg700" && given.units.empty()) {
    plan_spec = "builtin:vg700ca";
  }
  std::string plan_name = "(none)";
  std::optional<pb::TestPlan> plan;
  if (!plan_spec.empty()) {
    auto loaded = judge::LoadPlan(plan_spec);  // fail here, not in a child
    if (!loaded.ok()) return loaded.status();
    plan = std::move(*loaded);
    plan_name = plan->name().empty() ? plan_spec : plan->name();
    if (plan->require_operator() && IsBlank(given.operator_name)) {
      return Status::InvalidArgument("plan " + plan_name +
                                     " requires an operator: give --operator NAME (or "
                                     "operator_name in the station file)");
    }
  }
  StationRunResult result;
  // Pre-flight: every problem of the station at once, before any process.
  StationRunOptions checked = given;
  {
    const PreflightResult pre = Preflight(given, plan ? &*plan : nullptr);
    const bool skip = given.skip_failed_slots && !pre.station_problem &&
                      pre.failed_units.size() < given.units.size() + (given.sim_units > 0 ? 1 : 0);
    if (!pre.problems.empty() && !skip) {
      // One problem: one line; several: one line each under a count.
      std::string text = pre.problems.size() == 1
                             ? "pre-flight: " + pre.problems.front() + "; nothing started"
                             : "pre-flight: " + std::to_string(pre.problems.size()) +
                                   " problems, nothing started:";
      for (const std::string& p : pre.problems) {
        if (pre.problems.size() > 1) text += "\n  " + p;
      }
      if (!pre.station_problem && !pre.failed_units.empty() &&
          pre.failed_units.size() < given.units.size() + (given.sim_units > 0 ? 1 : 0)) {
        text += "\n  (--skip-failed-slots runs the other slots without them)";
      }
      return Status::InvalidArgument(text);
    }
    // Skipped: the failed units leave units, slots and locations together.
    // The others keep what they were: their slot (an unnamed one is numbered
    // by its place in the whole station) and, for a simulated unit without
    // index=, the simulated unit of its place.
    if (!pre.failed_units.empty()) {
      checked.slots.resize(checked.units.size());
      for (size_t i = 0; i < checked.units.size(); ++i) {
        if (checked.slots[i].empty())
          checked.slots[i] = std::to_string(given.sim_units + static_cast<int>(i) + 1);
        std::string& unit = checked.units[i];
        auto spec = UnitSourceSpec(unit);
        if (spec.ok() && spec->kind == "sim" && spec->options.count("index") == 0) {
          unit += ",index=" + std::to_string(i);
        }
      }
    }
    for (size_t k = pre.failed_units.size(); k-- > 0;) {
      const size_t i = pre.failed_units[k];
      checked.units.erase(checked.units.begin() + static_cast<std::ptrdiff_t>(i));
      if (i < checked.slots.size())
        checked.slots.erase(checked.slots.begin() + static_cast<std::ptrdiff_t>(i));
      if (i < checked.unit_locations.size()) {
        checked.unit_locations.erase(checked.unit_locations.begin() +
                                     static_cast<std::ptrdiff_t>(i));
      }
    }
    for (const std::string& p : pre.problems) {
      LogWarning("skipped: " + p);
      result.skipped.push_back(p);
    }
  }
  const StationRunOptions& o = checked;
  // Runs of this station that an earlier station process left open (killed
  // outright, a power cut): the store resumes them, finds their source
  // silent and ends them incomplete, and the analysis judges them ERROR.
  // The station waits for that too (bounded), so that the archive holds no
  // open run once it is done.
  std::set<std::string> left_open;
  {
    // A bad archive file fails before any process starts.
    auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kWrite);
    if (!archive.ok()) return archive.status();
    auto open_runs = store::QueryOpenRunIds(**archive, o.station);
    if (!open_runs.ok()) return open_runs.status();
    left_open.insert(open_runs->begin(), open_runs->end());
    // The station in every run id: two stations never mint the same one.
    // The same station started again within the second of its last start
    // (a script's quick retest) would: it waits for the next second.
    std::vector<std::string> serials;
    for (int i = 0; i < o.sim_units; ++i) serials.push_back(acquire::SimSerial(o.lot, i));
    for (const std::string& u : o.units) serials.push_back(u.substr(0, u.find('=')));
    for (int attempt = 0;; ++attempt) {
      const int64_t now = NowUtime();
      result.run_prefix = CompactUtc(now) + "-" + o.station;
      bool collides = false;
      for (const std::string& serial : serials) {
        auto taken = (*archive)->FindRunKey(result.run_prefix + "-" + serial);
        if (!taken.ok()) return taken.status();
        collides = collides || taken->has_value();
      }
      if (!collides) break;
      if (attempt >= 5) {
        return Status::InvalidArgument("run ids " + result.run_prefix +
                                       "-* are already in the archive (has the clock gone "
                                       "back?): not starting runs that would collide");
      }
      std::this_thread::sleep_for(std::chrono::microseconds(1'000'000 - now % 1'000'000 + 1000));
    }
  }
  result.left_open.assign(left_open.begin(), left_open.end());
  result.log_path = o.db_path + ".log";
  std::string url = o.lcm_url;
  if (url.empty()) {
    BusAddress address;
    address.port = PickPort();
    url = address.ToUrl();
  }
  auto bus_or = LcmBus::Open(url, std::move(*security));
  if (!bus_or.ok()) return bus_or.status();
  LcmBus& bus = **bus_or;

  // What the operator sees, one entry per unit in slot order, as heard on the bus.
  MonitorOptions monitor_options;
  monitor_options.run_prefix = result.run_prefix;
  StationMonitor monitor(monitor_options);
  ConsoleModel& model = monitor.model();
  model.station = o.station;
  model.lot = o.lot;
  model.plan = plan_name;
  model.operator_name = o.operator_name;
  model.bus = url;
  model.archive = o.db_path;
  model.planned_s = o.duration_s;
  for (int i = 0; i < o.sim_units; ++i)
    monitor.AddUnit(std::to_string(i + 1), acquire::SimSerial(o.lot, i));
  for (size_t i = 0; i < o.units.size(); ++i) {
    const std::string slot = i < o.slots.size() && !o.slots[i].empty()
                                 ? o.slots[i]
                                 : std::to_string(o.sim_units + static_cast<int>(i) + 1);
    auto spec = UnitSourceSpec(o.units[i]);
    monitor.AddUnit(slot, o.units[i].substr(0, o.units[i].find('=')),
                    spec.ok() && spec->kind == "serial");
  }
  monitor.Attach(bus);

  {
    auto header = ReadFileToString(result.log_path);
    std::string text = header.ok() ? *header : "";
    text += "=== imuqual run " + result.run_prefix + " lot " + o.lot + " on " + url + "\n";
    IMUQUAL_RETURN_IF_ERROR(WriteStringToFile(result.log_path, text));
  }
  const std::string dir = ExecutableDir();
  Children children;
  auto supervised_process = [](std::string name, std::string kind, std::vector<std::string> argv) {
    Supervised p;
    p.name = std::move(name);
    p.kind = std::move(kind);
    p.argv = std::move(argv);
    return p;
  };
  children.store = supervised_process(
      "imuqual-store", "store",
      {dir + "/imuqual-store", "--lcm-url", url, "--db", o.db_path, "--stale-after",
       std::to_string(o.stale_after_s), "--give-up", std::to_string(o.give_up_s), "--write-give-up",
       std::to_string(o.archive_timeout_s), "--station", o.station});
  for (std::string& a : SecurityArgs(o, o.store_sign_key)) children.store->argv.push_back(std::move(a));
  if (!o.sync_to.empty()) children.store->argv.insert(children.store->argv.end(), {"--sync-to", o.sync_to});
  // The plan this station runs is the only one its store and analyze take.
  if (!plan_spec.empty()) children.store->argv.insert(children.store->argv.end(), {"--accept-plan", plan_spec});
  for (int k = 0; k < o.analyze_shards; ++k) {
    Supervised a =
        supervised_process("imuqual-analyze", "analyze",
                           {dir + "/imuqual-analyze", "--lcm-url", url, "--station", o.station});
    for (std::string& arg : SecurityArgs(o, o.analyze_sign_key)) a.argv.push_back(std::move(arg));
    if (!plan_spec.empty()) a.argv.insert(a.argv.end(), {"--accept-plan", plan_spec});
    if (o.analyze_shards > 1) {
      const std::string shard = std::to_string(k) + "/" + std::to_string(o.analyze_shards);
      a.name += " " + shard;
      a.argv.insert(a.argv.end(), {"--shard", shard});
    }
    children.analyze.push_back(std::move(a));
  }
  std::vector<Supervised*> supervised = {&*children.store};
  for (Supervised& a : children.analyze) supervised.push_back(&a);
  for (Supervised* p : supervised) {
    auto started = Subprocess::Start(p->argv, result.log_path);
    if (!started.ok()) return started.status();
    p->proc = std::move(*started);
  }

  auto failure = [&](const std::string& what) {
    return Status::Unavailable(what + "; last lines of " + result.log_path + ":\n" +
                               LogTail(result.log_path, 8));
  };
  auto reported = [&](const Supervised& p) {
    return p.proc && monitor.Reported(p.kind, p.proc->pid());
  };
  // Wait until store and analyze are up and listening.
  const double start_deadline = MonotonicSeconds() + kStartTimeoutS;
  for (;;) {
    bool all = true;
    for (Supervised* p : supervised) {
      if (auto code = p->proc->Poll())
        return failure(p->name + " exited (code " + std::to_string(*code) + ")");
      all = all && reported(*p);
    }
    if (all) break;
    if (MonotonicSeconds() > start_deadline) return failure("imuqual-store/analyze did not start");
    if (ShutdownRequested()) return Status::Unavailable("interrupted before the soak started");
    IMUQUAL_RETURN_IF_ERROR(bus.HandleFor(50));
  }

  std::vector<std::string> acquire_args = {dir + "/imuqual-acquire",
                                           "--lcm-url",
                                           url,
                                           "--lot",
                                           o.lot,
                                           "--station",
                                           o.station,
                                           "--profile",
                                           o.profile,
                                           "--run-prefix",
                                           result.run_prefix,
                                           "--await",
                                           "store,analyze"};
  if (o.sim_units > 0)
    acquire_args.insert(acquire_args.end(), {"--sim", std::to_string(o.sim_units)});
  if (o.duration_s > 0)
    acquire_args.insert(acquire_args.end(), {"--duration", std::to_string(o.duration_s)});
  for (const std::string& unit : o.units) acquire_args.insert(acquire_args.end(), {"--unit", unit});
  for (size_t i = 0; i < o.slots.size(); ++i) {
    acquire_args.insert(acquire_args.end(),
                        {"--slot", model.units[static_cast<size_t>(o.sim_units) + i].slot});
  }
  if (o.rate_hz) acquire_args.insert(acquire_args.end(), {"--rate", FormatRate(*o.rate_hz)});
  if (!plan_spec.empty()) acquire_args.insert(acquire_args.end(), {"--plan", plan_spec});
  if (!o.operator_name.empty())
    acquire_args.insert(acquire_args.end(), {"--operator", o.operator_name});
  if (o.inject_drop > 0) {
    acquire_args.insert(acquire_args.end(), {"--inject-drop", std::to_string(o.inject_drop)});
  }
  if (o.pace > 0) acquire_args.insert(acquire_args.end(), {"--pace", std::to_string(o.pace)});
  for (std::string& a : SecurityArgs(o, o.acquire_sign_key)) acquire_args.push_back(std::move(a));
  {
    auto started = Subprocess::Start(acquire_args, result.log_path);
    if (!started.ok()) return started.status();
    children.acquire = std::move(*started);
  }
  std::optional<Subprocess>& acquire = children.acquire;

  const bool tty = o.show_progress && ::isatty(STDERR_FILENO);
  LiveScreen screen(tty);
  const double t0 = MonotonicSeconds();
  double last_change = t0, last_draw = t0 - kRedrawS, last_line = t0;
  double drain_deadline = -1;   // set when the runs are ending abnormally
  double settle_deadline = -1;  // set when only runs left open earlier remain
  int64_t last_total = -1;
  int last_done = -1;
  Status outcome;
  auto notice = [&](const std::string& text) {
    model.notice = text;
    if (!tty) LogWarning(text);
  };
  for (;;) {
    IMUQUAL_RETURN_IF_ERROR(bus.HandleFor(100));
    const double now = MonotonicSeconds();
    int64_t published = 0;
    int done = 0, announced = 0;
    for (const ConsoleUnit& u : model.units) {
      published += u.samples;
      done += u.archived;
      announced += !u.run_id.empty();
    }
    if (published != last_total || done != last_done) {
      last_total = published;
      last_done = done;
      last_change = now;
    }
    // Supervision: a dead store or analyze process is restarted; it catches
    // up from the source's retention and the archive.
    for (Supervised* p : supervised) {
      if (p->restart_at < 0) {
        if (auto code = p->proc->Poll()) {
          if (p->kind == "store" && *code == store::kStoreExitUnwritable) {
            // Restarting cannot free the disk: the station stops, nothing
            // unarchived was acknowledged.
            outcome = Status::ResourceExhausted("imuqual-store could not write the archive " + o.db_path +
                                      "; last lines of " + result.log_path + ":\n" +
                                      LogTail(result.log_path, 8));
            break;
          }
          p->crashes.push_back(now);
          std::erase_if(p->crashes, [&](double t) { return now - t > kCrashWindowS; });
          if (static_cast<int>(p->crashes.size()) > o.max_restarts) {
            outcome = failure(p->name + " died " + std::to_string(p->crashes.size()) +
                              " times in " + std::to_string(static_cast<int>(kCrashWindowS)) +
                              " s (last exit code " + std::to_string(*code) + ")");
            break;
          }
          p->restart_at = now + kRestartDelayS;
          notice(p->name + " exited (code " + std::to_string(*code) + "); restarting it");
        }
      } else if (now >= p->restart_at) {
        auto started = Subprocess::Start(p->argv, result.log_path);
        if (!started.ok()) {
          outcome = started.status();
          break;
        }
        p->proc = std::move(*started);
        p->restart_at = -1;
        ++p->restarts;
        ++result.restarts;
        notice(p->name + " restarted (pid " + std::to_string(p->proc->pid()) + "); catching up");
      }
    }
    if (!outcome.ok()) break;

    model.wall_s = now - t0;
    model.processes.clear();
    {
      ConsoleProcess store_p, analyze_p, acquire_p;
      store_p.name = "store";
      store_p.running = children.store->restart_at < 0 ? 1 : 0;
      store_p.restarts = children.store->restarts;
      analyze_p.name = "analyze";
      analyze_p.expected = static_cast<int>(children.analyze.size());
      for (const Supervised& a : children.analyze) {
        analyze_p.running += a.restart_at < 0;
        analyze_p.restarts += a.restarts;
      }
      acquire_p.name = "acquire";
      acquire_p.running = acquire->Poll() ? 0 : 1;
      for (ConsoleProcess* cp : {&store_p, &analyze_p, &acquire_p}) {
        // A complaint stands while its process keeps reporting it (a dead
        // process's last words fade after a few seconds).
        cp->problem = monitor.Problem(cp->name, now);
        model.processes.push_back(*cp);
      }
    }
    // A unit whose samples stopped growing: how long (a silent serial unit).
    monitor.Refresh(now, /*processes_from_status=*/false);
    std::erase_if(left_open, [&](const std::string& run) { return monitor.RunArchived(run); });
    if (tty && now - last_draw >= kRedrawS) {
      screen.Draw(model);
      last_draw = now;
    } else if (o.show_progress && !tty && now - last_line >= kLogLineS) {
      std::fprintf(stderr, "%s\n", ConsoleSummaryLine(model).c_str());
      last_line = now;
    }

    if (done >= static_cast<int>(model.units.size())) {
      if (left_open.empty()) break;
      if (settle_deadline < 0) {
        settle_deadline = now + o.stale_after_s + kSettleLeftOpenS;
        notice(std::to_string(left_open.size()) +
               " run(s) left open by an earlier station process: waiting for them to be judged");
      }
      if (now > settle_deadline) break;
    }
    if (ShutdownRequested() && drain_deadline < 0) {
      drain_deadline = now + kAbortDrainS;
      result.interrupted = true;
      notice("interrupted: aborting the runs and archiving what was measured ...");
      acquire->Signal(SIGTERM);
    }
    // Aborted: done once the source has ended and every announced run is archived.
    if (result.interrupted && acquire->Poll() && done >= announced) break;
    if (drain_deadline >= 0 && now > drain_deadline) break;
    if (auto code = acquire->Poll(); code && *code != 0 && announced == 0) {
      // It failed before announcing anything (a bad source or plan): nothing to wait for.
      outcome = failure("imuqual-acquire failed (exit " + std::to_string(*code) + ")");
      if (*code == 2) outcome = Status::InvalidArgument(outcome.message());  // it refused its input
      break;
    }
    if (auto code = acquire->Poll(); code && *code != 0 && drain_deadline < 0) {
      // A unit's source failed (its run is aborted) or acquire died (the
      // store ends its runs as incomplete once it has been silent for
      // stale_after_s): wait for the runs to be archived, then report.
      drain_deadline = now + o.stale_after_s + kAbortDrainS;
      notice("imuqual-acquire ended with code " + std::to_string(*code) +
             "; waiting for its runs to be archived");
    }
    if (now - last_change > o.stall_timeout_s) {
      outcome = failure("the station made no progress for " +
                        std::to_string(static_cast<int>(o.stall_timeout_s)) + " s");
      break;
    }
  }
  screen.Close();
  // Stop in order: the source first (it normally ends by itself once its
  // last acknowledgements arrive), then analysis, then the archive (which
  // drains and commits what it holds).
  std::optional<int> acquire_code;
  if (outcome.ok() && !result.interrupted) acquire_code = acquire->Wait(kAcquireEndS);
  acquire->Stop(kStopTimeoutS);
  // A unit's source that failed (bad data, a device gone) aborted that run
  // only: every run may be archived by now, before acquire's exit code was
  // looked at, so the runs' end states say it.
  if (outcome.ok() && !result.interrupted) {
    std::vector<std::string> failed;
    for (const ConsoleUnit& u : model.units) {
      const bool ended_early =
          u.state == imuqual::run_t::STATE_ABORTED || u.state == imuqual::run_t::STATE_INCOMPLETE;
      if (!ended_early) continue;
      auto reason = monitor.end_reasons().find(u.serial);
      failed.push_back(u.serial + " (" +
                       (reason == monitor.end_reasons().end() ? "ended early" : reason->second) +
                       ")");
    }
    if (!failed.empty()) {
      result.failure =
          std::to_string(failed.size()) + " of " + std::to_string(model.units.size()) +
          " units' sources failed, their runs archived as ERROR: " + Join(failed, "; ");
    } else if (acquire_code && *acquire_code != 0) {
      result.failure = "imuqual-acquire failed (exit " + std::to_string(*acquire_code) +
                       "); its runs are archived as they ended. Last lines of " + result.log_path +
                       ":\n" + LogTail(result.log_path, 6);
    }
  }
  for (Supervised& a : children.analyze) {
    if (a.proc) a.proc->Stop(kStopTimeoutS);
  }
  const int store_code = children.store->proc->Stop(kStopTimeoutS);
  if (!outcome.ok()) return outcome;
  if (store_code == store::kStoreExitUnwritable) {
    return Status::ResourceExhausted("imuqual-store could not write the archive " + o.db_path +
                           " at the end; last lines of " + result.log_path + ":\n" +
                           LogTail(result.log_path, 8));
  }
  if (store_code != 0 && !result.interrupted) {
    return failure("imuqual-store ended with code " + std::to_string(store_code));
  }
  for (const ConsoleUnit& u : model.units) {
    if (!u.run_id.empty()) result.run_ids.push_back(u.run_id);
  }
  return result;
}

}  // namespace imuqual::station
