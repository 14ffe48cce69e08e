#include "analyze/service/analyze_service.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <thread>
#include <variant>

#include "analyze/judge/plan.h"
#include "analyze/judge/run_admission.h"
#include "analyze/service/run_analyzer.h"
#include "common/ack.h"
#include "common/batch_integrity.h"
#include "common/bounded_queue.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/last_heard.h"
#include "common/lcm_bus.h"
#include "common/listening_clock.h"
#include "common/log.h"
#include "common/process_status.h"
#include "common/seq_tracker.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/allan_curve_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/unit_result_t.hpp"

namespace imuqual::analyze {
namespace {

using Work = std::variant<imuqual::run_t, imuqual::rate_batch_t, imuqual::ack_t>;

constexpr double kDoneReackForS = 60.0;  // finished runs keep saying so this long
// A final result no store has confirmed is published again after 2 s, then
// with the period doubling up to 30 s, for at most 30 min.
constexpr double kFirstRepublishS = 2.0;
constexpr double kMaxRepublishPeriodS = 30.0;
constexpr double kResultRetentionS = 1800.0;
constexpr size_t kMaxHeldBeforeRunInfo = 4096;
constexpr size_t kMaxRefusedRuns = 10000;  // refused run ids remembered (beyond: refused again)
// decision_t's pending reasons: at most this many, each at most this long,
// so that the message stays well within one 64 KB datagram (a plan judges a
// few measurements per axis).
constexpr size_t kMaxPendingReasons = 64;
constexpr size_t kMaxPendingReasonBytes = 400;

// measurement_t's OUTCOME_*, QUALIFIER_* and RULE_* codes are the numbers
// of pb::Outcome, pb::Qualifier and pb::Limit::DecisionRule.
int8_t OutcomeCode(pb::Outcome o) { return static_cast<int8_t>(o); }
static_assert(imuqual::measurement_t::OUTCOME_INCONCLUSIVE == pb::INCONCLUSIVE &&
              imuqual::measurement_t::OUTCOME_ABORTED == pb::ABORTED &&
              imuqual::measurement_t::OUTCOME_ERROR == pb::ERROR);
static_assert(imuqual::measurement_t::QUALIFIER_UPPER_BOUND == pb::UPPER_BOUND &&
              imuqual::measurement_t::QUALIFIER_MODEL_INADEQUATE == pb::MODEL_INADEQUATE);
static_assert(imuqual::measurement_t::RULE_SIMPLE == pb::Limit::SIMPLE &&
              imuqual::measurement_t::RULE_GUARDED_REJECTION == pb::Limit::GUARDED_REJECTION);

struct RunEntry {
  std::optional<imuqual::run_t> info;
  std::optional<RunAnalyzer> analyzer;
  std::string error;  // why the run cannot be analysed, if it cannot
  SeqTracker tracker;
  std::map<int64_t, imuqual::rate_batch_t> held;  // received, not yet processed
  int64_t processed_since_interim = 0;
  AckPacer ack;
  double last_interim_s = 0;
  bool finished = false;
  double finished_s = 0;
  int64_t acked_after_finish = 0;    // late batches of a finished run are acknowledged too
  bool inferred_incomplete = false;  // ended here for silence, not announced so
  int64_t rejected = 0;
  // The final outcome, kept and published again until a store says it has
  // archived the run (ack_t run_done): a result lost on the bus is repaired
  // like a batch. Released on that confirmation or after kResultRetentionS.
  std::optional<RunOutcome> final_outcome;
  double next_republish_s = 0;
  double republish_period_s = 0;
  // The judgement round this analysis answers (run_t.revision) and the
  // batches it treated as gaps: both go with its results, so that a store
  // archives only a judgement computed on what it holds.
  int revision = 0;
  int64_t gap_batches = 0;
  // Early decisions: the looks already announced on decision_t, and when a
  // decided state is announced again while the run goes on.
  int looks_announced = 0;
  bool decision_announced = false;
  double next_decision_s = 0;

  explicit RunEntry(const SeqTracker::Options& o) : tracker(0, o) {}
};

// What is kept of a finished run: enough to tell whether an announcement
// opens it again.
struct FinishedRun {
  imuqual::run_t identity;  // as first announced, plan dropped (its digest stays)
  int revision = 0;
  int64_t last_seq = -1;        // the last batch the analysis covered
  bool end_by_acquire = false;  // acquire itself announced the end
};

FinishedRun SummaryOf(const RunEntry& e) {
  FinishedRun f;
  if (e.info) {
    f.identity = *e.info;
    f.identity.plan.clear();  // compared by digest
    f.identity.truth.clear();
    f.identity.plan_size = f.identity.truth_size = 0;
  }
  f.revision = e.revision;
  f.last_seq = e.tracker.next_seq() - 1;
  f.end_by_acquire = e.info && e.info->announcer == "acquire" &&
                     e.info->state != imuqual::run_t::STATE_RUNNING && !e.inferred_incomplete;
  return f;
}

// A finished run is analysed again, from its first batch, when the store
// opens a new judgement round, or when acquire announces it going on
// although its end was not acquire's own (inferred from silence here, or
// declared by a store that found acquire silent): it was ended early by a
// fault, and its data are arriving after all.
bool Reopens(const FinishedRun& f, const imuqual::run_t& run) {
  if (run.revision > f.revision) return true;
  if (run.announcer != "acquire" || f.end_by_acquire) return false;
  return run.state == imuqual::run_t::STATE_RUNNING || run.last_seq > f.last_seq;
}

// A look entry still pending, "axis: name: why" (the why names the
// measurement itself once it has a value to show).
std::string PendingReason(const judge::LookEntry& entry) {
  const std::string who = (entry.axis.empty() ? "" : entry.axis + ": ") + entry.name;
  return entry.why.starts_with(who) ? entry.why : who + ": " + entry.why;
}

// The early-decision state of a run being analysed (its plan has
// early_decision), as of its last look.
imuqual::decision_t DecisionMessage(const imuqual::run_t& run, int revision,
                                    const RunAnalyzer& analyzer) {
  const judge::EarlyDecider& d = *analyzer.decider();
  imuqual::decision_t msg;
  msg.host_utime = NowUtime();
  msg.run_id = run.run_id;
  msg.unit_serial = run.unit_serial;
  msg.revision = static_cast<int16_t>(revision);
  switch (d.unit_decision()) {
    case judge::Decision::kPass:
      msg.state = imuqual::decision_t::STATE_PASS;
      break;
    case judge::Decision::kFail:
      msg.state = imuqual::decision_t::STATE_FAIL;
      break;
    case judge::Decision::kPending:
      msg.state = imuqual::decision_t::STATE_PENDING;
      break;
  }
  msg.looks_done = static_cast<int16_t>(analyzer.looks_done());
  msg.looks_planned = static_cast<int16_t>(d.schedule().times_s.size());
  msg.decided_at_s = d.decided_time_s();
  msg.end_sample = analyzer.analysed_end_counter();
  msg.z = d.looks().empty() ? allan::kNaN : d.looks().back().z;
  if (!d.looks().empty()) {
    // What is pending; or, every limit decided, why the unit still waits
    // (its marginal flags, FLAGS_AGREE_FULL_LENGTH).
    std::vector<std::string> reasons;
    for (const judge::LookEntry& entry : d.looks().back().entries) {
      if (entry.decision == judge::Decision::kPending) reasons.push_back(PendingReason(entry));
    }
    if (!d.looks().back().note.empty()) reasons.push_back(d.looks().back().note);
    for (std::string& reason : reasons) {
      if (msg.pending.size() == kMaxPendingReasons) break;
      if (reason.size() > kMaxPendingReasonBytes) {
        // Cut on a UTF-8 character boundary (the reasons carry '±').
        size_t cut = kMaxPendingReasonBytes - 3;
        while (cut > 0 && (static_cast<unsigned char>(reason[cut]) & 0xC0) == 0x80) --cut;
        reason = reason.substr(0, cut) + "...";
      }
      msg.pending.push_back(std::move(reason));
    }
  }
  msg.num_pending = static_cast<int16_t>(msg.pending.size());
  return msg;
}

}  // namespace

bool InShard(std::string_view serial, int shard_index, int shard_count) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : serial) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return static_cast<int>(h % static_cast<uint64_t>(shard_count)) == shard_index;
}

Status AnalyzeOptions::Validate() const {
  if (lcm_url.empty()) return Status::InvalidArgument("lcm_url: required");
  IMUQUAL_RETURN_IF_ERROR(LcmBus::CheckSecurity(lcm_url, security));
  if (shard_count < 1 || shard_index < 0 || shard_index >= shard_count) {
    return Status::InvalidArgument("shard: must be K/N with 0 <= K < N");
  }
  if (density < 1 || density > 64 || (density & (density - 1)) != 0) {
    return Status::InvalidArgument("density: must be a power of two in 1..64");
  }
  if (!(interim_period_s > 0)) return Status::InvalidArgument("interim_period_s: must be > 0");
  if (!(interim_runs_per_s > 0)) return Status::InvalidArgument("interim_runs_per_s: must be > 0");
  if (queue_capacity < 16) return Status::InvalidArgument("queue_capacity: must be >= 16");
  if (!(hole_give_up_s > 0)) return Status::InvalidArgument("hole_give_up_s: must be > 0");
  if (!(stale_after_s > 0)) return Status::InvalidArgument("stale_after_s: must be > 0");
  if (!station.empty()) IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("station", station));
  if (!(inject_result_drop >= 0 && inject_result_drop < 1)) {
    return Status::InvalidArgument("inject_result_drop: must be in [0, 1)");
  }
  return Status::Ok();
}

struct AnalyzeService::Impl {
  AnalyzeOptions options;
  // Each run's interim period now (Tick): options.interim_period_s, longer
  // with more active runs than options.interim_runs_per_s.
  double interim_period_s;
  std::unique_ptr<LcmBus> bus;
  BoundedQueue<Work> queue;
  std::map<std::string, RunEntry> runs;
  std::map<std::string, FinishedRun> finished_ids;
  LastHeard heard;  // run_t arrivals, noted by the handler
  std::string instance = InstanceName();
  // The acknowledgements due, sent together (AckBatch::FlushIfDue, after each round of work).
  AckBatch acks{"analyze", instance};
  SeqTracker::Options tracker_options;
  // Counters (worker thread, except where atomic).
  std::atomic<int64_t> batches_received{0}, out_of_shard{0};
  int64_t batches_processed = 0, duplicates = 0, absurd = 0, rejected = 0, resend_requests = 0,
          batches_given_up = 0, runs_finished = 0, late_after_finish = 0, foreign_messages = 0,
          results_republished = 0, results_abandoned = 0, results_dropped_on_purpose = 0,
          damaged = 0, runs_reopened = 0, decisions_published = 0, runs_decided = 0;
  std::set<std::string> foreign_ids;  // runs of other stations (worker thread)
  // Runs whose announcement was refused (judge::RunAdmission): never
  // analysed, their batches dropped; at most kMaxRefusedRuns remembered.
  judge::RunAdmission admission;
  std::set<std::string> refused_ids;
  int64_t runs_refused = 0, announcements_refused = 0, messages_of_refused_runs = 0;
  ThrottledLog refusal_log;
  // Refuses a run's announcement for `why` (logged, counted).
  void Refuse(const std::string& run_id, const std::string& why);
  // Refuses an announcement that changes what a run is (`field`).
  void RefuseChange(const std::string& run_id, const std::string& field);
  ThrottledLog damage_log;

  explicit Impl(const AnalyzeOptions& o)
      : options(o),
        interim_period_s(o.interim_period_s),
        queue(static_cast<size_t>(o.queue_capacity)),
        admission(o.accepted_plans) {
    tracker_options.give_up_after_s = o.hole_give_up_s;
    tracker_options.max_ahead = 8192;
  }

  void Handle(Work&& work, double now);
  void OnStoreAck(const imuqual::ack_t& ack, double now);
  void RepublishUnconfirmed(const std::string& run_id, RunEntry& e, double now);
  void OnRun(imuqual::run_t&& run, double now);
  void OnBatch(imuqual::rate_batch_t&& batch, double now);
  void Tick(double now);
  void TickRun(const std::string& run_id, RunEntry& e, double now);
  void StartAnalyzer(RunEntry& e);
  // `now`: when the early decisions a batch completes are announced.
  void ProcessHeld(RunEntry& e, double now);
  // Early decisions: the run's state on decision_t after each new look, at
  // once when the unit is decided, and the decided state again every
  // interim period until the run ends.
  void AnnounceDecision(RunEntry& e, double now);
  void Finish(const std::string& run_id, RunEntry& e, double now);
  // `first`: the final outcome's first publication (the only one fault
  // injection may drop).
  void PublishOutcome(const RunEntry& e, const RunOutcome& out, bool final, bool first = false);
  // Fault injection: true to drop this message.
  bool InjectDrop(bool final, bool first) {
    if (!final || !first || !(options.inject_result_drop > 0)) return false;
    const bool drop =
        std::uniform_real_distribution<double>(0, 1)(inject_rng) < options.inject_result_drop;
    results_dropped_on_purpose += drop;
    return drop;
  }
  std::mt19937_64 inject_rng{1};
  void Ack(const std::string& run_id, RunEntry& e, double now, bool force);
  Counters StatusCounters();
};

AnalyzeService::AnalyzeService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AnalyzeService::~AnalyzeService() = default;

Result<std::unique_ptr<AnalyzeService>> AnalyzeService::Create(const AnalyzeOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  return std::unique_ptr<AnalyzeService>(new AnalyzeService(std::make_unique<Impl>(options)));
}

void AnalyzeService::Impl::Handle(Work&& work, double now) {
  if (auto* run = std::get_if<imuqual::run_t>(&work)) {
    OnRun(std::move(*run), now);
  } else if (auto* ack = std::get_if<imuqual::ack_t>(&work)) {
    OnStoreAck(*ack, now);
  } else {
    OnBatch(std::move(std::get<imuqual::rate_batch_t>(work)), now);
  }
}

void AnalyzeService::Impl::Refuse(const std::string& run_id, const std::string& why) {
  ++runs_refused;
  if (refused_ids.size() < kMaxRefusedRuns) refused_ids.insert(run_id);
  runs.erase(run_id);  // batches held before the announcement go too
  refusal_log.Warning("refused run " + run_id.substr(0, 160) + ": " + why +
                      "; it is not analysed");
}

void AnalyzeService::Impl::RefuseChange(const std::string& run_id, const std::string& field) {
  ++announcements_refused;
  refusal_log.Warning("refused an announcement of run " + run_id + " that changes its " + field +
                      " (fixed at its first announcement)");
}

void AnalyzeService::Impl::OnRun(imuqual::run_t&& run, double now) {
  if (refused_ids.count(run.run_id)) {
    ++messages_of_refused_runs;
    return;
  }
  std::optional<FinishedRun> finished;
  if (auto f = finished_ids.find(run.run_id); f != finished_ids.end()) finished = f->second;
  if (auto r = runs.find(run.run_id); r != runs.end() && r->second.finished) {
    finished = SummaryOf(r->second);
  }
  if (finished) {
    imuqual::run_t announced = run;
    announced.plan.clear();
    announced.truth.clear();
    announced.plan_size = announced.truth_size = 0;
    if (const std::string field = judge::RunIdentityDifference(finished->identity, announced);
        !field.empty()) {
      RefuseChange(run.run_id, field);
      return;
    }
    if (!Reopens(*finished, run)) return;
    LogWarning("run " + run.run_id + " is analysed again from its first batch: " +
               (run.revision > finished->revision
                    ? "the store opened judgement round " + std::to_string(run.revision)
                    : "acquire announces it going on (batch " + std::to_string(run.last_seq) +
                          ") after it was ended early at batch " +
                          std::to_string(finished->last_seq)));
    finished_ids.erase(run.run_id);
    runs.erase(run.run_id);
    ++runs_reopened;
  }
  if (!options.station.empty() && run.station != options.station) {
    // Another station's run on this bus: not ours to analyse (nor to hold
    // batches for).
    if (foreign_ids.insert(run.run_id).second) {
      LogWarning("ignoring run " + run.run_id + " of station '" + run.station +
                 "' (this analyze serves station '" + options.station + "')");
    }
    ++foreign_messages;
    runs.erase(run.run_id);
    return;
  }
  if (Status st = admission.Admit(run); !st.ok()) {
    Refuse(run.run_id, st.message());
    return;
  }
  auto [it, inserted] = runs.try_emplace(run.run_id, tracker_options);
  RunEntry& e = it->second;
  (void)inserted;
  if (e.info) {
    if (const std::string field = judge::RunIdentityDifference(*e.info, run); !field.empty()) {
      RefuseChange(run.run_id, field);
      return;
    }
  }
  e.revision = std::max<int>(e.revision, run.revision);
  if (e.info && e.info->announcer == "acquire" && run.announcer == "store" &&
      run.state == imuqual::run_t::STATE_RUNNING) {
    return;  // acquire's own announcements describe a running run; the store's bring the round
  }
  if (e.info && e.info->state != imuqual::run_t::STATE_RUNNING &&
      run.state == imuqual::run_t::STATE_RUNNING) {
    // An announced end never goes back to running (heartbeats may cross);
    // an end inferred here from silence does, if the run is not finished.
    if (!e.inferred_incomplete || e.finished) return;
    LogWarning("run " + run.run_id + " is announced again; it was not incomplete after all");
    e.inferred_incomplete = false;
    e.tracker.SetFinal(false);
  }
  const bool first = !e.info.has_value();
  e.info = std::move(run);
  e.tracker.SetAnnouncedLast(e.info->last_seq);
  if (e.info->state != imuqual::run_t::STATE_RUNNING) e.tracker.SetFinal();
  if (first) {
    StartAnalyzer(e);
    Ack(e.info->run_id, e, now, true);  // "present": opens acquire's window
  }
}

void AnalyzeService::Impl::StartAnalyzer(RunEntry& e) {
  const imuqual::run_t& r = *e.info;
  RunDescription d;
  d.run_id = r.run_id;
  d.serial = r.unit_serial;
  d.nominal_rate_hz = r.nominal_rate_hz;
  for (int i = 0; i < r.num_axes; ++i) {
    d.axes.push_back({r.axis_names[i],
                      r.axis_kinds[i] == imuqual::rate_batch_t::KIND_ACCEL ? pb::ACCEL : pb::GYRO});
  }
  if (!d.plan.ParseFromArray(r.plan.data(), static_cast<int>(r.plan.size()))) {
    e.error = "the run's plan does not decode";
  } else if (Status st = judge::ValidatePlan(d.plan); !st.ok()) {
    e.error = "the run's plan is invalid: " + st.message();
  }
  auto analyzer = RunAnalyzer::Create(std::move(d), AnalyzerOptions{options.density});
  if (!analyzer.ok()) {
    e.error = analyzer.status().message();
  } else {
    e.analyzer.emplace(std::move(*analyzer));
  }
  if (!e.error.empty()) LogError("run " + r.run_id + ": " + e.error);
  LogInfo("analysing run " + r.run_id + " (unit " + r.unit_serial + ", " +
          std::to_string(r.num_axes) + " axes at " + std::to_string(r.nominal_rate_hz) + " Hz)");
}

void AnalyzeService::Impl::OnBatch(imuqual::rate_batch_t&& batch, double now) {
  // Before any field is trusted: a damaged batch is dropped; its seq stays a
  // hole that the tracker asks to be resent.
  if (Status st = VerifyBatch(batch); !st.ok()) {
    ++damaged;
    damage_log.Warning(st.message() + "; dropped, to be resent");
    return;
  }
  if (foreign_ids.count(batch.run_id)) {
    ++foreign_messages;
    return;
  }
  if (refused_ids.count(batch.run_id)) {
    ++messages_of_refused_runs;
    return;
  }
  if (finished_ids.count(batch.run_id)) {
    ++late_after_finish;
    return;
  }
  auto [it, inserted] = runs.try_emplace(batch.run_id, tracker_options);
  RunEntry& e = it->second;
  (void)now;
  (void)inserted;
  if (e.finished) {
    // Late (a resend for someone else, or a run believed ended): acknowledged
    // so that acquire's window never waits on a run that is done here.
    ++late_after_finish;
    e.acked_after_finish = std::max(e.acked_after_finish, batch.seq + 1);
    return;
  }
  if (!e.info && e.held.size() >= kMaxHeldBeforeRunInfo) {
    ++rejected;  // it will be resent once the run is known
    return;
  }
  const int64_t seq = batch.seq;
  switch (e.tracker.Offer(seq)) {
    case SeqTracker::Arrival::kDuplicate:
      ++duplicates;
      return;
    case SeqTracker::Arrival::kAbsurd:
      ++absurd;
      return;
    case SeqTracker::Arrival::kNew:
      break;
  }
  e.held.emplace(seq, std::move(batch));
}

// Processes held batches that are now in order (everything below the
// tracker's frontier has arrived or was given up).
void AnalyzeService::Impl::ProcessHeld(RunEntry& e, double now) {
  if (!e.analyzer) {
    // A run that cannot be analysed (its description is unusable): its
    // batches are counted and let go, so its acks move and it can finish
    // with an ERROR saying why.
    if (!e.info) return;
    while (!e.held.empty() && e.held.begin()->first < e.tracker.next_seq()) {
      ++rejected;
      e.held.erase(e.held.begin());
    }
    return;
  }
  while (!e.held.empty() && e.held.begin()->first < e.tracker.next_seq()) {
    const imuqual::rate_batch_t& b = e.held.begin()->second;
    BatchView view;
    view.seq = b.seq;
    view.first_sample = b.first_sample;
    view.sample_utime = b.sample_utime;
    view.nominal_rate_hz = b.nominal_rate_hz;
    if (b.has_temperature) view.temperature_c = b.temperature_c;
    for (const std::vector<float>& axis : b.samples) view.samples.emplace_back(axis);
    for (int i = 0; i < b.num_flagged; ++i) {
      view.flags.push_back({b.flagged_sample[i], b.flagged_axis[i], b.flagged_bits[i]});
    }
    Status st = e.analyzer->AddBatch(view);
    if (!st.ok()) {
      ++rejected;
      if (e.rejected++ < 5)
        LogWarning("run " + b.run_id + " seq " + std::to_string(b.seq) +
                   " rejected: " + st.message());
    } else {
      ++batches_processed;
      ++e.processed_since_interim;
      AnnounceDecision(e, now);  // a look this batch completed, before the next
    }
    e.held.erase(e.held.begin());
  }
}

void AnalyzeService::Impl::AnnounceDecision(RunEntry& e, double now) {
  if (!e.analyzer || !e.analyzer->decider() || !e.info) return;
  const bool decided = e.analyzer->decided();
  const bool new_look = e.analyzer->looks_done() > e.looks_announced;
  if (!new_look && !(decided && now >= e.next_decision_s)) return;
  const imuqual::decision_t msg = DecisionMessage(*e.info, e.revision, *e.analyzer);
  Status st = bus->Publish(channels::Decision(msg.unit_serial), msg);
  if (!st.ok()) LogWarning(st.message());
  ++decisions_published;
  e.looks_announced = e.analyzer->looks_done();
  if (decided) {
    if (!e.decision_announced) {
      ++runs_decided;
      char at[64];
      std::snprintf(at, sizeof at, " at %g s (look %d of %d)", msg.decided_at_s, msg.looks_done,
                    msg.looks_planned);
      LogInfo("run " + msg.run_id + " decided " +
              judge::DecisionName(e.analyzer->decider()->unit_decision()) + at);
    }
    e.decision_announced = true;
    e.next_decision_s = now + interim_period_s;
  }
}

void AnalyzeService::Impl::Ack(const std::string& run_id, RunEntry& e, double now, bool force) {
  // Handled = processed: held batches (out of order, or waiting for the
  // run's description) are not acknowledged yet.
  int64_t seq =
      e.held.empty() ? e.tracker.next_seq() : std::min(e.held.begin()->first, e.tracker.next_seq());
  if (e.finished) seq = std::max(seq, e.acked_after_finish);
  if (!e.ack.Due(seq, e.finished, now, force)) return;
  // Sent with the others (AckBatch::FlushIfDue).
  acks.Add(run_id, seq, e.finished, force || e.ack.Urgent(seq, e.finished));
  e.ack.Sent(seq, e.finished, now);   // a lost one is said again within 0.5 s
}

void AnalyzeService::Impl::PublishOutcome(const RunEntry& e, const RunOutcome& out, bool final,
                                          bool first) {
  const imuqual::run_t& r = *e.info;
  const int64_t now = NowUtime();
  for (const auto& [axis, curve] : out.curves) {
    imuqual::allan_curve_t msg;
    msg.host_utime = now;
    msg.run_id = r.run_id;
    msg.unit_serial = r.unit_serial;
    msg.axis = axis;
    msg.axis_kind = imuqual::rate_batch_t::KIND_GYRO;
    for (int i = 0; i < r.num_axes; ++i) {
      if (r.axis_names[i] == axis) msg.axis_kind = r.axis_kinds[i];
    }
    msg.estimator = std::string(allan::DeviationName(curve.deviation));
    msg.ci_method = std::string(allan::CiMethodName(curve.ci));
    msg.is_final = final;
    msg.revision = static_cast<int16_t>(e.revision);
    msg.samples = out.samples;
    msg.valid_samples = out.samples - curve.invalid_rate_samples;  // neither missing nor invalid
    msg.tau0_s = curve.tau0_s;
    msg.num_points = static_cast<int32_t>(curve.points.size());
    for (const allan::CurvePoint& p : curve.points) {
      msg.m.push_back(p.m);
      msg.tau_s.push_back(p.tau_s);
      msg.dev.push_back(p.dev);
      msg.lo.push_back(p.lo);
      msg.hi.push_back(p.hi);
      msg.edf.push_back(p.edf);
      msg.n_terms.push_back(p.n);
      msg.stride.push_back(p.stride);
      msg.alpha.push_back(p.alpha ? static_cast<int8_t>(*p.alpha)
                                  : imuqual::allan_curve_t::NO_ALPHA);
      msg.alpha_inherited.push_back(p.alpha_inherited);
    }
    if (InjectDrop(final, first)) continue;
    Status st = bus->Publish(channels::Curve(r.unit_serial), msg);
    if (!st.ok()) LogWarning(st.message());
  }
  imuqual::unit_result_t res;
  res.host_utime = now;
  res.run_id = r.run_id;
  res.unit_serial = r.unit_serial;
  res.is_final = final;
  res.revision = static_cast<int16_t>(e.revision);
  res.last_seq = e.tracker.next_seq() - 1;
  res.gap_batches = e.gap_batches;
  res.verdict = OutcomeCode(out.judgement.verdict);
  res.reasons = out.judgement.reasons;
  res.num_reasons = static_cast<int16_t>(std::min<size_t>(res.reasons.size(), 32000));
  res.reasons.resize(res.num_reasons);
  res.samples = out.samples;
  res.warmup_samples = out.warmup_samples;
  res.gap_samples = out.gap_samples;
  res.invalid_samples = out.invalid_samples;
  res.axis_invalid_samples = out.axis_invalid_samples;
  res.num_axes = static_cast<int8_t>(res.axis_invalid_samples.size());
  for (const pb::Measurement& m : out.measurements) {
    imuqual::measurement_t mm;
    mm.axis = m.axis();
    mm.name = m.name();
    mm.value = m.value();
    mm.uncertainty = m.has_uncertainty() ? m.uncertainty() : allan::kNaN;
    mm.unit = m.unit();
    mm.low = m.has_low() ? m.low() : allan::kNaN;
    mm.high = m.has_high() ? m.high() : allan::kNaN;
    mm.marginal_low = m.has_marginal_low() ? m.marginal_low() : allan::kNaN;
    mm.marginal_high = m.has_marginal_high() ? m.marginal_high() : allan::kNaN;
    mm.outcome = OutcomeCode(m.outcome());
    mm.note = m.note();
    mm.uncertainty_method = m.uncertainty_method();
    mm.qualifier = static_cast<int8_t>(m.qualifier());
    mm.decision_rule = static_cast<int8_t>(m.decision_rule());
    mm.guard_band = m.has_guard_band() ? m.guard_band() : allan::kNaN;
    res.measurements.push_back(std::move(mm));
  }
  res.num_measurements = static_cast<int16_t>(res.measurements.size());
  if (InjectDrop(final, first)) return;
  Status st = bus->Publish(channels::Result(r.unit_serial), res);
  if (!st.ok()) LogWarning(st.message());
}

void AnalyzeService::Impl::OnStoreAck(const imuqual::ack_t& ack, double now) {
  (void)now;
  for (int i = 0; i < ack.num_runs; ++i) {
    if (!ack.run_done[i]) continue;
    auto it = runs.find(ack.run_ids[i]);
    if (it != runs.end() && it->second.finished) it->second.final_outcome.reset();
  }
}

// A finished run's final curves and result, published again while no store
// has confirmed the run archived: first after kFirstRepublishS, then with
// the period doubling up to kMaxRepublishPeriodS.
void AnalyzeService::Impl::RepublishUnconfirmed(const std::string& run_id, RunEntry& e,
                                                double now) {
  if (!e.final_outcome || now < e.next_republish_s) return;
  if (now - e.finished_s > kResultRetentionS) {
    LogWarning("run " + run_id + ": no store confirmed its result in " +
               std::to_string(static_cast<int>(kResultRetentionS)) +
               " s; no longer publishing it (the store re-announces an unjudged run)");
    e.final_outcome.reset();
    ++results_abandoned;
    return;
  }
  PublishOutcome(e, *e.final_outcome, true);
  ++results_republished;
  e.republish_period_s = std::min(2 * e.republish_period_s, kMaxRepublishPeriodS);
  e.next_republish_s = now + e.republish_period_s;
}

void AnalyzeService::Impl::Finish(const std::string& run_id, RunEntry& e, double now) {
  RunEnding ending;
  if (e.info->state == imuqual::run_t::STATE_ABORTED) {
    ending = EndingForRunState("aborted", e.info->end_reason);
  }
  if (e.info->state == imuqual::run_t::STATE_INCOMPLETE) {
    ending = EndingForRunState("incomplete", e.info->end_reason);
  }
  if (e.analyzer) {
    e.analyzer->Finish(e.info->first_sample, e.info->end_sample);
    RunOutcome out = e.analyzer->Outcome(true, ending);
    if (!e.error.empty()) {
      out.judgement.verdict = pb::ERROR;
      out.judgement.reasons.insert(out.judgement.reasons.begin(), e.error);
    }
    PublishOutcome(e, out, true, true);
    LogInfo("run " + run_id + " done: " + judge::OutcomeName(out.judgement.verdict) + ", " +
            std::to_string(out.samples) + " samples per axis, " + std::to_string(out.gap_samples) +
            " gap samples");
    e.final_outcome = std::move(out);
  } else {
    RunOutcome out;
    out.judgement.verdict = pb::ERROR;
    out.judgement.reasons = {"cannot analyse the run: " + e.error};
    if (!ending.reason.empty()) out.judgement.reasons.push_back(ending.reason);
    // An empty final curve per axis: the store archives a run once it has a
    // final curve of every axis, and this run has nothing more to give.
    for (const std::string& axis : e.info->axis_names)
      out.curves.emplace_back(axis, allan::Curve{});
    PublishOutcome(e, out, true, true);
    e.final_outcome = std::move(out);
  }
  e.republish_period_s = kFirstRepublishS;
  e.next_republish_s = now + kFirstRepublishS;
  e.finished = true;
  e.finished_s = now;
  ++runs_finished;
  e.analyzer.reset();  // release the engines; the entry stays to re-ack
  Ack(run_id, e, now, true);
}

void AnalyzeService::Impl::TickRun(const std::string& run_id, RunEntry& e, double now) {
  if (e.finished) {
    Ack(run_id, e, now, false);
    RepublishUnconfirmed(run_id, e, now);
    return;
  }
  if (!e.info) return;  // batches before the run's first heartbeat wait
  if (e.info->state == imuqual::run_t::STATE_RUNNING &&
      heard.SecondsSince(run_id, now) > options.stale_after_s) {
    // Nobody announces the run any more (acquire and store both silent).
    LogWarning("run " + run_id + ": not announced for " +
               std::to_string(static_cast<int>(options.stale_after_s)) +
               " s; ending it as incomplete");
    e.info->state = imuqual::run_t::STATE_INCOMPLETE;
    e.info->end_reason =
        "not announced for " + std::to_string(static_cast<int>(options.stale_after_s)) + " s";
    e.inferred_incomplete = true;
    e.tracker.SetFinal();
  }
  for (const SeqRange& r : e.tracker.DueRequests(now)) {
    imuqual::resend_t req;
    req.host_utime = NowUtime();
    req.requester = instance;
    req.run_id = run_id;
    req.first_seq = r.first;
    req.last_seq = r.last;
    if (bus->Publish(channels::kResend, req).ok()) ++resend_requests;
  }
  for (const SeqRange& r : e.tracker.TakeGivenUp(now)) {
    batches_given_up += r.last - r.first + 1;
    e.gap_batches += r.last - r.first + 1;
    LogWarning("run " + run_id + ": batches " + std::to_string(r.first) + ".." +
               std::to_string(r.last) + " were not resent; analysing them as a gap");
  }
  ProcessHeld(e, now);
  AnnounceDecision(e, now);  // the decided state again, every interim period
  if (e.tracker.complete() && e.held.empty()) {
    Finish(run_id, e, now);
    return;
  }
  Ack(run_id, e, now, false);
  if (e.analyzer && e.processed_since_interim > 0 &&
      now - e.last_interim_s >= interim_period_s) {
    PublishOutcome(e, e.analyzer->Outcome(false), false);
    e.processed_since_interim = 0;
    e.last_interim_s = now;
  }
}

void AnalyzeService::Impl::Tick(double now) {
  const auto active = std::count_if(runs.begin(), runs.end(),
                                    [](const auto& kv) { return !kv.second.finished; });
  interim_period_s = std::max(options.interim_period_s,
                              static_cast<double>(active) / options.interim_runs_per_s);
  for (auto it = runs.begin(); it != runs.end();) {
    TickRun(it->first, it->second, now);
    // A finished run stays while its result waits for a store's confirmation.
    if (it->second.finished && now - it->second.finished_s > kDoneReackForS &&
        !it->second.final_outcome) {
      finished_ids[it->first] = SummaryOf(it->second);
      heard.Forget(it->first);
      it = runs.erase(it);
    } else {
      ++it;
    }
  }
}

Counters AnalyzeService::Impl::StatusCounters() {
  int64_t held = 0, active = 0;
  for (const auto& [id, e] : runs) {
    held += static_cast<int64_t>(e.held.size());
    active += !e.finished;
  }
  return {{"runs_active", active},
          {"runs_finished", runs_finished},
          {"runs_reopened", runs_reopened},
          {"batches_received", batches_received.load()},
          {"batches_processed", batches_processed},
          {"batches_damaged", damaged},
          {"batches_held", held},
          {"duplicates", duplicates},
          {"absurd_seq", absurd},
          {"rejected", rejected},
          {"resend_requests", resend_requests},
          {"batches_given_up", batches_given_up},
          {"late_after_finish", late_after_finish},
          {"queue_depth", static_cast<int64_t>(queue.size())},
          {"queue_high_water", static_cast<int64_t>(queue.high_water())},
          {"queue_dropped", static_cast<int64_t>(queue.dropped())},
          {"decode_errors", static_cast<int64_t>(bus->decode_errors())},
          {"out_of_shard", out_of_shard.load()},
          {"foreign_runs", static_cast<int64_t>(foreign_ids.size())},
          {"results_republished", results_republished},
          {"decisions_published", decisions_published},
          {"runs_decided", runs_decided},
          {"results_abandoned", results_abandoned},
          {"results_dropped_on_purpose", results_dropped_on_purpose},
          {"stopped_ms", std::llround(ListeningPausedSeconds() * 1e3)},
          {"foreign_messages", foreign_messages},
          {"runs_refused", runs_refused},
          {"announcements_refused", announcements_refused},
          {"messages_of_refused_runs", messages_of_refused_runs}};
}

Status AnalyzeService::Run() {
  Impl& s = *impl_;
  BusSecurity security = s.options.security;
  security.role = BusRole::kAnalyze;
  auto bus = LcmBus::Open(s.options.lcm_url, std::move(security));
  if (!bus.ok()) return bus.status();
  s.bus = std::move(*bus);
  const AnalyzeOptions& o = s.options;
  s.bus->Subscribe<imuqual::run_t>(channels::kRun, 1000,
                                   [&s, &o](const std::string&, imuqual::run_t&& run, int64_t) {
                                     if (!InShard(run.unit_serial, o.shard_index, o.shard_count))
                                       return;
                                     s.heard.Note(run.run_id);
                                     s.queue.TryPush(std::move(run));
                                   });
  // Other shards' batches are skipped by channel name, before decoding.
  const size_t raw_prefix = std::strlen(channels::kRawPrefix);
  std::function<bool(const char*)> in_shard = nullptr;
  if (o.shard_count > 1) {
    in_shard = [&s, &o, raw_prefix](const char* channel) {
      if (std::strlen(channel) > raw_prefix &&
          InShard(channel + raw_prefix, o.shard_index, o.shard_count)) {
        return true;
      }
      ++s.out_of_shard;
      return false;
    };
  }
  s.bus->Subscribe<imuqual::rate_batch_t>(
      channels::kRawAll, o.queue_capacity, in_shard,
      [&s, &o](const std::string&, imuqual::rate_batch_t&& batch, int64_t) {
        if (!InShard(batch.unit_serial, o.shard_index, o.shard_count)) {
          ++s.out_of_shard;
          return;
        }
        ++s.batches_received;
        s.queue.TryPush(std::move(batch));
      });

  // Stores' confirmations that a run is archived (its final result too).
  s.bus->SubscribeWithOrigin<imuqual::ack_t>(
      channels::kAck, 1000, nullptr,
      [&s](const std::string&, imuqual::ack_t&& ack, const MessageOrigin& from) {
        // The store's own word (its seal says who sent it), naming a run done.
        if (ack.process != "store" || from.role != BusRole::kStore) return;
        if (std::any_of(ack.run_done.begin(), ack.run_done.end(), [](int8_t d) { return d != 0; }))
          s.queue.TryPush(std::move(ack));
      });

  std::atomic<bool> stop{false};
  std::thread worker([&s, &stop] {
    double next_status = 0;
    for (;;) {
      std::vector<Work> items = s.queue.PopAll(std::chrono::milliseconds(5), 1024);
      // Every timer (silence, give-up) on the listening clock: an analyze
      // that was frozen does not end the runs it was analysing as silent.
      double now = ListeningSeconds();
      for (Work& w : items) s.Handle(std::move(w), now);
      if (items.empty() && stop.load() && s.queue.size() == 0) {
        (void)s.acks.Flush(*s.bus);
        break;
      }
      s.Tick(now);
      // Together every kAckFlushPeriodS (urgent ones at once, AckPacer::Urgent);
      // a lost one is said again (AckPacer).
      (void)s.acks.FlushIfDue(*s.bus, now);
      if (now >= next_status) {
        (void)PublishStatus(*s.bus, "analyze", true, "", s.StatusCounters());
        next_status = now + 1.0;
      }
    }
    (void)PublishStatus(*s.bus, "analyze", true, "stopped", s.StatusCounters());
  });
  LogInfo("bus: " + s.bus->security_description() + "; plans accepted: " +
          (s.admission.restricts_plans() ? s.admission.AcceptedNames()
                                         : std::string("any (give --accept-plan to name them)")));
  LogInfo("analyzing on " + o.lcm_url + " (shard " + std::to_string(o.shard_index) + "/" +
          std::to_string(o.shard_count) + ")");
  Status result;
  while (!ShutdownRequested()) {
    Status st = s.bus->HandleFor(100);
    (void)ListeningSeconds();  // observed while the worker is busy (a fit) too
    if (!st.ok()) {
      result = st;
      break;
    }
  }
  stop = true;
  s.queue.Close();
  worker.join();
  return result;
}

}  // namespace imuqual::analyze
