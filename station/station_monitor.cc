#include "station/station_monitor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "analyze/allan/units.h"
#include "analyze/judge/early_decision.h"
#include "analyze/judge/judge.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/strings.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "imuqual/rate_batch_t.hpp"
#include "report/marks.h"
#include "store/outcome.h"

namespace imuqual::station {
namespace {

// The worse of two outcomes: FAIL > INCONCLUSIVE > MARGINAL > PASS (not the
// codes' order).
int8_t Worst(int8_t a, int8_t b) {
  return store::OutcomeSeverity(store::OutcomeFromNumber(b)) >
                 store::OutcomeSeverity(store::OutcomeFromNumber(a))
             ? b
             : a;
}

// Indices of at most `most` points spread evenly in log tau (the first and
// last kept), for a curve of `n` points with increasing tau.
std::vector<size_t> Thinned(const std::vector<double>& tau, size_t most) {
  std::vector<size_t> keep;
  const size_t n = tau.size();
  if (n <= most || most < 2 || !(tau.front() > 0)) {
    for (size_t i = 0; i < n && i < std::max<size_t>(most, 2); ++i) keep.push_back(i);
    return keep;
  }
  const double lo = std::log(tau.front()), hi = std::log(tau.back());
  size_t next = 0;
  for (size_t k = 0; k < most; ++k) {
    const double target = lo + (hi - lo) * static_cast<double>(k) / static_cast<double>(most - 1);
    while (next + 1 < n && std::log(tau[next]) < target) ++next;
    if (keep.empty() || keep.back() != next) keep.push_back(next);
  }
  if (keep.back() != n - 1) keep.push_back(n - 1);
  return keep;
}

}  // namespace

StationMonitor::StationMonitor(MonitorOptions options) : options_(std::move(options)) {}

void StationMonitor::AddUnit(std::string slot, std::string serial, bool device_paced) {
  ConsoleUnit u;
  u.slot = std::move(slot);
  u.serial = std::move(serial);
  index_[u.serial] = model_.units.size();
  tracks_[u.serial].device_paced = device_paced;
  model_.units.push_back(std::move(u));
  Changed();
}

void StationMonitor::Changed(int64_t utime) {
  ++version_;
  newest_utime_ = std::max(newest_utime_, utime);
}

void StationMonitor::Attach(LcmBus& bus) {
  bus.SubscribeWithOrigin<imuqual::status_t>(
      channels::kStatus, 1000, nullptr,
      [this](const std::string&, imuqual::status_t&& s, const MessageOrigin& from) {
        // A process speaks for itself only (its seal names its role).
        if (s.process != RoleName(from.role)) return;
        OnStatus(s, MonotonicSeconds());
      });
  bus.Subscribe<imuqual::run_t>(
      channels::kRun, 1000, [this](const std::string&, imuqual::run_t&& r, int64_t) { OnRun(r); });
  bus.Subscribe<imuqual::decision_t>(
      channels::kDecisionAll, 1000,
      [this](const std::string&, imuqual::decision_t&& d, int64_t) { OnDecision(d); });
  bus.SubscribeWithOrigin<imuqual::ack_t>(
      channels::kAck, 20000, nullptr,
      [this](const std::string&, imuqual::ack_t&& a, const MessageOrigin& from) {
        if (a.process == RoleName(from.role)) OnAck(a);
      });
  bus.Subscribe<imuqual::unit_result_t>(
      channels::kResultAll, 1000,
      [this](const std::string&, imuqual::unit_result_t&& r, int64_t) { OnResult(r); });
  if (options_.keep_curves) {
    bus.Subscribe<imuqual::allan_curve_t>(
        channels::kCurveAll, 2000,
        [this](const std::string&, imuqual::allan_curve_t&& c, int64_t) { OnCurve(c); });
  }
}

ConsoleUnit* StationMonitor::UnitOfRun(const std::string& run_id, const std::string& serial,
                                       const imuqual::run_t* announcement) {
  if (!options_.run_prefix.empty() && run_id.rfind(options_.run_prefix + "-", 0) != 0) {
    return nullptr;  // another station run
  }
  auto it = index_.find(serial);
  const bool fresh_run = options_.discover_units && announcement != nullptr &&
                         announcement->announcer == "acquire" &&
                         announcement->state == imuqual::run_t::STATE_RUNNING &&
                         (it == index_.end() || model_.units[it->second].run_id != run_id);
  if (fresh_run) {
    // A new soak: every unit shown is done (archived with its final result)
    // and started before this run. They leave, and so do the last soak's
    // processes (those still running report again within a second).
    const bool all_done =
        std::all_of(model_.units.begin(), model_.units.end(), [&](const ConsoleUnit& v) {
          return v.archived && v.final_result &&
                 tracks_[v.serial].start_utime < announcement->start_utime;
        });
    if (all_done && !model_.units.empty()) {
      RemoveUnits([](const ConsoleUnit&) { return true; });
      instances_.clear();
      most_alive_.clear();
      superseded_seen_.clear();
      forgotten_restarts_.clear();
      problems_.clear();
    }
    // A new unit in a fixture slot whose unit is done: it takes the row.
    RemoveUnits([&](const ConsoleUnit& v) {
      const Track& t = tracks_[v.serial];
      return v.serial != serial && v.slot == announcement->slot &&
             t.station == announcement->station && v.archived && v.final_result &&
             t.start_utime < announcement->start_utime;
    });
    it = index_.find(serial);
  }
  if (it == index_.end()) {
    // Discovered from its run's announcement only (a result or a decision
    // names no slot); at most kMaxUnits (a bus flooded with announcements
    // cannot grow the monitor without bound).
    if (!options_.discover_units || announcement == nullptr) return nullptr;
    if (model_.units.size() >= kMaxUnits) return nullptr;
    ConsoleUnit u;
    u.slot = announcement->slot;
    u.serial = serial;
    // Slot order (natural: A2 before A10), then serial.
    auto at = std::upper_bound(model_.units.begin(), model_.units.end(), u,
                               [](const ConsoleUnit& a, const ConsoleUnit& b) {
                                 if (NaturalLess(a.slot, b.slot)) return true;
                                 if (NaturalLess(b.slot, a.slot)) return false;
                                 return a.serial < b.serial;
                               });
    model_.units.insert(at, std::move(u));
    index_.clear();
    for (size_t i = 0; i < model_.units.size(); ++i) index_[model_.units[i].serial] = i;
    tracks_[serial] = Track{};
    tracks_[serial].station = announcement->station;
    it = index_.find(serial);
  }
  ConsoleUnit& u = model_.units[it->second];
  Track& track = tracks_[serial];
  if (u.run_id.empty()) {
    u.run_id = run_id;
    if (announcement != nullptr) track.start_utime = announcement->start_utime;
  } else if (u.run_id != run_id && options_.discover_units && announcement != nullptr &&
             announcement->start_utime > track.start_utime) {
    // The unit's next run (a retest on the same bus): a fresh row.
    ConsoleUnit fresh;
    fresh.slot = announcement->slot.empty() ? u.slot : announcement->slot;
    fresh.serial = serial;
    fresh.run_id = run_id;
    for (auto c = curves_.begin(); c != curves_.end();) {
      c = c->first.first == u.run_id ? curves_.erase(c) : std::next(c);
    }
    const std::string station = track.station;
    u = std::move(fresh);
    track = Track{};
    track.start_utime = announcement->start_utime;
    track.station = station;
    end_reasons_.erase(serial);
    Changed();
  }
  return u.run_id == run_id ? &u : nullptr;
}

void StationMonitor::OnStatus(const imuqual::status_t& s, double now) {
  const std::string key = s.process + "/" + s.instance;
  if (instances_.count(key) == 0 && instances_.size() >= kMaxInstances) {
    // Room for the newcomer: the instance heard longest ago leaves.
    auto oldest = std::min_element(
        instances_.begin(), instances_.end(),
        [](const auto& a, const auto& b) { return a.second.last_heard < b.second.last_heard; });
    Forget(oldest->first, oldest->second.kind);
    instances_.erase(oldest);
  }
  Instance& in = instances_[key];
  if (in.kind.empty()) {
    in.kind = s.process;
    in.first_heard = now;
    Changed();
  }
  in.last_heard = now;
  for (size_t i = 0; i < s.counter_names.size() && i < s.counter_values.size(); ++i) {
    int64_t* counter = s.counter_names[i] == "messages_unauthenticated" ? &in.unauthenticated
                       : s.counter_names[i] == "messages_replayed"      ? &in.replayed
                                                                        : nullptr;
    if (counter != nullptr && *counter != s.counter_values[i]) {
      *counter = s.counter_values[i];
      Changed();
    }
  }
  if (s.process == "acquire") {
    // Each acquire process's own list (several may share a bus).
    std::set<std::string> reconnecting;
    const std::string_view prefix = channels::kReconnectingCounterPrefix;
    for (size_t i = 0; i < s.counter_names.size() && i < s.counter_values.size(); ++i) {
      if (s.counter_names[i].rfind(prefix, 0) == 0 && s.counter_values[i] > 0)
        reconnecting.insert(s.counter_names[i].substr(prefix.size()));
    }
    if (reconnecting != in.reconnecting) Changed();
    in.reconnecting = std::move(reconnecting);
  }
  if (s.healthy) {
    if (problems_.erase({s.process, s.instance}) > 0) Changed();
  } else {
    problems_[{s.process, s.instance}] = {s.message, now};
    Changed();
  }
}

void StationMonitor::OnRun(const imuqual::run_t& r) {
  ConsoleUnit* u = UnitOfRun(r.run_id, r.unit_serial, &r);
  if (u == nullptr) return;
  if (options_.discover_units) {
    // The header: what the latest announcement says.
    model_.station = r.station;
    model_.lot = r.lot;
    model_.operator_name = r.operator_name;
  }
  if (!r.slot.empty()) u->slot = r.slot;
  // States only move on, except an end the store inferred from silence:
  // acquire announcing the run again (it was paused, or cut off) makes it
  // running again.
  if (r.announcer == "acquire" && u->state == imuqual::run_t::STATE_INCOMPLETE) {
    u->state = r.state;
  } else {
    u->state = std::max(u->state, r.state);
  }
  if (!r.end_reason.empty()) end_reasons_[r.unit_serial] = r.end_reason;
  // Aborted for a reason other than the operator's stop: its source failed
  // (acquire ends a unit's run so when its source's read fails).
  const auto why = end_reasons_.find(r.unit_serial);
  u->source_failed = u->state == imuqual::run_t::STATE_ABORTED && why != end_reasons_.end() &&
                     why->second != kShutdownEndReason;
  u->samples = std::max(u->samples, r.samples_published);
  if (r.nominal_rate_hz > 0) u->elapsed_s = static_cast<double>(u->samples) / r.nominal_rate_hz;
  // The planned length as acquire announced it (a store's re-announcement
  // does not know it: it keeps what was heard).
  if (r.planned_s > 0 && std::isfinite(r.planned_s)) u->planned_s = r.planned_s;
  if (r.announcer == "acquire")
    tracks_[r.unit_serial].device_paced = r.source.rfind("serial:", 0) == 0;
  if (u->axes.empty()) {
    for (const std::string& name : r.axis_names) {
      ConsoleAxis x;
      x.name = name;
      u->axes.push_back(std::move(x));
    }
    // Early decisions: the looks its plan schedules.
    pb::TestPlan plan;
    if (plan.ParseFromArray(r.plan.data(), static_cast<int>(r.plan.size()))) {
      // The limits on each axis's curve minimum, for the live page's plots.
      for (size_t a = 0; a < u->axes.size(); ++a) {
        const bool accel = a < r.axis_kinds.size() &&
                           r.axis_kinds[a] == imuqual::rate_batch_t::KIND_ACCEL;
        const judge::AxisDesc axis{u->axes[a].name, accel ? pb::ACCEL : pb::GYRO};
        if (const pb::Limit* l = judge::FindLimit(plan, "bias_instability", &axis)) {
          if (l->has_high()) u->axes[a].limit_high = l->high();
          if (l->has_marginal_high()) u->axes[a].marginal_high = l->marginal_high();
        }
      }
      if (plan.has_early_decision())
        u->looks_planned = static_cast<int>(judge::MakeLookSchedule(plan).times_s.size());
      if (options_.discover_units && !plan.name().empty()) model_.plan = plan.name();
    }
  }
  Changed();
}

void StationMonitor::OnDecision(const imuqual::decision_t& d) {
  ConsoleUnit* u = UnitOfRun(d.run_id, d.unit_serial, nullptr);
  if (u == nullptr) return;
  // Final once decided: a later message of the same run changes nothing.
  const bool decided = u->decision == imuqual::decision_t::STATE_PASS ||
                       u->decision == imuqual::decision_t::STATE_FAIL;
  const bool older = d.state == imuqual::decision_t::STATE_PENDING && d.looks_done < u->looks_done;
  if (decided || older) return;
  u->looks_planned = std::max<int>(u->looks_planned, d.looks_planned);
  u->looks_done = d.looks_done;
  u->decision = d.state;
  u->decided_at_s = d.decided_at_s;
  u->pending = d.pending;
  Changed(d.host_utime);
}

void StationMonitor::OnAck(const imuqual::ack_t& a) {
  // The store's latest word: a run it opens again (judged anew) is no
  // longer archived.
  if (a.process != "store") return;
  for (int i = 0; i < a.num_runs; ++i) {
    const std::string& run_id = a.run_ids[i];
    const bool done = a.run_done[i];
    // Acknowledgements carry no serial: the run's unit by its run id.
    auto shown = std::find_if(model_.units.begin(), model_.units.end(),
                              [&](const ConsoleUnit& u) { return u.run_id == run_id; });
    // A discovering monitor keeps only the runs it shows (a bus may carry
    // any number of them); the station's own keeps every run (runs left
    // open by an earlier station process are waited for by their id).
    if (options_.discover_units && shown == model_.units.end()) continue;
    if (done) {
      archived_runs_.insert(run_id);
    } else {
      archived_runs_.erase(run_id);
    }
    if (shown != model_.units.end() && shown->archived != done) {
      shown->archived = done;
      Changed(a.host_utime);
    }
  }
}

namespace {

// Why a unit's provisional verdict is what it is: the measurement that makes
// it, quoted with its uncertainty and the limit it meets ("pending: x:
// tau_at_minimum 153 s (minimum not resolved yet), limit 2..120").
std::string ProvisionalReason(const imuqual::measurement_t& m) {
  const auto [value, u] = report::QuotedWithUncertainty(m.value, m.uncertainty);
  const bool with_u = std::isfinite(m.uncertainty) && m.uncertainty > 0;
  const std::string unit = m.unit == "1" ? "" : " " + m.unit;
  std::string out = (m.outcome == imuqual::measurement_t::OUTCOME_INCONCLUSIVE ? "pending: " : "") +
                    (m.axis.empty() ? "" : m.axis + ": ") + m.name + " " + value +
                    (with_u ? " ± " + u : "") + unit;
  if (m.qualifier == imuqual::measurement_t::QUALIFIER_MINIMUM_NOT_RESOLVED) {
    out += " (minimum not resolved yet)";
  }
  const bool low = std::isfinite(m.low), high = std::isfinite(m.high);
  if (low || high) {
    out += ", limit " + (low && high ? ShortestReal(m.low) + ".." + ShortestReal(m.high)
                         : low      ? ">= " + ShortestReal(m.low)
                                    : "<= " + ShortestReal(m.high));
  }
  return out;
}

}  // namespace

void StationMonitor::OnResult(const imuqual::unit_result_t& r) {
  ConsoleUnit* u = UnitOfRun(r.run_id, r.unit_serial, nullptr);
  if (u == nullptr || (u->final_result && !r.is_final)) return;
  u->final_result = r.is_final;
  u->gap_samples = r.gap_samples;
  // Per axis in the run's axis order, as u->axes (from the run's announcement).
  const size_t counted = std::min<size_t>({u->axes.size(), r.axis_invalid_samples.size(),
                                           static_cast<size_t>(std::max<int8_t>(0, r.num_axes))});
  for (size_t a = 0; a < counted; ++a) u->axes[a].invalid_samples = r.axis_invalid_samples[a];
  // Final: the judgement's first reason. Provisional: the first measurement
  // that makes the verdict (the judgement's reasons also list what cannot be
  // measured yet, which the verdict ignores).
  u->reason = r.is_final && r.num_reasons > 0 ? r.reasons[0] : "";
  // Final: the analysis's verdict. Provisional: judged on what is measured
  // so far; what cannot be measured yet (a curve still shorter than its
  // minimum, the run's duration) does not count.
  u->verdict = r.is_final ? r.verdict : 0;
  for (ConsoleAxis& x : u->axes) x.outcome = 0;
  for (const imuqual::measurement_t& m : r.measurements) {
    const bool counts = r.is_final || (std::isfinite(m.value) && m.name != "duration");
    if (counts && !r.is_final) u->verdict = Worst(u->verdict, m.outcome);
    for (ConsoleAxis& x : u->axes) {
      if (x.name != m.axis) continue;
      if (counts) x.outcome = Worst(x.outcome, m.outcome);
      if (m.name == "bias_instability") {
        x.bias_instability = m.value;
        x.unit = m.unit;
        x.bias_instability_uncertainty = m.uncertainty;
        x.bias_instability_qualifier = m.qualifier;
      }
    }
  }
  if (!r.is_final && u->verdict != imuqual::measurement_t::OUTCOME_PASS) {
    for (const imuqual::measurement_t& m : r.measurements) {
      if (!std::isfinite(m.value) || m.name == "duration" || m.outcome != u->verdict) continue;
      u->reason = ProvisionalReason(m);
      break;
    }
  }
  Changed(r.host_utime);
}

void StationMonitor::OnCurve(const imuqual::allan_curve_t& c) {
  const ConsoleUnit* u = UnitOfRun(c.run_id, c.unit_serial, nullptr);
  if (u == nullptr) return;
  // Only the run's announced axes, and a few estimators each.
  if (std::none_of(u->axes.begin(), u->axes.end(),
                   [&](const ConsoleAxis& x) { return x.name == c.axis; })) {
    return;
  }
  auto& estimators = curves_[{c.run_id, c.axis}];
  if (estimators.count(c.estimator) == 0 && estimators.size() >= kMaxEstimators) return;
  LiveCurve& live = estimators[c.estimator];
  if (live.is_final && !c.is_final) return;  // a late interim curve
  const size_t n = std::min<size_t>({static_cast<size_t>(std::max(0, c.num_points)), c.tau_s.size(),
                                     c.dev.size(), c.lo.size(), c.hi.size()});
  const bool gyro = c.axis_kind == imuqual::rate_batch_t::KIND_GYRO;
  const double scale = gyro ? 3600.0 : 1.0 / allan::kMicroGInMetersPerSecSq;
  LiveCurve next;
  next.axis = c.axis;
  next.estimator = c.estimator;
  next.unit = gyro ? "deg/h" : "ug";
  next.is_final = c.is_final;
  next.samples = c.samples;
  next.host_utime = c.host_utime;
  const std::vector<double> tau(c.tau_s.begin(), c.tau_s.begin() + static_cast<std::ptrdiff_t>(n));
  for (size_t i : Thinned(tau, kMaxLiveCurvePoints)) {
    if (!(c.dev[i] > 0) || !std::isfinite(c.dev[i])) continue;
    next.tau_s.push_back(c.tau_s[i]);
    next.dev.push_back(c.dev[i] * scale);
    next.lo.push_back(std::isfinite(c.lo[i]) ? c.lo[i] * scale : NAN);
    next.hi.push_back(std::isfinite(c.hi[i]) ? c.hi[i] * scale : NAN);
  }
  live = std::move(next);
  Changed(c.host_utime);
}

std::vector<LiveCurve> StationMonitor::Curves(const ConsoleUnit& unit) const {
  std::vector<LiveCurve> out;
  for (const ConsoleAxis& x : unit.axes) {
    auto it = curves_.find({unit.run_id, x.name});
    if (it == curves_.end() || it->second.empty()) continue;
    // The overlapping Allan deviation when there is one, else the first.
    auto oadev = it->second.find("oadev");
    out.push_back(oadev != it->second.end() ? oadev->second : it->second.begin()->second);
  }
  return out;
}

void StationMonitor::RemoveUnits(const std::function<bool(const ConsoleUnit&)>& which) {
  const size_t before = model_.units.size();
  std::erase_if(model_.units, [&](const ConsoleUnit& u) {
    if (!which(u)) return false;
    for (auto it = curves_.begin(); it != curves_.end();) {
      it = it->first.first == u.run_id ? curves_.erase(it) : std::next(it);
    }
    tracks_.erase(u.serial);
    end_reasons_.erase(u.serial);
    return true;
  });
  if (model_.units.size() == before) return;
  index_.clear();
  for (size_t i = 0; i < model_.units.size(); ++i) index_[model_.units[i].serial] = i;
  Changed();
}

void StationMonitor::Refresh(double now, bool processes_from_status) {
  if (options_.discover_units && options_.forget_after_s > 0) {
    RemoveUnits([&](const ConsoleUnit& u) {
      Track& t = tracks_[u.serial];
      if (!(u.archived && u.final_result)) {
        t.done_at = -1;
      } else if (t.done_at < 0) {
        t.done_at = now;
      }
      return t.done_at >= 0 && now - t.done_at >= options_.forget_after_s;
    });
  }
  for (ConsoleUnit& u : model_.units) {
    Track& t = tracks_[u.serial];
    if (u.samples != t.samples || t.grew_at < 0) {
      t.samples = u.samples;
      t.grew_at = now;
    }
    const bool waiting = u.state == 0 || u.state == imuqual::run_t::STATE_RUNNING;
    const double silent = t.device_paced && waiting && !u.archived ? now - t.grew_at : 0;
    bool reconnecting = false;
    for (const auto& [key, in] : instances_) {
      reconnecting = reconnecting || (silent > 0 && now - in.last_heard < kComplaintS &&
                                      in.reconnecting.count(u.run_id) > 0);
    }
    // Shown to the second: a change of a whole second is a change.
    if (std::floor(silent) != std::floor(u.silent_s) || reconnecting != u.reconnecting) Changed();
    u.silent_s = silent;
    u.reconnecting = reconnecting;
  }
  if (!processes_from_status) return;
  // The processes as their status messages say: alive while heard within
  // kGoneS. An instance was restarted (superseded) when another of its kind
  // was first heard after it fell silent: more than a status period after
  // its last word, or at all once it is gone (processes started together
  // are heard within one period of each other).
  std::vector<ConsoleProcess> processes;
  int64_t first_start = 0;
  for (const ConsoleUnit& u : model_.units) {
    const int64_t start = tracks_[u.serial].start_utime;
    if (start > 0 && (first_start == 0 || start < first_start)) first_start = start;
  }
  model_.wall_s = first_start > 0 ? static_cast<double>(NowUtime() - first_start) / 1e6 : 0;
  // Instances silent for long and complaints long past are forgotten.
  std::erase_if(instances_, [&](const auto& e) {
    if (now - e.second.last_heard <= kForgetProcessS) return false;
    Forget(e.first, e.second.kind);
    return true;
  });
  std::erase_if(problems_, [&](const auto& e) { return now - e.second.heard_s > kComplaintS; });
  for (auto& [key, in] : instances_) in.gone = now - in.last_heard >= kGoneS;
  for (const char* kind : {"store", "analyze", "acquire"}) {
    ConsoleProcess p;
    p.name = kind;
    for (const auto& [key, in] : instances_) {
      if (in.kind != kind) continue;
      p.unauthenticated += in.unauthenticated;  // every instance's, restarted ones too
      p.replayed += in.replayed;
      bool superseded = false;
      for (const auto& [other_key, other] : instances_) {
        superseded = superseded ||
                     (other.kind == kind && (other.first_heard > in.last_heard + kStatusPeriodS ||
                                             (in.gone && other.first_heard > in.last_heard)));
      }
      if (superseded) {
        ++p.restarts;
        // Found superseded only now, it may have counted as running beside
        // its successor (a restart within a status period): not one more
        // process expected.
        if (superseded_seen_.insert(key).second && most_alive_[kind] > 1) --most_alive_[kind];
      } else if (!in.gone) {
        ++p.running;
      }
    }
    p.restarts += forgotten_restarts_[kind];
    int& most = most_alive_[kind];
    most = std::max(most, p.running);
    p.expected = std::max(1, most);
    p.problem = Problem(kind, now);
    processes.push_back(std::move(p));
  }
  const auto same = [](const ConsoleProcess& a, const ConsoleProcess& b) {
    return a.name == b.name && a.running == b.running && a.expected == b.expected &&
           a.restarts == b.restarts && a.problem == b.problem;
  };
  if (!std::equal(processes.begin(), processes.end(), model_.processes.begin(),
                  model_.processes.end(), same)) {
    Changed();
  }
  model_.processes = std::move(processes);
}

void StationMonitor::Forget(const std::string& key, const std::string& kind) {
  // A restart stays counted after its instance is forgotten.
  if (superseded_seen_.erase(key) > 0) ++forgotten_restarts_[kind];
}

bool StationMonitor::Reported(const std::string& kind, int pid) const {
  const std::string suffix = ":" + std::to_string(pid);
  for (const auto& [key, in] : instances_) {
    if (in.kind == kind && key.size() > suffix.size() &&
        key.compare(key.size() - suffix.size(), suffix.size(), suffix) == 0) {
      return true;
    }
  }
  return false;
}

std::string StationMonitor::Problem(const std::string& kind, double now) const {
  std::string out;
  for (const auto& [who, complaint] : problems_) {
    if (who.first == kind && now - complaint.heard_s < kComplaintS) out = complaint.message;
  }
  return out;
}

}  // namespace imuqual::station
