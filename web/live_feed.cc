#include "web/live_feed.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "common/clock.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "store/outcome.h"

namespace imuqual::web {
namespace {

using nlohmann::json;

// Archived strings may hold any bytes: invalid UTF-8 is replaced, never thrown on.
std::string Dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// A value to 6 significant digits (the page draws it; the archive keeps it
// exactly); null when not finite.
json Rounded(double v) {
  if (!std::isfinite(v)) return nullptr;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return std::strtod(buf, nullptr);
}

}  // namespace

std::string LiveStatusJson(const station::ConsoleModel& m, int64_t newest_utime) {
  json units = json::array();
  bool all_done = !m.units.empty();
  for (const station::ConsoleUnit& u : m.units) {
    const station::ConsoleUnitCells cells = station::DescribeUnit(m, u);
    json axes = json::array();
    for (const station::ConsoleAxisCells& x : cells.axes) {
      json axis = {{"name", x.name},
                   {"verdict", x.verdict},
                   {"bias_instability", x.bias_instability},
                   {"invalid_samples", x.invalid_samples}};
      // The plan's limits on the curve minimum, in the curve's unit (absent: none).
      if (std::isfinite(x.limit_high)) axis["limit_high"] = x.limit_high;
      if (std::isfinite(x.marginal_high)) axis["marginal_high"] = x.marginal_high;
      axes.push_back(std::move(axis));
    }
    all_done = all_done && u.archived && u.final_result;
    units.push_back({{"slot", u.slot},
                     {"serial", u.serial},
                     {"run_id", u.run_id},
                     {"verdict", cells.verdict},
                     {"outcome", store::OutcomeText(store::OutcomeFromNumber(u.verdict))},
                     {"final", u.final_result},
                     {"reason", cells.reason},
                     {"state", cells.state},
                     {"elapsed", cells.elapsed},
                     {"elapsed_s", Rounded(u.elapsed_s)},
                     {"planned_s", Rounded(station::UnitPlannedS(m, u))},
                     {"samples", u.samples},
                     {"gap_samples", u.gap_samples},
                     {"archived", u.archived},
                     {"attention", cells.attention},
                     {"axes", std::move(axes)}});
  }
  json processes = json::array();
  for (const station::ConsoleProcess& p : m.processes) {
    processes.push_back({{"name", p.name},
                         {"messages_unauthenticated", p.unauthenticated},
                         {"messages_replayed", p.replayed},
                         {"running", p.running},
                         {"expected", p.expected},
                         {"restarts", p.restarts},
                         {"problem", p.problem}});
  }
  json doc = {{"station", m.station},
              {"lot", m.lot},
              {"plan", m.plan},
              {"operator", m.operator_name},
              {"bus", m.bus},
              {"archive", m.archive},
              {"wall_s", Rounded(m.wall_s)},
              {"progress", Rounded(station::ConsoleProgress(m))},
              {"processes_line", station::ConsoleProcessesLine(m)},
              {"processes", std::move(processes)},
              {"tally", station::ConsoleTally(m)},
              {"newest_utime", newest_utime},
              {"sent_utime", NowUtime()},
              {"all_done", all_done},
              {"units", std::move(units)}};
  return Dump(doc);
}

std::string LiveCurveJson(const std::string& serial, const std::string& run_id,
                          const station::LiveCurve& c) {
  json tau = json::array(), dev = json::array(), lo = json::array(), hi = json::array();
  for (size_t i = 0; i < c.tau_s.size(); ++i) {
    tau.push_back(Rounded(c.tau_s[i]));
    dev.push_back(Rounded(c.dev[i]));
    lo.push_back(Rounded(c.lo[i]));
    hi.push_back(Rounded(c.hi[i]));
  }
  return Dump({{"serial", serial},
               {"run_id", run_id},
               {"axis", c.axis},
               {"estimator", c.estimator},
               {"unit", c.unit},
               {"final", c.is_final},
               {"samples", c.samples},
               {"tau_s", std::move(tau)},
               {"dev", std::move(dev)},
               {"lo", std::move(lo)},
               {"hi", std::move(hi)}});
}

struct LiveFeed::Impl {
  std::unique_ptr<LcmBus> bus;
  std::unique_ptr<station::StationMonitor> monitor;
  std::thread thread;
  std::atomic<bool> stop{false};
  mutable std::mutex mu;
  std::condition_variable cv;
  // Guarded by mu:
  std::string status_json;
  uint64_t status_seq = 0;
  struct Curve {
    std::string run_id;
    int64_t stamp = 0;
    bool final = false;
    std::string json;
  };
  std::map<std::string, Curve> curves;  // "run\naxis" ->
  std::string done_lot;

  void Loop() {
    uint64_t shown_version = ~0ull;
    double last_snapshot = -1;
    while (!stop) {
      Status st = bus->HandleFor(100);
      if (!st.ok()) {
        LogWarning("serve: the bus: " + st.message());
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
      const double now = MonotonicSeconds();
      monitor->Refresh(now, /*processes_from_status=*/true);
      if (monitor->version() == shown_version || now - last_snapshot < kSnapshotS) continue;
      shown_version = monitor->version();
      last_snapshot = now;
      std::string status = LiveStatusJson(monitor->model(), monitor->newest_utime());
      std::map<std::string, Curve> next;
      {
        std::lock_guard<std::mutex> lock(mu);
        for (const station::ConsoleUnit& u : monitor->model().units) {
          if (u.run_id.empty()) continue;
          for (const station::LiveCurve& c : monitor->Curves(u)) {
            const std::string key = u.run_id + "\n" + c.axis;
            auto old = curves.find(key);
            if (old != curves.end() && old->second.stamp == c.host_utime &&
                old->second.final == c.is_final) {
              next[key] = std::move(old->second);
              continue;
            }
            next[key] = {u.run_id, c.host_utime, c.is_final, LiveCurveJson(u.serial, u.run_id, c)};
          }
        }
        curves = std::move(next);
        status_json = std::move(status);
        const auto& units = monitor->model().units;
        const bool done = !units.empty() &&
                          std::all_of(units.begin(), units.end(),
                                      [](const auto& u) { return u.archived && u.final_result; });
        done_lot = done ? monitor->model().lot : "";
        ++status_seq;
      }
      cv.notify_all();
    }
    cv.notify_all();
  }
};

LiveFeed::LiveFeed(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

LiveFeed::~LiveFeed() {
  impl_->stop = true;
  impl_->cv.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

Result<std::unique_ptr<LiveFeed>> LiveFeed::Open(const std::string& bus_url,
                                                 const std::string& archive_label,
                                                 BusSecurity security) {
  security.role = BusRole::kMonitor;
  auto bus = LcmBus::Open(bus_url, std::move(security));
  if (!bus.ok()) return Status::InvalidArgument("--bus " + bus_url + ": " + bus.status().message());
  auto impl = std::make_unique<Impl>();
  impl->bus = std::move(*bus);
  station::MonitorOptions o;
  o.discover_units = true;
  o.keep_curves = true;
  o.forget_after_s = 3600;
  impl->monitor = std::make_unique<station::StationMonitor>(o);
  impl->monitor->model().bus = bus_url;
  impl->monitor->model().archive = archive_label;
  impl->monitor->Attach(*impl->bus);
  impl->status_json = LiveStatusJson(impl->monitor->model(), 0);
  Impl* raw = impl.get();
  impl->thread = std::thread([raw] { raw->Loop(); });
  return std::unique_ptr<LiveFeed>(new LiveFeed(std::move(impl)));
}

bool LiveFeed::stopping() const { return impl_->stop; }

std::string LiveFeed::DoneLot() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->done_lot;
}

std::string LiveFeed::StatusJson() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->status_json;
}

std::string LiveFeed::CurvesJson(const std::string& run_id) const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  std::string out = "[";
  for (const auto& [key, c] : impl_->curves) {
    if (c.run_id != run_id) continue;
    if (out.size() > 1) out += ",";
    out += c.json;
  }
  return out + "]\n";
}

std::string LiveFeed::NextEvents(Cursor* cursor, std::chrono::milliseconds timeout) {
  Impl& d = *impl_;
  std::unique_lock<std::mutex> lock(d.mu);
  d.cv.wait_for(lock, timeout, [&] { return d.stop || d.status_seq != cursor->status_seq; });
  if (d.stop) return "";
  std::string out;
  if (d.status_seq != cursor->status_seq) {
    cursor->status_seq = d.status_seq;
    out += "event: status\ndata: " + d.status_json + "\n\n";
  }
  const double now = MonotonicSeconds();
  for (const auto& [key, c] : d.curves) {
    auto sent = cursor->curve_stamps.find(key);
    if (sent != cursor->curve_stamps.end() && sent->second == c.stamp * 2 + c.final) continue;
    auto at = cursor->curve_sent_at.find(key);
    if (!c.final && at != cursor->curve_sent_at.end() && now - at->second < kCurvePeriodS) continue;
    cursor->curve_stamps[key] = c.stamp * 2 + c.final;
    cursor->curve_sent_at[key] = now;
    out += "event: curve\ndata: " + c.json + "\n\n";
  }
  return out;
}

}  // namespace imuqual::web
