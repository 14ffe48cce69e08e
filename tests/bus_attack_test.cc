// Attacks on a keyed station bus (private network namespace): a station
// with a station key and role keys soaks two simulated units (one planted to
// FAIL) under an early-decision plan, once undisturbed and once while
// forgers on the same bus send everything the issue's attacker sent on the
// builds before the authenticated bus:
// - run announcements with a laxer plan for the run ids the station will
//   mint, and phantom runs (one with markup for a serial);
// - early decisions (PASS) from the soak's first seconds;
// - acknowledgements of batches never published (next_seq 2^40), while
//   acquire drops 5 % of its first publications on purpose;
// - a resend flood;
// - the undisturbed soak's recorded traffic played again;
// - final results and curves saying PASS for the planted failure, after
//   its run was announced complete.
// The forgers: a host without the key, a host with another station's key,
// and insiders that hold this station's key but not the right role key
// (none, or acquire's while claiming analyze or the store). A phantom run
// signed with acquire's real key but with a plan the station does not
// accept is refused too.
// THEN every verdict, measurement and curve point of the attacked soak equals
// the undisturbed one's, nothing is lost (no gap, nothing evicted), each
// attack is counted in the processes' status and shown on the console's and
// the live page's process line, the runs record how their bus was
// authenticated, and the archive verifies against the store's key.
#include <gtest/gtest.h>
#include <lcm/lcm.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "analyze/judge/plan.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/allan_curve_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/resend_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "station/station_console.h"
#include "station/station_monitor.h"
#include "store/sqlite.h"
#include "tests/station_harness.h"
#include "web/live_feed.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::CommandResult;
using testing::HarnessKeys;
using testing::RunCommand;
using testing::StationHarness;

constexpr double kRunTimeoutS = 240;  // bound on a soak (each takes a few seconds)
constexpr double kForgePeriodS = 0.02;

// The early-decision plan of early_station_test: looks every 20 s from 60 s.
// clang-format off
constexpr char kPlan[] = R"pb(
name: "attack-bus"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 600
warmup_s: 60
grid { kind: OCTAVE }
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 marginal_high: 0.5 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
early_decision { risk: 0.01 min_duration_s: 60 look_period_s: 20 horizon_s: 600 }
)pb";
// clang-format on

// What one unit's soak left in the archive, to compare bit for bit.
struct ArchivedUnit {
  std::string verdict, reasons, end_reason, bus_auth;
  std::map<std::string, std::string> measurements;  // "axis/name" -> value, u, outcome (exact)
  std::map<std::string, double> curve;              // "axis/m" -> dev
  int64_t gap_samples = -1;
};

std::string Exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

std::map<std::string, ArchivedUnit> ReadArchive(const std::string& db) {
  std::map<std::string, ArchivedUnit> out;
  auto d = store::Db::Open(db, store::Db::Mode::kReadOnly);
  EXPECT_TRUE(d.ok());
  if (!d.ok()) return out;
  auto runs = (*d)->Prepare(
      "SELECT serial, COALESCE(verdict, ''), COALESCE(reasons, ''), COALESCE(end_reason, ''), "
      "COALESCE(bus_auth, ''), COALESCE(gap_samples, -1), run_key FROM runs");
  while (*runs->Step()) {
    ArchivedUnit& u = out[runs->Text(0)];
    u.verdict = runs->Text(1);
    u.reasons = runs->Text(2);
    u.end_reason = runs->Text(3);
    u.bus_auth = runs->Text(4);
    u.gap_samples = runs->Int(5);
    const int64_t key = runs->Int(6);
    auto m = (*d)->Prepare(
        "SELECT axis, name, value, COALESCE(uncertainty, 0), COALESCE(outcome, '') FROM "
        "measurements WHERE run_key = ?");
    m->Bind(1, key);
    while (*m->Step()) {
      u.measurements[m->Text(0) + "/" + m->Text(1)] =
          Exact(m->Real(2)) + " " + Exact(m->Real(3)) + " " + m->Text(4);
    }
    auto c = (*d)->Prepare("SELECT axis, m, dev FROM curve_points WHERE run_key = ?");
    c->Bind(1, key);
    while (*c->Step()) u.curve[c->Text(0) + "/" + std::to_string(c->Int(1))] = c->Real(2);
  }
  return out;
}

// Every datagram on a bus, as sent (a recorder beside the station).
class Recorder {
 public:
  explicit Recorder(const std::string& url) : lcm_(lcm_create(url.c_str())) {
    EXPECT_NE(lcm_, nullptr);
    lcm_subscription_t* s = lcm_subscribe(lcm_, ".*", &Recorder::OnMessage, this);
    lcm_subscription_set_queue_capacity(s, 100000);
    thread_ = std::thread([this] {
      while (!stop_) lcm_handle_timeout(lcm_, 50);
    });
  }
  ~Recorder() {
    stop_ = true;
    thread_.join();
    lcm_destroy(lcm_);
  }
  std::vector<std::pair<std::string, std::vector<uint8_t>>> Take() {
    std::lock_guard<std::mutex> lock(mu_);
    return std::move(recorded_);
  }

 private:
  static void OnMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
    auto* self = static_cast<Recorder*>(user);
    const auto* data = static_cast<const uint8_t*>(rbuf->data);
    std::lock_guard<std::mutex> lock(self->mu_);
    self->recorded_.emplace_back(channel, std::vector<uint8_t>(data, data + rbuf->data_size));
  }
  lcm_t* lcm_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mu_;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> recorded_;
};

// One who sends forgeries as `role` with the keys `security` holds.
struct Forger {
  std::string who;
  std::unique_ptr<LcmBus> bus;
};

Forger MakeForger(const std::string& who, const std::string& url, BusSecurity security,
                  BusRole role) {
  security.role = role;
  auto bus = LcmBus::Open(url, std::move(security));
  EXPECT_TRUE(bus.ok()) << who << ": " << bus.status().ToString();
  return {who, bus.ok() ? std::move(*bus) : nullptr};
}

imuqual::run_t LaxAnnouncement(const std::string& run_id, const std::string& serial,
                               const std::string& station) {
  auto plan = judge::ParsePlanText(kPlan, "plan");
  EXPECT_TRUE(plan.ok());
  pb::TestPlan lax = *plan;
  for (pb::Limit& l : *lax.mutable_limits()) {
    if (l.measurement() == "bias_instability") l.set_high(2000), l.set_marginal_high(1900);
  }
  lax.clear_early_decision();
  const std::string bytes = lax.SerializeAsString();
  imuqual::run_t r{};
  r.host_utime = NowUtime();
  r.run_id = run_id;
  r.unit_serial = serial;
  r.lot = "ATK";
  r.station = station;
  r.source = "sim:vg700";
  r.software_version = "forged";
  r.start_utime = NowUtime();
  r.nominal_rate_hz = 100;
  r.num_axes = 3;
  r.axis_names = {"x", "y", "z"};
  r.axis_kinds = {1, 1, 1};
  r.plan_size = static_cast<int32_t>(bytes.size());
  r.plan.assign(bytes.begin(), bytes.end());
  r.plan_sha256 = Sha256Hex(bytes);
  r.state = imuqual::run_t::STATE_RUNNING;
  r.last_seq = -1;
  r.first_sample = -1;
  r.end_sample = -1;
  r.announcer = "acquire";
  return r;
}

imuqual::unit_result_t ForgedPass(const std::string& run_id, const std::string& serial) {
  imuqual::unit_result_t res{};
  res.host_utime = NowUtime();
  res.run_id = run_id;
  res.unit_serial = serial;
  res.is_final = true;
  res.verdict = imuqual::measurement_t::OUTCOME_PASS;
  res.num_reasons = 1;
  res.reasons = {"forged: all good"};
  res.samples = 66000;
  res.last_seq = 659;
  imuqual::measurement_t m{};
  m.axis = "x";
  m.name = "bias_instability";
  m.value = 9.87;
  m.uncertainty = 0.1;
  m.unit = "deg/h";
  m.outcome = imuqual::measurement_t::OUTCOME_PASS;
  res.num_measurements = 1;
  res.measurements = {m};
  return res;
}

imuqual::allan_curve_t ForgedCurve(const std::string& run_id, const std::string& serial,
                                   const std::string& axis) {
  imuqual::allan_curve_t c{};
  c.host_utime = NowUtime();
  c.run_id = run_id;
  c.unit_serial = serial;
  c.axis = axis;
  c.axis_kind = 1;
  c.estimator = "oadev";
  c.ci_method = "chi2";
  c.is_final = true;
  c.tau0_s = 0.01;
  c.num_points = 1;
  c.m = {1};
  c.tau_s = {0.01};
  c.dev = {1e-5};
  c.lo = {1e-5};
  c.hi = {1e-5};
  c.edf = {10};
  c.n_terms = {10};
  c.stride = {1};
  c.alpha = {0};
  c.alpha_inherited = {0};
  return c;
}

// A soak of the two units on `h`'s station; `during` runs every few ms
// until every run is archived (and `after` for 3 s more).
void Soak(StationHarness& h, const std::string& plan, const std::string& prefix,
          const std::vector<std::string>& extra, const std::function<void(double)>& during = nullptr) {
  // The store and analyze take the freshness window too, the store the
  // resend budget (it resends from the archive).
  std::vector<std::string> consumer = {"--accept-plan", plan}, store_args = consumer;
  for (size_t i = 0; i + 1 < extra.size(); i += 2) {
    if (extra[i] == "--max-message-age") consumer.insert(consumer.end(), {extra[i], extra[i + 1]});
    if (extra[i] == "--max-message-age" || extra[i] == "--resend-budget-mb")
      store_args.insert(store_args.end(), {extra[i], extra[i + 1]});
  }
  Subprocess store = h.StartStore(store_args);
  Subprocess analyze = h.StartAnalyze(consumer);
  std::vector<std::string> args = {"--lot",     "ATK", "--run-prefix", prefix, "--plan",  plan,
                                   "--await",   "store,analyze", "--batch-samples", "100",
                                   "--window",  "8",   "--rate",       "100", "--station", "st",
                                   "--unit",    "GOOD1=sim:vg700,index=1,seed=2,duration=660",
                                   "--unit",    "BAD=sim:vg700,index=7,seed=2,duration=660"};
  args.insert(args.end(), extra.begin(), extra.end());
  if (during) during(-1);  // before acquire starts
  Subprocess acquire = h.Start("imuqual-acquire", args);
  const double start = MonotonicSeconds();
  // This soak's runs (the harness hears a recorded past's too).
  auto done = [&] {
    return h.runs_done().count(prefix + "-GOOD1") + h.runs_done().count(prefix + "-BAD") == 2;
  };
  while (!done() && MonotonicSeconds() < start + kRunTimeoutS) {
    if (during) during(MonotonicSeconds() - start);
    h.Pump(static_cast<int>(kForgePeriodS * 1000));
  }
  ASSERT_TRUE(done()) << h.Logs();
  EXPECT_EQ(acquire.Wait(60).value_or(-1), 0) << h.Logs();
  const double done_at = MonotonicSeconds();
  while (during && MonotonicSeconds() < done_at + 3) {
    during(MonotonicSeconds() - start);
    h.Pump(static_cast<int>(kForgePeriodS * 1000));
  }
  h.Pump(1200);  // every process's status after the attack
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

TEST(BusAttackTest, NoForgedReplayedOrFloodedMessageChangesAVerdictOrLosesASample) {
  // GIVEN an undisturbed soak, recorded
  StationHarness ref("bus_attack_ref", HarnessKeys::kStationAndRoles);
  const std::string plan = ref.path("plan.textproto");
  std::ofstream(plan) << kPlan;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> recorded;
  {
    Recorder recorder(ref.url());
    Soak(ref, plan, "REF", {});
    recorded = recorder.Take();
  }
  const double recorded_at = MonotonicSeconds();
  ASSERT_GT(recorded.size(), 100u);
  const auto expected = ReadArchive(ref.db());
  ASSERT_EQ(expected.size(), 2u);
  ASSERT_EQ(expected.at("BAD").verdict, "FAIL") << "the planted unit must fail";
  ASSERT_NE(expected.at("GOOD1").verdict, "FAIL");

  // WHEN the same soak runs on a station with the same keys while forgers
  // and a recorded past are on its bus
  StationHarness h("bus_attack", HarnessKeys::kStationAndRoles, &ref);
  std::ofstream(h.path("plan.textproto")) << kPlan;
  station::MonitorOptions mo;
  mo.discover_units = true;
  station::StationMonitor monitor(mo);
  monitor.Attach(h.bus());

  BusSecurity none;  // a host without the key
  BusSecurity other;  // another station's key
  other.station_key = *GenerateStationKey();
  BusSecurity insider = h.Security(BusRole::kTool);  // this station's key and trust, no role key
  insider.signing_key.reset();
  BusSecurity stolen = h.Security(BusRole::kAcquire);  // acquire's host: its own key only
  std::vector<Forger> as_analyze, as_store, as_acquire;
  for (auto& [who, sec] : std::vector<std::pair<std::string, BusSecurity>>{
           {"no key", none}, {"another station's key", other}, {"the key, no role key", insider}}) {
    as_analyze.push_back(MakeForger(who, h.url(), sec, BusRole::kAnalyze));
    as_store.push_back(MakeForger(who, h.url(), sec, BusRole::kStore));
    as_acquire.push_back(MakeForger(who, h.url(), sec, BusRole::kAcquire));
  }
  stolen.signing_key->role = "analyze";  // acquire's secret passed off as analyze's
  as_analyze.push_back(MakeForger("acquire's key as analyze", h.url(), stolen, BusRole::kAnalyze));
  stolen.signing_key->role = "store";
  as_store.push_back(MakeForger("acquire's key as the store", h.url(), stolen, BusRole::kStore));
  // The flood from a compromised analyze host (resend requests must be
  // signed by analyze or the store: the key alone does not make the station
  // resend): answered within its own budget.
  LcmBus& flooder = h.BusAs(BusRole::kAnalyze);
  lcm_t* raw = lcm_create(h.url().c_str());  // plays the recorded past
  ASSERT_NE(raw, nullptr);

  size_t replayed = 0;
  int floods = 0;
  const std::vector<std::pair<std::string, std::string>> units = {{"ATK-GOOD1", "GOOD1"},
                                                                  {"ATK-BAD", "BAD"}};
  auto attack = [&](double t) {
    if (t < 0) {
      // Announcements for the run ids the station will mint, with a laxer
      // plan, before acquire's own; phantom runs.
      for (const auto& [run_id, serial] : units) {
        for (Forger& f : as_acquire)
          (void)f.bus->Publish(channels::kRun, LaxAnnouncement(run_id, serial, "st"));
      }
      for (Forger& f : as_acquire) {
        (void)f.bus->Publish(channels::kRun, LaxAnnouncement("PH-<script>", "<script>", "st"));
      }
      // acquire's own key, a plan the station does not accept, or markup for
      // names: refused too.
      LcmBus& acquire_key = h.BusAs(BusRole::kAcquire);
      (void)acquire_key.Publish(channels::kRun, LaxAnnouncement("PH-LAX-U9", "U9", "st"));
      imuqual::run_t markup = LaxAnnouncement("PH-1-X", "<b>X</b>", "st");
      (void)acquire_key.Publish(channels::kRun, markup);
      // The recorded past is older than the attacked station's freshness
      // window (5 s) before it is played.
      while (MonotonicSeconds() < recorded_at + 6) h.Pump(100);
      return;
    }
    for (const auto& [run_id, serial] : units) {
      imuqual::decision_t d{};
      d.host_utime = NowUtime();
      d.run_id = run_id;
      d.unit_serial = serial;
      d.state = imuqual::decision_t::STATE_PASS;
      d.decided_at_s = 60;
      d.end_sample = 0;  // plausible: nothing beyond what acquire published
      imuqual::ack_t ack{};
      ack.host_utime = NowUtime();
      ack.process = "store";
      ack.instance = "forger:1";
      ack.num_runs = 1;
      ack.run_ids = {run_id};
      ack.next_seq = {int64_t{1} << 40};
      ack.run_done = {false};
      for (Forger& f : as_analyze) {
        (void)f.bus->Publish(channels::Decision(serial), d);
        (void)f.bus->Publish(channels::Result(serial), ForgedPass(run_id, serial));
        for (const char* axis : {"x", "y", "z"})
          (void)f.bus->Publish(channels::Curve(serial), ForgedCurve(run_id, serial, axis));
      }
      for (Forger& f : as_store) (void)f.bus->Publish(channels::kAck, ack);
      imuqual::resend_t req{};
      req.host_utime = NowUtime();
      req.requester = "forger";
      req.run_id = run_id;
      req.first_seq = 0;
      req.last_seq = 4095;
      for (Forger& f : as_store) (void)f.bus->Publish(channels::kResend, req);
      // The flood once acquire is there to hear it (it started a second ago).
      const bool acquire_up = t >= 1.0;
      for (int burst = 0; acquire_up && burst < 50 && floods < 3091; ++burst, ++floods) {
        (void)flooder.Publish(channels::kResend, req);
      }
    }
    // The recorded past, a few hundred datagrams at a time.
    for (int i = 0; i < 200 && replayed < recorded.size(); ++i, ++replayed) {
      const auto& [channel, bytes] = recorded[replayed];
      lcm_publish(raw, channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
    }
  };
  Soak(h, h.path("plan.textproto"), "ATK",
       {"--inject-drop", "0.05", "--inject-seed", "5", "--max-message-age", "5",
        "--resend-budget-mb", "0.05", "--pace", "20"},
       attack);
  lcm_destroy(raw);
  EXPECT_EQ(replayed, recorded.size());
  EXPECT_EQ(floods, 3091);

  // THEN the archive is the undisturbed one's, bit for bit
  const auto got = ReadArchive(h.db());
  ASSERT_EQ(got.size(), 2u) << "phantom or forged runs archived";
  for (const auto& [serial, want] : expected) {
    SCOPED_TRACE(serial);
    const ArchivedUnit& have = got.at(serial);
    EXPECT_EQ(have.verdict, want.verdict);
    EXPECT_EQ(have.reasons, want.reasons);
    EXPECT_EQ(have.end_reason, want.end_reason);
    EXPECT_EQ(have.measurements, want.measurements);
    EXPECT_EQ(have.curve, want.curve);
    EXPECT_EQ(have.gap_samples, 0) << "samples lost";
    EXPECT_NE(have.bus_auth.find("station key "), std::string::npos) << have.bus_auth;
    EXPECT_NE(have.bus_auth.find("roles signed: acquire"), std::string::npos) << have.bus_auth;
  }
  // ... nothing evicted from acquire's retention, no batch lost
  EXPECT_EQ(h.Counter("acquire", "evicted_unacknowledged"), 0);
  EXPECT_GT(h.Counter("acquire", "injected_drops"), 0) << "no drop: the acknowledgement attack is vacuous";
  // ... every attack counted where it landed
  for (const char* process : {"store", "analyze", "acquire"}) {
    EXPECT_GT(h.Counter(process, "messages_unauthenticated"), 0) << process;
  }
  EXPECT_GT(h.Counter("store", "messages_replayed"), 0);
  EXPECT_GT(h.Counter("analyze", "messages_replayed"), 0);
  EXPECT_GE(h.Counter("store", "runs_refused"), 2) << "PH-LAX-U9 and the markup run";
  EXPECT_GE(h.Counter("analyze", "runs_refused"), 2);
  // ... the flood answered within its requester's budget (50 KB/s here),
  // while the store's and analyze's own requests repaired every dropped batch
  std::printf("flood: %lld resend requests heard by acquire, %lld batches resent, %lld throttled\n",
              static_cast<long long>(h.Counter("acquire", "resend_requests")),
              static_cast<long long>(h.Counter("acquire", "batches_resent")),
              static_cast<long long>(h.Counter("acquire", "resends_throttled")));
  EXPECT_GT(h.Counter("acquire", "resends_throttled"), 0);
  // ... and shown on the console and the live page
  monitor.Refresh(MonotonicSeconds(), /*processes_from_status=*/true);
  const std::string line = station::ConsoleProcessesLine(monitor.model());
  EXPECT_NE(line.find("store "), std::string::npos) << line;
  EXPECT_NE(line.find(" (refused "), std::string::npos) << line;
  EXPECT_NE(line.find("unauthenticated"), std::string::npos) << line;
  EXPECT_NE(line.find("replayed"), std::string::npos) << line;
  const std::string live = web::LiveStatusJson(monitor.model(), 0);
  EXPECT_NE(live.find("\"messages_unauthenticated\":"), std::string::npos);
  EXPECT_NE(live.find(line.substr(2, 20)), std::string::npos) << live;
  // ... and the archive verifies against the store's key
  const CommandResult verify = RunCommand(Bin("imuqual") + " verify --db " + h.db() + " --pubkey " +
                                          h.sign_key(BusRole::kStore) + ".pub 2>&1");
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
}

}  // namespace
}  // namespace imuqual
