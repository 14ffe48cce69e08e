#include "store/cli/station_runner.h"

#include <csignal>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>

#include "acquire/lot_profile.h"
#include "analyze/judge/plan_file.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/subprocess.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "store/archive.h"

namespace imuqual::cli {
namespace {

constexpr double kStartTimeoutS = 20;   // store/analyze must report by then
constexpr double kStopTimeoutS = 15;    // SIGTERM -> SIGKILL
constexpr double kAbortDrainS = 30;     // after Ctrl-C: time for aborted runs to be archived
constexpr double kAcquireEndS = 5;      // all archived: time for acquire's final acks

std::string CompactUtc(int64_t utime) {
  std::string out;
  for (char c : FormatUtimeIso(utime)) {
    if (c != '-' && c != ':') out += c;
  }
  return out;
}

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

// The station's processes. However RunStation ends, they are stopped in
// order (source, analysis, archive), each given time to drain.
struct Children {
  std::optional<Subprocess> acquire, analyze, store;
  ~Children() {
    for (std::optional<Subprocess>* p : {&acquire, &analyze, &store}) {
      if (p->has_value()) (*p)->Stop(kStopTimeoutS);
    }
  }
};

struct RunProgress {
  int64_t samples_published = 0;
  int8_t state = 0;
  bool store_done = false;
  bool analyze_done = false;
};

std::string Si(double v) {
  char buf[32];
  if (v >= 1e6) {
    std::snprintf(buf, sizeof buf, "%.1fM", v / 1e6);
  } else if (v >= 1e3) {
    std::snprintf(buf, sizeof buf, "%.1fk", v / 1e3);
  } else {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  }
  return buf;
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
  if (rate_hz < 0 || !std::isfinite(rate_hz)) return Status::InvalidArgument("--rate must be > 0 Hz");
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("--lot", lot));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("--station", station));
  if (db_path.empty()) return Status::InvalidArgument("--db is required");
  if (!(inject_drop >= 0 && inject_drop < 1)) {
    return Status::InvalidArgument("--inject-drop must be in [0, 1)");
  }
  if (!(pace >= 0) || !std::isfinite(pace)) return Status::InvalidArgument("--pace must be >= 0");
  return Status::Ok();
}

Result<StationRunResult> RunStation(const StationRunOptions& o) {
  IMUQUAL_RETURN_IF_ERROR(o.Validate());
  auto profile = sim::LotProfileByName(o.profile);
  if (!profile.ok()) return profile.status();
  std::string plan_spec = o.plan_spec;
  if (plan_spec.empty() && o.profile == "vg700" && o.units.empty()) plan_spec = "builtin:vg700ca";
  if (!plan_spec.empty()) {
    auto plan = judge::LoadPlan(plan_spec);  // fail here, not in a child
    if (!plan.ok()) return plan.status();
  }
  {
    // A bad archive file fails before any process starts.
    auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kWrite);
    if (!archive.ok()) return archive.status();
  }
  const double rate = o.rate_hz > 0 ? o.rate_hz : profile->nominal_rate_hz;
  // Progress in samples is known for simulated units only; otherwise in runs.
  const int expected_runs = o.sim_units + static_cast<int>(o.units.size());
  const double total_samples = o.units.empty() ? o.sim_units * std::round(o.duration_s * rate) : 0;

  StationRunResult result;
  result.run_prefix = CompactUtc(NowUtime());
  result.log_path = o.db_path + ".log";
  std::string url = o.lcm_url;
  if (url.empty()) {
    BusAddress address;
    address.port = PickPort();
    url = address.ToUrl();
  }
  auto bus_or = LcmBus::Open(url);
  if (!bus_or.ok()) return bus_or.status();
  LcmBus& bus = **bus_or;

  std::map<std::string, RunProgress> runs;
  std::map<std::string, std::string> reported;  // process -> instance
  auto ours = [&](const std::string& run_id) { return run_id.rfind(result.run_prefix + "-", 0) == 0; };
  bus.Subscribe<imuqual::status_t>(
      channels::kStatus, 1000,
      [&](const std::string&, imuqual::status_t&& s, int64_t) { reported[s.process] = s.instance; });
  bus.Subscribe<imuqual::run_t>(channels::kRun, 1000,
                                [&](const std::string&, imuqual::run_t&& r, int64_t) {
                                  if (!ours(r.run_id)) return;
                                  RunProgress& p = runs[r.run_id];
                                  p.samples_published = std::max(p.samples_published, r.samples_published);
                                  p.state = std::max(p.state, r.state);
                                });
  bus.Subscribe<imuqual::ack_t>(channels::kAck, 20000,
                                [&](const std::string&, imuqual::ack_t&& a, int64_t) {
                                  if (!ours(a.run_id) || !a.run_done) return;
                                  RunProgress& p = runs[a.run_id];
                                  if (a.process == "store") p.store_done = true;
                                  if (a.process == "analyze") p.analyze_done = true;
                                });

  {
    auto header = ReadFileToString(result.log_path);
    std::string text = header.ok() ? *header : "";
    text += "=== imuqual run " + result.run_prefix + " lot " + o.lot + " on " + url + "\n";
    IMUQUAL_RETURN_IF_ERROR(WriteStringToFile(result.log_path, text));
  }
  const std::string dir = ExecutableDir();
  Children children;
  {
    auto store = Subprocess::Start({dir + "/imuqual-store", "--lcm-url", url, "--db", o.db_path,
                                    "--stale-after", std::to_string(o.stale_after_s)},
                                   result.log_path);
    if (!store.ok()) return store.status();
    children.store = std::move(*store);
    auto analyze = Subprocess::Start({dir + "/imuqual-analyze", "--lcm-url", url}, result.log_path);
    if (!analyze.ok()) return analyze.status();
    children.analyze = std::move(*analyze);
  }
  std::optional<Subprocess>& store = children.store;
  std::optional<Subprocess>& analyze = children.analyze;

  auto failure = [&](const std::string& what) {
    return Status::Unavailable(what + "; last lines of " + result.log_path + ":\n" +
                               LogTail(result.log_path, 8));
  };
  auto is_instance = [&](const std::string& process, pid_t pid) {
    auto it = reported.find(process);
    return it != reported.end() &&
           it->second.size() > std::to_string(pid).size() &&
           it->second.substr(it->second.rfind(':') + 1) == std::to_string(pid);
  };
  // Wait until store and analyze are up and listening.
  const double start_deadline = MonotonicSeconds() + kStartTimeoutS;
  while (!(is_instance("store", store->pid()) && is_instance("analyze", analyze->pid()))) {
    if (store->Poll()) return failure("imuqual-store exited (code " + std::to_string(*store->Poll()) + ")");
    if (analyze->Poll()) return failure("imuqual-analyze exited (code " + std::to_string(*analyze->Poll()) + ")");
    if (MonotonicSeconds() > start_deadline) return failure("imuqual-store/analyze did not start");
    if (ShutdownRequested()) return Status::Unavailable("interrupted before the soak started");
    IMUQUAL_RETURN_IF_ERROR(bus.HandleFor(50));
  }

  std::vector<std::string> acquire_args = {
      dir + "/imuqual-acquire", "--lcm-url", url, "--lot", o.lot, "--station", o.station,
      "--profile", o.profile, "--run-prefix", result.run_prefix, "--await", "store,analyze"};
  if (o.sim_units > 0) acquire_args.insert(acquire_args.end(), {"--sim", std::to_string(o.sim_units)});
  if (o.duration_s > 0) acquire_args.insert(acquire_args.end(), {"--duration", std::to_string(o.duration_s)});
  for (const std::string& unit : o.units) acquire_args.insert(acquire_args.end(), {"--unit", unit});
  if (o.rate_hz > 0) acquire_args.insert(acquire_args.end(), {"--rate", std::to_string(o.rate_hz)});
  if (!plan_spec.empty()) acquire_args.insert(acquire_args.end(), {"--plan", plan_spec});
  if (!o.operator_name.empty()) acquire_args.insert(acquire_args.end(), {"--operator", o.operator_name});
  if (o.inject_drop > 0) {
    acquire_args.insert(acquire_args.end(), {"--inject-drop", std::to_string(o.inject_drop)});
  }
  if (o.pace > 0) acquire_args.insert(acquire_args.end(), {"--pace", std::to_string(o.pace)});
  {
    auto started = Subprocess::Start(acquire_args, result.log_path);
    if (!started.ok()) return started.status();
    children.acquire = std::move(*started);
  }
  std::optional<Subprocess>& acquire = children.acquire;

  const bool tty = o.show_progress && ::isatty(STDERR_FILENO);
  const double t0 = MonotonicSeconds();
  double last_change = t0, last_line = t0;
  double drain_deadline = -1;  // set when the runs are ending abnormally
  int64_t last_total = -1;
  int last_done = -1;
  Status outcome;
  for (;;) {
    IMUQUAL_RETURN_IF_ERROR(bus.HandleFor(100));
    const double now = MonotonicSeconds();
    int64_t published = 0;
    int done = 0;
    for (const auto& [id, p] : runs) {
      published += p.samples_published;
      done += p.store_done;
    }
    if (published != last_total || done != last_done) {
      last_total = published;
      last_done = done;
      last_change = now;
    }
    if (o.show_progress && (tty ? now - last_line > 0.2 : now - last_line > 10)) {
      const double frac = total_samples > 0 ? std::min(1.0, published / total_samples)
                                            : static_cast<double>(done) / expected_runs;
      const int bar = static_cast<int>(frac * 30);
      std::fprintf(stderr, "%s[%s%s] %3.0f%%  %s/%s samples  runs archived %d/%d  %.0f s%s",
                   tty ? "\r" : "", std::string(bar, '=').c_str(),
                   std::string(30 - bar, ' ').c_str(), 100 * frac, Si(published).c_str(),
                   total_samples > 0 ? Si(total_samples).c_str() : "?", done, expected_runs,
                   now - t0, tty ? "" : "\n");
      std::fflush(stderr);
      last_line = now;
    }
    if (done >= expected_runs) break;
    if (ShutdownRequested() && drain_deadline < 0) {
      drain_deadline = now + kAbortDrainS;
      result.interrupted = true;
      if (tty) std::fprintf(stderr, "\n");
      LogWarning("interrupted: aborting the runs and archiving what was measured");
      acquire->Signal(SIGTERM);
    }
    if (drain_deadline >= 0 && now > drain_deadline) break;
    if (auto code = acquire->Poll(); code && *code != 0 && runs.empty()) {
      // It failed before announcing anything (a bad source or plan): nothing to wait for.
      outcome = failure("imuqual-acquire failed (exit " + std::to_string(*code) + ")");
      break;
    }
    if (auto code = acquire->Poll(); code && *code != 0 && drain_deadline < 0) {
      // The source died: the store ends its runs as incomplete once it has
      // been silent for stale_after_s; wait for that, then report.
      drain_deadline = now + o.stale_after_s + kAbortDrainS;
      result.failure = "imuqual-acquire failed (exit " + std::to_string(*code) +
                       "); its runs are archived as incomplete. Last lines of " +
                       result.log_path + ":\n" + LogTail(result.log_path, 6);
      if (tty) std::fprintf(stderr, "\n");
      LogWarning("imuqual-acquire ended with code " + std::to_string(*code) +
                 "; waiting for its runs to be archived as incomplete");
    }
    if (store->Poll()) {
      outcome = failure("imuqual-store exited (code " + std::to_string(*store->Poll()) + ")");
      break;
    }
    if (analyze->Poll()) {
      outcome = failure("imuqual-analyze exited (code " + std::to_string(*analyze->Poll()) + ")");
      break;
    }
    if (now - last_change > o.stall_timeout_s) {
      outcome = failure("the station made no progress for " +
                        std::to_string(static_cast<int>(o.stall_timeout_s)) + " s");
      break;
    }
  }
  if (tty) std::fprintf(stderr, "\n");
  // Stop in order: the source first (it normally ends by itself once its
  // last acknowledgements arrive), then analysis, then the archive (which
  // drains and commits what it holds).
  if (outcome.ok() && !result.interrupted && result.failure.empty()) acquire->Wait(kAcquireEndS);
  acquire->Stop(kStopTimeoutS);
  analyze->Stop(kStopTimeoutS);
  const int store_code = store->Stop(kStopTimeoutS);
  if (!outcome.ok()) return outcome;
  if (store_code != 0 && !result.interrupted) {
    return failure("imuqual-store ended with code " + std::to_string(store_code));
  }
  for (const auto& [id, p] : runs) result.run_ids.push_back(id);
  return result;
}

}  // namespace imuqual::cli
