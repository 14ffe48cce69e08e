#include "store/store_service.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <limits>
#include <set>
#include <thread>
#include <variant>

#include "analyze/judge/run_admission.h"
#include "common/listening_clock.h"
#include "common/ack.h"
#include "common/batch_integrity.h"
#include "common/bounded_queue.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/last_heard.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "common/process_status.h"
#include "common/resend_budget.h"
#include "common/seq_tracker.h"
#include "common/shutdown.h"
#include "common/strings.h"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "common/text_util.h"
#include "store/outcome.h"
#include "store/plant_shipper.h"
#include "store/records.h"

namespace imuqual::store {
namespace {

using Item = std::variant<imuqual::run_t, imuqual::rate_batch_t, imuqual::allan_curve_t,
                          imuqual::unit_result_t, imuqual::resend_t>;

constexpr size_t kMaxWaitingPerRun = 4096;     // batches held until the run is announced
constexpr double kDoneAckForS = 60.0;          // a finished run keeps saying so this long
constexpr int64_t kMaxServedPerRequest = 512;  // archived batches resent per request
constexpr int64_t kMaxAhead = int64_t{1} << 20;  // seqs accepted beyond the frontier
constexpr double kRetryPeriodS = 1.0;          // a failed result/curve write is retried
constexpr double kFirstWriteRetryS = 0.1;      // a failed transaction is retried after this,
constexpr double kMaxWriteRetryS = 2.0;        // doubling up to this
constexpr int64_t kBatchOverheadBytes = 256;   // a held batch's size beyond its samples
constexpr size_t kMaxRefusedRuns = 10000;  // refused run ids remembered (beyond: refused again)
constexpr int kMaxRevisions = 3;               // judgement rounds before the store settles

// Adds `seq` to a set of ranges (kept short: consecutive seqs extend the last).
void AddSeq(std::vector<SeqRange>* ranges, int64_t seq) {
  for (SeqRange& r : *ranges) {
    if (seq >= r.first && seq <= r.last) return;
  }
  if (!ranges->empty() && ranges->back().last + 1 == seq) {
    ranges->back().last = seq;
  } else {
    ranges->push_back({seq, seq});
  }
}
bool InRanges(const std::vector<SeqRange>& ranges, int64_t seq) {
  return std::any_of(ranges.begin(), ranges.end(),
                     [seq](const SeqRange& r) { return seq >= r.first && seq <= r.last; });
}

std::string Fixed(double value, int decimals) {
  char text[48];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}
std::string Ms(int64_t micros) { return Fixed(static_cast<double>(micros) / 1e3, 1); }

struct StoreRun {
  int64_t key = -1;  // -1: not in the archive yet
  RunInfo info;
  SeqTracker tracker;
  std::vector<imuqual::rate_batch_t> waiting;  // batches before the run is known
  // Written in every transaction until one commits (a failed transaction
  // loses nothing: these stay until they are durable).
  std::vector<CurveRecord> curves_pending;
  std::optional<ResultRecord> result;  // the final result, once received
  // The encoding of that result's message as received (host_utime zeroed):
  // the same result published again is recognized ("" after a restart).
  std::string result_message;
  bool result_stored = false;
  std::set<std::string> curves_stored;  // axes whose final curve is durable
  // A run is archived when its samples, a final curve of every axis and its
  // judgement are (curves and results lost on the bus are published again
  // by analyze until this store confirms the run done).
  bool JudgedAndCurved() const {
    if (!result_stored) return false;
    return std::all_of(info.axes.begin(), info.axes.end(),
                       [&](const AxisInfo& a) { return curves_stored.count(a.name) > 0; });
  }
  double next_retry_s = 0;
  bool done = false;
  double done_s = 0;
  AckPacer ack;
  // acquire's side: what it still retains, and whether it is gone.
  int64_t acquire_retained_first = 0;
  bool acquire_gone = false;
  double next_announce_s = 0;
  std::vector<double> codec_scales;  // per axis, from one chunk to the next
  // Seqs this store asked to be resent (pruned below the frontier): a batch
  // among them arrives late by design and stays out of the latency figures.
  std::vector<SeqRange> requested;
  // Seqs that arrived but could not be written at least once, and why: if
  // one of them is never archived it is a "store_write" gap, not "seq".
  std::vector<SeqRange> unwritten;
  std::string unwritten_cause;
  bool WasRequested(int64_t seq) const {
    return std::any_of(requested.begin(), requested.end(),
                       [seq](const SeqRange& h) { return seq >= h.first && seq <= h.last; });
  }
  explicit StoreRun(const SeqTracker::Options& o) : tracker(0, o) {}
};

// A chunk written in a transaction.
struct StagedChunk {
  std::string run_id;
  int64_t seq = 0;
  int64_t values = 0;        // samples x axes, when the row is new
  int64_t newest_utime = 0;  // host time its newest sample arrived; 0: not timed
  int64_t sent_utime = 0;    // host time acquire sent it; 0: not timed
};

// What a transaction changed, applied to the in-memory state after COMMIT.
struct Staged {
  std::vector<StagedChunk> chunks;                       // now durable
  std::set<std::string> curves;                          // runs whose pending curves are durable
  std::set<std::string> results;                         // runs whose result is durable
};

}  // namespace

Status StoreOptions::Validate() const {
  if (lcm_url.empty()) return Status::InvalidArgument("lcm_url: required");
  IMUQUAL_RETURN_IF_ERROR(LcmBus::CheckSecurity(lcm_url, security));
  if (db_path.empty()) return Status::InvalidArgument("db_path: required");
  if (queue_capacity < 16) return Status::InvalidArgument("queue_capacity: must be >= 16");
  if (max_transaction < 1) return Status::InvalidArgument("max_transaction: must be >= 1");
  if (!(hole_give_up_s > 0)) return Status::InvalidArgument("hole_give_up_s: must be > 0");
  if (!(stale_after_s > 0)) return Status::InvalidArgument("stale_after_s: must be > 0");
  if (!(heartbeat_s > 0)) return Status::InvalidArgument("heartbeat_s: must be > 0");
  if (!station.empty()) IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("station", station));
  if (max_unwritten_mb < 1) return Status::InvalidArgument("max_unwritten_mb: must be >= 1");
  if (!(write_give_up_s > 0)) return Status::InvalidArgument("write_give_up_s: must be > 0");
  if (!sync_to.empty() && !IsPostgresUrl(sync_to)) {
    return Status::InvalidArgument("sync_to: the plant archive must be a postgresql:// URL, not '" +
                                   sync_to + "'");
  }
  if (!(sync_period_s > 0)) return Status::InvalidArgument("sync_period_s: must be > 0");
  return Status::Ok();
}

struct StoreService::Impl {
  StoreOptions options;
  std::unique_ptr<Archive> archive;
  std::unique_ptr<PlantShipper> shipper;  // with sync_to: ships finalised runs to the plant
  std::unique_ptr<LcmBus> bus;
  BoundedQueue<Item> queue;
  std::map<std::string, StoreRun> runs;
  std::set<std::string> finalized;  // runs archived for good; their late messages are ignored
  // Of those announced again by acquire: how they ended, read once.
  std::map<std::string, RunInfo> final_ends;
  LastHeard acquire_heard;          // acquire's run_t arrivals, noted by the handler
  SeqTracker::Options tracker_options;
  std::string instance = InstanceName();
  // The acknowledgements due, sent together (AckBatch::FlushIfDue, end of Tick).
  AckBatch acks{"store", instance};
  std::string health_message;
  ThrottledLog write_errors;
  ThrottledLog rejections;
  std::atomic<int64_t> received{0};
  int64_t chunks_inserted = 0, duplicates = 0, absurd = 0, rejected = 0, waiting_dropped = 0,
          commits = 0, commit_failures = 0, apply_errors = 0, resend_requests = 0,
          batches_given_up = 0, runs_done = 0, batches_served = 0, runs_taken_over = 0,
          late_messages = 0, values_archived = 0, foreign_messages = 0, write_retries = 0,
          unwritten_dropped = 0, damaged = 0, judgements_superseded = 0, stale_results = 0;
  ThrottledLog damage_log;
  std::set<std::string> foreign_runs;  // runs of other stations (writer thread)
  // Runs whose announcement was refused (judge::RunAdmission): never
  // archived, their messages dropped (writer thread).
  judge::RunAdmission admission;
  std::set<std::string> refused_runs;
  std::unique_ptr<ResendBudget> resend_budget;  // per requester
  int64_t resends_throttled = 0;
  int64_t runs_refused = 0, announcements_refused = 0, messages_of_refused_runs = 0,
          results_conflicting = 0, settled_messages = 0;
  ThrottledLog refusal_log;
  // "" if `msg` announces the run `known` describes, else the field it changes.
  static std::string IdentityChange(const RunInfo& known, const imuqual::run_t& msg);
  void RefuseChange(const std::string& run_id, const std::string& field);
  // Takes a final result of the run's current round (Apply); false if refused.
  bool TakeResult(StoreRun& r, const imuqual::unit_result_t& res);
  // Runs and batches of failed transactions, written again (before anything
  // newer) once the back-off allows; bounded by max_unwritten_mb.
  std::vector<Item> held;
  int64_t held_bytes = 0, held_batches = 0;
  std::map<std::string, size_t> held_run_at;  // run id -> its run_t in `held`
  bool write_failing = false;
  double write_failing_since_s = 0, next_write_s = 0, write_backoff_s = 0;
  std::string write_error;
  std::atomic<bool> gave_up_writing{false};
  // Commit time minus the arrival of each batch's newest sample, over the
  // batches archived on their first arrival (resends and replays after a
  // restart are late by design): how far the archive trails the units.
  LatencyHistogram sample_to_archive;
  // Commit time minus the time acquire sent the batch, same batches: the
  // station's own share (bus, queue, transaction), whatever the source's
  // timing.
  LatencyHistogram sent_to_archive;

  explicit Impl(const StoreOptions& o)
      : options(o), queue(static_cast<size_t>(o.queue_capacity)), admission(o.accepted_plans) {
    tracker_options.give_up_after_s = o.hole_give_up_s;
    tracker_options.max_ahead = kMaxAhead;
  }

  // The run's state, or nullptr for a run already finalized (its late
  // messages are ignored). Creates the state of a run seen for the first time.
  StoreRun* Find(const std::string& run_id);
  Status Resume(const std::string& run_id, double now);
  bool ReopenIfResumed(const imuqual::run_t& msg, double now);
  std::string UncoveredBy(const StoreRun& r);
  Result<int> OpenJudgementRound(int64_t key, const std::string& run_id, const std::string& cause);
  void Supersede(StoreRun& r, const std::string& cause, double now);
  bool OfAnotherStation(const imuqual::run_t& run) const {
    return !options.station.empty() && run.station != options.station;
  }
  Status Apply(Item& item, Staged* staged);
  Status ApplyRun(const imuqual::run_t& msg, Staged* staged);
  Status ApplyBatch(StoreRun& r, const imuqual::rate_batch_t& b, Staged* staged);
  Status WritePending(StoreRun& r, Staged* staged);
  Status Commit();
  void Transaction(std::vector<Item>& items, double now, bool force = false);
  void Hold(Item&& item);
  void Remember(Item& item);
  void WriteFailed(const Status& st, double now);
  void WriteRecovered(double now);
  int64_t UnwrittenBatches() const { return held_batches; }
  void Committed(const Staged& staged);
  void RolledBack();
  Status ServeResend(const imuqual::resend_t& req);
  void TakeOver(const std::string& run_id, StoreRun& r, double now);
  void RecordGivenUp(StoreRun& r, const std::vector<SeqRange>& holes);
  void Tick(double now);
  Status Finalize(StoreRun& r);
  Counters StatusCounters() const;
  void LogSummary() const;
};

StoreService::StoreService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
StoreService::~StoreService() = default;

Result<std::unique_ptr<StoreService>> StoreService::Create(const StoreOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  auto impl = std::make_unique<Impl>(options);
  auto archive = Archive::Open(options.db_path, Archive::Mode::kWrite);
  if (!archive.ok()) return archive.status();
  impl->archive = std::move(*archive);
  if (options.security.signing_key) {
    IMUQUAL_RETURN_IF_ERROR(impl->archive->SetSigningKey(*options.security.signing_key));
  }
  auto unfinished = impl->archive->UnfinishedRunIds();
  if (!unfinished.ok()) return unfinished.status();
  for (const std::string& id : *unfinished) {
    IMUQUAL_RETURN_IF_ERROR(impl->Resume(id, ListeningSeconds()));
  }
  return std::unique_ptr<StoreService>(new StoreService(std::move(impl)));
}

StoreRun* StoreService::Impl::Find(const std::string& run_id) {
  auto it = runs.find(run_id);
  if (it != runs.end()) return &it->second;
  if (finalized.count(run_id)) return nullptr;
  auto done = archive->IsFinalized(run_id);
  if (done.ok() && *done) {
    finalized.insert(run_id);
    return nullptr;
  }
  return &runs.try_emplace(run_id, tracker_options).first->second;
}

// A run the archive holds but has not finalized (this store stopped before
// its end): the tracker starts from what is archived and from the holes
// already given up; acquire has stale_after_s to show up before the store
// takes the run over.
Status StoreService::Impl::Resume(const std::string& run_id, double now) {
  auto info = archive->LoadRun(run_id);
  if (!info.ok()) return info.status();
  auto key = archive->FindRunKey(run_id);
  if (!key.ok()) return key.status();
  StoreRun& r = runs.try_emplace(run_id, tracker_options).first->second;
  r.key = **key;
  r.info = *info;
  auto next = archive->NextMissingSeq(r.key);
  if (!next.ok()) return next.status();
  auto held = archive->ArchivedSeqsFrom(r.key, *next);
  if (!held.ok()) return held.status();
  auto gaps = archive->LoadGaps(r.key);
  if (!gaps.ok()) return gaps.status();
  r.tracker = SeqTracker(*next, tracker_options);
  for (int64_t seq : *held) r.tracker.Offer(seq);
  for (const GapRecord& g : *gaps) {
    if (g.reason == "seq" || g.reason == "store_write") r.tracker.Skip({g.first_seq, g.last_seq});
  }
  r.tracker.SetAnnouncedLast(r.info.last_seq);
  if (r.info.state != "running") r.tracker.SetFinal();
  auto result = archive->LoadResult(r.key);
  if (!result.ok()) return result.status();
  if (result->has_value()) {
    r.result = std::move(**result);
    r.result_stored = true;
  }
  auto curves = archive->LoadCurves(r.key);
  if (!curves.ok()) return curves.status();
  for (const CurveRecord& c : *curves) r.curves_stored.insert(c.axis);
  (void)now;
  acquire_heard.Note(run_id);  // acquire gets stale_after_s from now to show up
  LogInfo("run " + run_id + ": resuming an unfinished run, " + std::to_string(*next) +
          " batches archived in order");
  return Status::Ok();
}

// A finalized run that acquire announces going on although the store had
// ended it as incomplete (acquire silent, e.g. a paused host or a network
// partition longer than stale_after_s): its judgement is superseded and the
// run is open again, to be archived and judged on all its data.
bool StoreService::Impl::ReopenIfResumed(const imuqual::run_t& msg, double now) {
  if (!finalized.count(msg.run_id)) return false;
  // How each such run ended, read once (acquire announces a run it ended
  // every second until it leaves).
  auto ended = final_ends.find(msg.run_id);
  if (ended == final_ends.end()) {
    auto archived = archive->LoadRun(msg.run_id);
    if (!archived.ok()) return false;
    ended = final_ends.emplace(msg.run_id, std::move(*archived)).first;
  }
  const RunInfo& info = ended->second;
  if (const std::string field = IdentityChange(info, msg); !field.empty()) {
    RefuseChange(msg.run_id, field);
    return false;
  }
  if (info.state != "incomplete") return false;
  if (msg.state != imuqual::run_t::STATE_RUNNING && msg.last_seq <= info.last_seq) return false;
  auto key = archive->FindRunKey(msg.run_id);
  if (!key.ok() || !key->has_value()) return false;
  const std::string cause = "acquire announced the run going on (batch " +
                            std::to_string(msg.last_seq) + ") after it had ended as incomplete (" +
                            info.end_reason + ") at batch " + std::to_string(info.last_seq);
  auto revision = OpenJudgementRound(**key, msg.run_id, cause);
  if (!revision.ok()) return false;
  final_ends.erase(msg.run_id);
  finalized.erase(msg.run_id);
  runs.erase(msg.run_id);
  if (Status resumed = Resume(msg.run_id, now); !resumed.ok()) {
    write_errors.Error("run " + msg.run_id + ": " + resumed.message());
    return false;
  }
  StoreRun& r = runs.at(msg.run_id);
  if (msg.state == imuqual::run_t::STATE_RUNNING) r.tracker.SetFinal(false);
  r.next_announce_s = now;
  return true;
}

// Why the run's final result does not describe what the archive holds ("" if
// it does): another judgement round, fewer batches than the run has, or
// other batches taken as gaps than the archive lacks. A result archived
// before schema 4 does not say what it covered and is taken as it is.
std::string StoreService::Impl::UncoveredBy(const StoreRun& r) {
  const ResultRecord& res = *r.result;
  if (res.revision != r.info.revision) {
    return "the judgement answers round " + std::to_string(res.revision) + ", the run is at round " +
           std::to_string(r.info.revision);
  }
  if (!res.last_seq || !res.gap_batches) return "";
  const int64_t last_seq = std::max(r.info.last_seq, r.tracker.next_seq() - 1);
  if (*res.last_seq != last_seq) {
    return "the judgement covers batches 0.." + std::to_string(*res.last_seq) + " of 0.." +
           std::to_string(last_seq);
  }
  auto archived = archive->db().QueryInt("SELECT COUNT(*) FROM raw_chunks WHERE run_key = " +
                                         std::to_string(r.key) + " AND seq <= " +
                                         std::to_string(last_seq));
  if (!archived.ok()) return "";  // cannot tell; the archive's own error is reported elsewhere
  const int64_t missing = last_seq + 1 - *archived;
  if (*res.gap_batches != missing) {
    return "the judgement took " + std::to_string(*res.gap_batches) +
           " batches as never arrived, the archive lacks " + std::to_string(missing);
  }
  return "";
}

// In a transaction of its own: the run's archived judgement superseded (kept,
// with `cause`) and a new judgement round opened. The new round, or the
// error (logged).
Result<int> StoreService::Impl::OpenJudgementRound(int64_t key, const std::string& run_id,
                                                   const std::string& cause) {
  Status st = archive->Begin();
  Result<int> revision = st.ok() ? archive->SupersedeJudgement(key, NowUtime(), cause) : st;
  st = revision.status();
  if (st.ok()) st = Commit();
  if (!st.ok()) {
    (void)archive->Rollback();
    write_errors.Error("run " + run_id + ": cannot open a new judgement round: " + st.message());
    return st;
  }
  ++judgements_superseded;
  LogWarning("run " + run_id + ": " + cause + "; its judgement is superseded, judged again (round " +
             std::to_string(*revision) + ")");
  return revision;
}

// Opens a new judgement round for a run whose result does not describe its
// archived data; the store announces the round until analyze answers it.
void StoreService::Impl::Supersede(StoreRun& r, const std::string& cause, double now) {
  auto revision = OpenJudgementRound(r.key, r.info.run_id, cause);
  if (!revision.ok()) return;
  r.info.revision = *revision;
  r.result.reset();
  r.result_stored = false;
  r.curves_stored.clear();
  r.curves_pending.clear();
  r.next_announce_s = now;
}

// acquire went silent: nothing more will come from it. A running run is
// incomplete; its holes become gaps; the store announces the run and serves
// its batches from the archive until its analysis is stored.
void StoreService::Impl::TakeOver(const std::string& run_id, StoreRun& r, double now) {
  r.acquire_gone = true;
  ++runs_taken_over;
  if (r.info.state == "running") {
    r.info.state = "incomplete";
    r.info.end_utime = NowUtime();
    // Batches published after acquire's last announcement are part of it.
    r.info.last_seq = std::max(r.info.last_seq, r.tracker.highest());
    r.tracker.SetAnnouncedLast(r.info.last_seq);
    r.info.end_reason = "acquire silent for " + std::to_string(static_cast<int>(options.stale_after_s)) +
                        " s after " + std::to_string(r.info.last_seq + 1) + " batches";
    Status st = archive->Begin();
    if (st.ok()) st = archive->UpsertRun(r.info).status();
    if (st.ok()) st = Commit();
    if (!st.ok()) {
      (void)archive->Rollback();
      write_errors.Error("run " + run_id + ": cannot mark it incomplete: " + st.message());
    }
    LogWarning("run " + run_id + ": acquire silent for " +
               std::to_string(static_cast<int>(options.stale_after_s)) +
               " s; the run is incomplete after " + std::to_string(r.info.last_seq + 1) + " batches");
  }
  r.tracker.SetFinal();
  RecordGivenUp(r, r.tracker.GiveUpAll());
  r.next_announce_s = now;
}

// Given-up holes go into the archive at once (a restarted store then does not
// wait for them again); failures only cost that wait.
void StoreService::Impl::RecordGivenUp(StoreRun& r, const std::vector<SeqRange>& holes) {
  if (holes.empty()) return;
  Status st = archive->Begin();
  for (const SeqRange& hole : holes) {
    batches_given_up += hole.last - hole.first + 1;
    // Split the hole where it changes between batches that never arrived
    // and batches that arrived but could not be written.
    for (int64_t first = hole.first; first <= hole.last;) {
      const bool unwritten = InRanges(r.unwritten, first);
      int64_t last = first;
      while (last < hole.last && InRanges(r.unwritten, last + 1) == unwritten) ++last;
      const std::string range = std::to_string(first) + ".." + std::to_string(last);
      if (unwritten) {
        LogError("run " + r.info.run_id + ": batches " + range +
                 " arrived but were never archived (store could not write: " + r.unwritten_cause +
                 ") and acquire no longer has them; recorded as a gap");
      } else {
        LogWarning("run " + r.info.run_id + ": batches " + range +
                   " never arrived; recorded as a gap");
      }
      if (st.ok()) {
        st = archive->InsertGap(
            r.key, {first, last, {}, {}, unwritten ? "store_write" : "seq", NowUtime()});
      }
      first = last + 1;
    }
  }
  if (st.ok()) st = Commit();
  if (!st.ok()) {
    (void)archive->Rollback();
    write_errors.Error("run " + r.info.run_id + ": cannot record gaps: " + st.message());
  }
}

// Resends from the archive what acquire cannot: batches it no longer
// retains, or all of them once it is gone.
// `req.requester` is the role the request's seal names (the handler put it
// there), in decimal: each requesting role is served within its budget
// (common/resend_budget.h); the rest is dropped and counted.
Status StoreService::Impl::ServeResend(const imuqual::resend_t& req) {
  const uint64_t requester = std::strtoull(req.requester.c_str(), nullptr, 10);
  auto it = runs.find(req.run_id);
  if (it == runs.end() || it->second.key < 0) return Status::Ok();
  StoreRun& r = it->second;
  const int64_t first = std::max<int64_t>(req.first_seq, 0);
  int64_t last = std::min(req.last_seq, first + kMaxServedPerRequest - 1);
  if (!r.acquire_gone) last = std::min(last, r.acquire_retained_first - 1);
  if (last < first) return Status::Ok();
  const double now = ListeningSeconds();
  // Served in seq order until the requester's budget is spent: the rest of
  // the request is counted, not read.
  const Status kSpent = Status::Unavailable("resend budget spent");
  bool spent = false;
  Status st = archive->ForEachChunk(
      r.key,
      [&](const ChunkRecord& c) -> Status {
        if (!resend_budget->Take(requester, static_cast<double>(c.data.size()), now)) {
          resends_throttled += last - c.seq + 1;
          spent = true;
          return kSpent;  // the requester asks again, with back-off
        }
        auto batch = BatchFromChunk(r.info, c);
        std::vector<uint8_t> bytes;
        Status sealed = batch.ok() ? EncodeSealedBatch(&*batch, &bytes) : batch.status();
        if (!sealed.ok()) {
          rejections.Error("cannot resend " + r.info.run_id + " seq " + std::to_string(c.seq) +
                           " from the archive: " + sealed.message());
          return Status::Ok();  // serve the rest
        }
        ++batches_served;
        return bus->PublishEncoded(channels::Raw(r.info.serial), bytes);
      },
      first, last);
  return spent ? Status::Ok() : st;
}

Status StoreService::Impl::ApplyRun(const imuqual::run_t& msg, Staged* staged) {
  if (msg.announcer == "store") return Status::Ok();  // a store's own re-announcement
  StoreRun* found = Find(msg.run_id);
  if (found == nullptr || found->done) {  // archived for good: nothing of it changes
    ++late_messages;
    return Status::Ok();
  }
  StoreRun& r = *found;
  const bool first = r.key < 0;
  if (!first) {
    if (const std::string field = IdentityChange(r.info, msg); !field.empty()) {
      RefuseChange(msg.run_id, field);
      return Status::Ok();
    }
  }
  r.acquire_retained_first = msg.retained_first_seq;
  if (r.acquire_gone && msg.state == imuqual::run_t::STATE_RUNNING) {
    // Back after the store found it silent: the run goes on, and whatever
    // was judged on its first part is judged again (UncoveredBy).
    LogWarning("run " + msg.run_id + ": acquire is back (batch " + std::to_string(msg.last_seq) +
               "); the run goes on");
    r.tracker.SetFinal(false);
  }
  r.acquire_gone = false;
  const int revision = r.info.revision;  // the store's, not in acquire's announcements
  r.info = RunInfoFromMessage(msg);
  r.info.revision = revision;
  r.info.bus_auth = bus->security_description();
  auto key = archive->UpsertRun(r.info);
  if (!key.ok()) return key.status();
  if (first) {
    r.key = *key;
    // Resume from what the archive already holds (a restarted store).
    auto next = archive->NextMissingSeq(r.key);
    if (!next.ok()) return next.status();
    auto held = archive->ArchivedSeqsFrom(r.key, *next);
    if (!held.ok()) return held.status();
    r.tracker = SeqTracker(*next, tracker_options);
    for (int64_t seq : *held) r.tracker.Offer(seq);
    if (*next > 0) {
      LogInfo("run " + msg.run_id + ": resuming, " + std::to_string(*next) +
              " batches already archived");
    }
    // If this transaction fails these are resent (the tracker did not move).
    std::vector<imuqual::rate_batch_t> waiting = std::move(r.waiting);
    r.waiting.clear();
    for (const imuqual::rate_batch_t& b : waiting) IMUQUAL_RETURN_IF_ERROR(ApplyBatch(r, b, staged));
    IMUQUAL_RETURN_IF_ERROR(WritePending(r, staged));
  }
  r.tracker.SetAnnouncedLast(msg.last_seq);
  if (msg.state != imuqual::run_t::STATE_RUNNING) r.tracker.SetFinal();
  return Status::Ok();
}

Status StoreService::Impl::ApplyBatch(StoreRun& r, const imuqual::rate_batch_t& b, Staged* staged) {
  if (r.key < 0) {
    if (r.waiting.size() >= kMaxWaitingPerRun) {
      ++waiting_dropped;  // it will be requested again once the run is known
    } else {
      r.waiting.push_back(b);
    }
    return Status::Ok();
  }
  if (b.seq < 0 || b.seq > r.tracker.next_seq() + kMaxAhead) {
    ++absurd;
    return Status::Ok();
  }
  if (r.tracker.Has(b.seq)) {  // already archived (a resend, or one the store served itself)
    ++duplicates;
    return Status::Ok();
  }
  std::string wrong;
  if (b.num_axes != static_cast<int>(r.info.axes.size())) wrong = "axes";
  if (b.num_samples < 1) wrong = "sample count";
  if (b.nominal_rate_hz != r.info.nominal_rate_hz) wrong = "rate";
  for (int i = 0; i < b.num_flagged && wrong.empty(); ++i) {
    if (b.flagged_sample[i] < 0 || b.flagged_sample[i] >= b.num_samples || b.flagged_axis[i] < 0 ||
        b.flagged_axis[i] >= b.num_axes) {
      wrong = "flags";
    }
  }
  if (!wrong.empty()) {
    ++rejected;
    rejections.Error("run " + b.run_id + " seq " + std::to_string(b.seq) +
                     ": batch does not match the run (" + wrong + "); rejected");
    return Status::Ok();
  }
  bool inserted = false;
  IMUQUAL_RETURN_IF_ERROR(archive->InsertChunk(r.key, ChunkFromBatch(b, &r.codec_scales), &inserted));
  if (!inserted) ++duplicates;
  StagedChunk staged_chunk{b.run_id, b.seq, 0, 0, 0};  // durable either way once committed
  if (inserted) {
    staged_chunk.values = int64_t{b.num_samples} * b.num_axes;
    if (!r.WasRequested(b.seq)) {
      staged_chunk.sent_utime = b.host_utime;
      // The newest sample arrived (num_samples - 1) sample periods after the
      // first: the batch could not have been sent before that.
      if (b.sample_utime > 0 && b.nominal_rate_hz > 0) {
        staged_chunk.newest_utime =
            b.sample_utime + std::llround((b.num_samples - 1) * 1e6 / b.nominal_rate_hz);
      }
    }
  }
  staged->chunks.push_back(std::move(staged_chunk));
  return Status::Ok();
}

namespace {

// The judgement round a curve or result answers (0 for other messages).
int RoundOf(const Item& item) {
  if (auto* c = std::get_if<imuqual::allan_curve_t>(&item)) return c->revision;
  if (auto* res = std::get_if<imuqual::unit_result_t>(&item)) return res->revision;
  return 0;
}

// The analysis judged samples the archive does not hold (batches it
// received but could not write, then lost): they are gap samples of the
// archived result, and the run FAILs with the cause, since its verdict can
// no longer be recomputed from the archive.
void AmendForUnarchived(const StoreRun& r, const std::vector<GapRecord>& gaps,
                        ResultRecord* result) {
  int64_t lost = 0, batches = 0;
  std::vector<std::string> ranges;
  const double per_batch = r.info.last_seq >= 0 ? static_cast<double>(r.info.samples_announced) /
                                                      static_cast<double>(r.info.last_seq + 1)
                                                : 0.0;
  for (const GapRecord& g : gaps) {
    if (g.reason != "store_write") continue;
    const int64_t n = g.last_seq - g.first_seq + 1;
    batches += n;
    lost += g.num_samples && *g.num_samples > 0 ? *g.num_samples
                                                : std::llround(per_batch * static_cast<double>(n));
    ranges.push_back(std::to_string(g.first_seq) + ".." + std::to_string(g.last_seq));
  }
  if (batches == 0) return;
  // A result that says what it covered was computed on the archive's data
  // (UncoveredBy): it counts these batches as gaps already.
  if (!result->gap_batches) result->gap_samples += lost;
  // A station fault, not a property of the unit: ERROR (never a yield loss).
  result->verdict = "ERROR";
  result->reasons.push_back(
      "archive incomplete: " + std::to_string(lost) + " samples (" + std::to_string(batches) +
      " batches, seq " + Join(ranges, ", ") +
      ") arrived but were never archived (store could not write: " +
      (r.unwritten_cause.empty() ? std::string("write failed") : r.unwritten_cause) +
      ")" + (result->gap_batches ? std::string("; judged on the rest")
                                 : std::string("; the verdict cannot be recomputed from the archive")));
}

}  // namespace

std::string StoreService::Impl::IdentityChange(const RunInfo& known, const imuqual::run_t& msg) {
  return judge::RunIdentityDifference(MessageFromRunInfo(known), msg);
}

void StoreService::Impl::RefuseChange(const std::string& run_id, const std::string& field) {
  ++announcements_refused;
  refusal_log.Warning("refused an announcement of run " + run_id + " that changes its " + field +
                      " (fixed at its first announcement)");
}

// The same final result again (analyze republishes until confirmed) is
// taken as it is; another one of the same round only if it judged more of
// the run (analyze ended it early, then heard it go on): a judgement on
// less of the data, or a different one on the same data, is refused.
bool StoreService::Impl::TakeResult(StoreRun& r, const imuqual::unit_result_t& res) {
  imuqual::unit_result_t plain = res;
  plain.host_utime = 0;
  std::vector<uint8_t> encoded;
  if (!EncodeMessage(plain, &encoded).ok()) return false;
  std::string message(encoded.begin(), encoded.end());
  if (message == r.result_message) return false;  // already taken
  if (!r.result_message.empty() && r.result && r.result->revision == res.revision) {
    const int64_t had_last = r.result->last_seq.value_or(-1);
    const int64_t had_gaps = r.result->gap_batches.value_or(0);
    const bool covers_more = res.last_seq > had_last ||
                             (res.last_seq == had_last && res.gap_batches < had_gaps);
    if (!covers_more) {
      ++results_conflicting;
      refusal_log.Warning("run " + res.run_id + ": refused a final result (" +
                          OutcomeText(OutcomeFromNumber(res.verdict)) + ") that disagrees with the one taken for "
                          "the same data of round " + std::to_string(res.revision));
      return false;
    }
    LogInfo("run " + res.run_id + ": a final result on more of the run (to batch " +
            std::to_string(res.last_seq) + ") replaces the one to batch " + std::to_string(had_last));
  }
  r.result = ResultFromMessage(res);
  r.result_message = std::move(message);
  r.result_stored = false;
  return true;
}

// Writes the run's pending curves and result (if any) into the current
// transaction.
Status StoreService::Impl::WritePending(StoreRun& r, Staged* staged) {
  for (const CurveRecord& c : r.curves_pending) IMUQUAL_RETURN_IF_ERROR(archive->PutCurve(r.key, c));
  if (!r.curves_pending.empty()) staged->curves.insert(r.info.run_id);
  if (r.result && !r.result_stored) {
    int64_t gap_ranges = 0;
    ResultRecord stored = *r.result;
    if (r.done) {
      auto gaps = archive->LoadGaps(r.key);
      if (!gaps.ok()) return gaps.status();
      gap_ranges = static_cast<int64_t>(gaps->size());
      AmendForUnarchived(r, *gaps, &stored);
    }
    stored.record = BuildRunRecord(r.info, stored, gap_ranges).SerializeAsString();
    IMUQUAL_RETURN_IF_ERROR(archive->PutResult(r.key, stored));
    staged->results.insert(r.info.run_id);
  }
  return Status::Ok();
}

Status StoreService::Impl::Apply(Item& item, Staged* staged) {
  // A damaged batch is never archived (nor is its run id trusted): dropped,
  // its seq stays a hole that the tracker asks to be resent.
  if (auto* b = std::get_if<imuqual::rate_batch_t>(&item)) {
    if (Status st = VerifyBatch(*b); !st.ok()) {
      ++damaged;
      damage_log.Warning(st.message() + "; dropped, to be resent");
      return Status::Ok();
    }
  }
  const std::string& run_id = std::visit([](const auto& m) -> const std::string& { return m.run_id; }, item);
  if (foreign_runs.count(run_id)) {
    ++foreign_messages;
    return Status::Ok();
  }
  if (refused_runs.count(run_id)) {
    ++messages_of_refused_runs;
    return Status::Ok();
  }
  if (auto* run = std::get_if<imuqual::run_t>(&item)) {
    if (run->announcer == "store") return Status::Ok();  // a store's own re-announcement
    if (Status st = admission.Admit(*run); !st.ok()) {
      ++runs_refused;
      if (refused_runs.size() < kMaxRefusedRuns) refused_runs.insert(run_id);
      if (auto waiting = runs.find(run_id); waiting != runs.end() && waiting->second.key < 0) {
        runs.erase(waiting);  // batches that came before the announcement go too
      }
      refusal_log.Warning("refused run " + run_id.substr(0, 160) + ": " + st.message() +
                          "; it is not archived");
      return Status::Ok();
    }
    if (OfAnotherStation(*run)) {
      // Another station's run on this bus: its own store archives it.
      foreign_runs.insert(run_id);
      ++foreign_messages;
      LogWarning("ignoring run " + run_id + " of station '" + run->station +
                 "' (this store serves station '" + options.station + "')");
      return Status::Ok();
    }
    return ApplyRun(*run, staged);
  }
  StoreRun* r = Find(run_id);
  if (r == nullptr) {
    ++late_messages;
    // A result or curve of a run archived for good: its analyze did not hear
    // the confirmation; say it again.
    if (finalized.count(run_id) && (std::holds_alternative<imuqual::unit_result_t>(item) ||
                                    std::holds_alternative<imuqual::allan_curve_t>(item))) {
      acks.Add(run_id, std::numeric_limits<int64_t>::max(), true);
    }
    return Status::Ok();
  }
  if (r->done) {
    // Finalized: settled. A batch is not added to it (acquire back after a
    // take-over opens the run again first, ReopenIfResumed, and the batches
    // are asked for again).
    if (std::holds_alternative<imuqual::rate_batch_t>(item)) {
      ++late_messages;
      return Status::Ok();
    }
    // Nothing a message says changes it; its analyze hears the confirmation again.
    ++settled_messages;
    acks.Add(run_id, std::numeric_limits<int64_t>::max(), true);
    return Status::Ok();
  }
  if (auto* b = std::get_if<imuqual::rate_batch_t>(&item)) return ApplyBatch(*r, *b, staged);
  if (RoundOf(item) != r->info.revision) {
    ++stale_results;  // answers an earlier judgement round (or a store that forgot one)
    return Status::Ok();
  }
  if (auto* c = std::get_if<imuqual::allan_curve_t>(&item)) {
    r->curves_pending.push_back(CurveFromMessage(*c));
  } else if (auto* res = std::get_if<imuqual::unit_result_t>(&item)) {
    if (!TakeResult(*r, *res)) return Status::Ok();
  }
  return r->key < 0 ? Status::Ok() : WritePending(*r, staged);
}

void StoreService::Impl::Committed(const Staged& staged) {
  const int64_t committed_utime = staged.chunks.empty() ? 0 : NowUtime();
  for (const StagedChunk& c : staged.chunks) {
    auto it = runs.find(c.run_id);
    if (it != runs.end() && it->second.tracker.Offer(c.seq) == SeqTracker::Arrival::kNew) {
      ++chunks_inserted;
      values_archived += c.values;
      if (c.newest_utime > 0) sample_to_archive.Add(committed_utime - c.newest_utime);
      if (c.sent_utime > 0) sent_to_archive.Add(committed_utime - c.sent_utime);
    }
  }
  for (const std::string& run_id : staged.curves) {
    StoreRun& r = runs.at(run_id);
    for (const CurveRecord& c : r.curves_pending) r.curves_stored.insert(c.axis);
    r.curves_pending.clear();
  }
  for (const std::string& run_id : staged.results) runs.at(run_id).result_stored = true;
}

void StoreService::Impl::RolledBack() {
  // Keys of runs created in the failed transaction are gone again.
  for (auto& [id, r] : runs) {
    if (r.key >= 0) {
      auto key = archive->FindRunKey(id);
      if (!key.ok() || !key->has_value()) r.key = -1;
    }
  }
}

Status StoreService::Impl::Commit() {
  if (options.before_commit) IMUQUAL_RETURN_IF_ERROR(options.before_commit());
  return archive->Commit();
}

// An item of a failed transaction (or one that came while writes back off):
// runs and batches are held to be written again; curves and results already
// wait in their run (Remember).
void StoreService::Impl::Hold(Item&& item) {
  if (auto* run = std::get_if<imuqual::run_t>(&item)) {
    auto at = held_run_at.find(run->run_id);
    if (at != held_run_at.end()) {
      held[at->second] = std::move(item);  // its newest announcement, where the first one was
    } else {
      held_run_at[run->run_id] = held.size();
      held.push_back(std::move(item));
    }
    return;
  }
  auto* b = std::get_if<imuqual::rate_batch_t>(&item);
  if (b == nullptr) return;
  StoreRun* r = Find(b->run_id);
  if (r == nullptr || (r->key >= 0 && r->tracker.Has(b->seq))) return;  // archived already
  AddSeq(&r->unwritten, b->seq);
  r->unwritten_cause = write_error;
  const int64_t bytes = kBatchOverheadBytes + 4 * static_cast<int64_t>(b->samples.size());
  if (held_bytes + bytes > int64_t{options.max_unwritten_mb} << 20) {
    // Not acknowledged: acquire retains it and resends it when asked.
    ++unwritten_dropped;
    return;
  }
  held_bytes += bytes;
  ++held_batches;
  held.push_back(std::move(item));
}

// Curves and results wait in their run until a transaction holding them
// commits (WritePending); this only puts them there.
void StoreService::Impl::Remember(Item& item) {
  const bool curve = std::holds_alternative<imuqual::allan_curve_t>(item);
  if (!curve && !std::holds_alternative<imuqual::unit_result_t>(item)) return;
  const std::string& run_id =
      std::visit([](const auto& m) -> const std::string& { return m.run_id; }, item);
  StoreRun* r = Find(run_id);
  if (r == nullptr || RoundOf(item) != r->info.revision) return;
  if (curve) {
    r->curves_pending.push_back(CurveFromMessage(std::get<imuqual::allan_curve_t>(item)));
  } else {
    r->result = ResultFromMessage(std::get<imuqual::unit_result_t>(item));
    r->result_stored = false;
  }
}

void StoreService::Impl::WriteFailed(const Status& st, double now) {
  ++commit_failures;
  write_error = st.message();
  if (!write_failing) {
    write_failing = true;
    write_failing_since_s = now;
    write_backoff_s = kFirstWriteRetryS;
  } else {
    write_backoff_s = std::min(write_backoff_s * 2, kMaxWriteRetryS);
    ++write_retries;
  }
  next_write_s = now + write_backoff_s;
  const int failing_s = static_cast<int>(now - write_failing_since_s);
  health_message = "archive cannot write (" + st.message() + ") for " + std::to_string(failing_s) +
                   " s: " + std::to_string(held_batches) + " batches held unacknowledged, retrying";
  write_errors.Error("archive write failed, nothing of it is acknowledged; " +
                     std::to_string(held_batches) + " batches held, retried in " +
                     Fixed(write_backoff_s, 1) + " s: " + st.message());
  if (now - write_failing_since_s > options.write_give_up_s) gave_up_writing = true;
}

void StoreService::Impl::WriteRecovered(double now) {
  if (!write_failing) return;
  write_failing = false;
  LogInfo("the archive writes again after " + Fixed(now - write_failing_since_s, 1) + " s (" +
          std::to_string(write_retries) + " retries so far)");
  // Holes get their full time again: acquire resends what the store could
  // not keep.
  for (auto& [id, r] : runs) r.tracker.Postpone(now);
}

// One transaction for what was held after a failed write, then everything
// popped; the in-memory state (trackers, acks, pending results) moves only
// after COMMIT, so an acknowledged batch is durable. A failed transaction
// holds its runs and batches for the next attempt (back-off) instead of
// losing them. `force`: try now, whatever the back-off.
void StoreService::Impl::Transaction(std::vector<Item>& items, double now, bool force) {
  std::vector<imuqual::resend_t> resends;  // served after the commit, outside the transaction
  std::vector<Item> work = std::move(held);
  held.clear();
  held_run_at.clear();
  held_bytes = 0;
  held_batches = 0;
  work.reserve(work.size() + items.size());
  for (Item& item : items) {
    if (auto* req = std::get_if<imuqual::resend_t>(&item)) {
      resends.push_back(std::move(*req));
    } else {
      work.push_back(std::move(item));
    }
  }
  if (write_failing && now < next_write_s && !force) {
    for (Item& item : work) {
      Remember(item);
      Hold(std::move(item));
    }
  } else if (!work.empty()) {
    // Runs archived for good that acquire announces going on are opened
    // again first, each in a transaction of its own.
    for (const Item& item : work) {
      const auto* run = std::get_if<imuqual::run_t>(&item);
      if (run == nullptr || run->announcer != "acquire" || foreign_runs.count(run->run_id) ||
          OfAnotherStation(*run)) {
        continue;
      }
      if (StoreRun* f = Find(run->run_id); f == nullptr || f->done) (void)ReopenIfResumed(*run, now);
    }
    Staged staged;
    Status st = archive->Begin();
    size_t applied = 0;
    for (; applied < work.size() && st.ok(); ++applied) {
      Status ap = Apply(work[applied], &staged);
      if (!ap.ok()) {
        ++apply_errors;
        // Disk or file trouble fails the whole transaction; anything else
        // loses only the message at fault.
        if (ap.code() == Status::Code::kIoError || ap.code() == Status::Code::kCorruption) {
          st = ap;
        } else {
          write_errors.Error(ap.message());
        }
      }
    }
    if (st.ok()) st = Commit();
    if (st.ok()) {
      ++commits;
      Committed(staged);
      WriteRecovered(now);
      health_message.clear();
    } else {
      (void)archive->Rollback();
      RolledBack();
      write_error = st.message();
      for (size_t i = 0; i < work.size(); ++i) {
        if (i >= applied) Remember(work[i]);  // not applied yet
        Hold(std::move(work[i]));
      }
      WriteFailed(st, now);
    }
  }
  for (const imuqual::resend_t& req : resends) {
    Status served = ServeResend(req);
    if (!served.ok()) rejections.Error("cannot resend from the archive: " + served.message());
  }
}

Status StoreService::Impl::Finalize(StoreRun& r) {
  IMUQUAL_RETURN_IF_ERROR(archive->Begin());
  Staged staged;
  r.done = true;  // gap ranges go into the record
  r.result_stored = false;
  // Batches that arrived but were never written keep their cause when the
  // gaps are recomputed (also those recorded before a restart).
  std::vector<SeqRange> unwritten = r.unwritten;
  auto before = archive->LoadGaps(r.key);
  Status st = before.status();
  if (st.ok()) {
    for (const GapRecord& g : *before) {
      if (g.reason == "store_write") unwritten.push_back({g.first_seq, g.last_seq});
    }
    st = archive->RecomputeGaps(r.key, r.info.last_seq, NowUtime());
  }
  for (const SeqRange& u : unwritten) {
    if (st.ok()) st = archive->LabelSeqGaps(r.key, u.first, u.last, "store_write");
  }
  if (st.ok()) st = WritePending(r, &staged);
  if (st.ok()) st = archive->MarkFinalized(r.key, NowUtime());
  if (st.ok()) st = Commit();
  if (!st.ok()) {
    r.done = false;
    ++commit_failures;
    (void)archive->Rollback();
    RolledBack();
    return st;
  }
  ++commits;
  Committed(staged);
  finalized.insert(r.info.run_id);
  if (shipper) shipper->Notify();
  return Status::Ok();
}

void StoreService::Impl::Tick(double now) {
  for (auto it = runs.begin(); it != runs.end();) {
    const std::string& id = it->first;
    StoreRun& r = it->second;
    if (r.key >= 0 && !r.done && !r.acquire_gone &&
        acquire_heard.SecondsSince(id, now) > options.stale_after_s) {
      TakeOver(id, r, now);
    }
    // Announced by the store once acquire is gone, and while a judgement
    // round the store opened awaits its answer (analyze learns the round).
    if (r.key >= 0 && !r.done && (r.acquire_gone || r.info.revision > 0) &&
        now >= r.next_announce_s) {
      imuqual::run_t msg = MessageFromRunInfo(r.info);
      msg.host_utime = NowUtime();
      (void)bus->Publish(channels::kRun, msg);
      r.next_announce_s = now + options.heartbeat_s;
    }
    // A result or curves whose transaction failed (full disk, ...) are
    // written again, at most once a retry period.
    if (r.key >= 0 && !r.done && ((r.result && !r.result_stored) || !r.curves_pending.empty()) &&
        now >= r.next_retry_s && (!write_failing || now >= next_write_s)) {
      r.next_retry_s = now + kRetryPeriodS;
      Staged staged;
      Status st = archive->Begin();
      if (st.ok()) st = WritePending(r, &staged);
      if (st.ok()) st = Commit();
      if (st.ok()) {
        ++commits;
        Committed(staged);
      } else {
        ++commit_failures;
        (void)archive->Rollback();
        write_errors.Error("run " + id + ": cannot store the result: " + st.message());
      }
    }
    if (r.key >= 0 && !r.done && write_failing) {
      // Nothing can be archived now: holes are neither requested nor given
      // up (what the store could not write is not what never arrived).
      r.tracker.Postpone(now);
    } else if (r.key >= 0 && !r.done) {
      std::erase_if(r.requested, [&](const SeqRange& h) { return h.last < r.tracker.next_seq(); });
      for (const SeqRange& h : r.tracker.DueRequests(now)) {
        if (!r.WasRequested(h.first) || !r.WasRequested(h.last)) r.requested.push_back(h);
        imuqual::resend_t req;
        req.host_utime = NowUtime();
        req.requester = instance;
        req.run_id = id;
        req.first_seq = h.first;
        req.last_seq = h.last;
        if (bus->Publish(channels::kResend, req).ok()) ++resend_requests;
      }
      RecordGivenUp(r, r.tracker.TakeGivenUp(now));
      if (r.tracker.complete() && r.JudgedAndCurved()) {
        // Archived only if judged on what the archive holds; else judged again.
        if (const std::string cause = UncoveredBy(r); !cause.empty()) {
          if (r.info.revision < kMaxRevisions) {
            Supersede(r, cause, now);
            ++it;
            continue;
          }
          r.result->verdict = "ERROR";  // a station fault, not the unit's
          r.result->reasons.push_back("the judgement does not cover the archived data after " +
                                      std::to_string(kMaxRevisions) + " rounds: " + cause);
          r.result_stored = false;
        }
        Status st = Finalize(r);
        if (!st.ok()) {
          write_errors.Error("run " + id + ": " + st.message());
        } else {
          r.done_s = now;
          ++runs_done;
          LogInfo("run " + id + " archived: " + std::to_string(r.tracker.next_seq()) +
                  " batches, verdict " + (r.result->verdict.empty() ? "-" : r.result->verdict));
        }
      }
    }
    if (r.key >= 0 && r.ack.Due(r.tracker.next_seq(), r.done, now, false)) {
      acks.Add(id, r.tracker.next_seq(), r.done, r.ack.Urgent(r.tracker.next_seq(), r.done));
      r.ack.Sent(r.tracker.next_seq(), r.done, now);  // a lost one is said again within 0.5 s
    }
    if (r.done && now - r.done_s > kDoneAckForS) {
      acquire_heard.Forget(id);
      it = runs.erase(it);  // `finalized` keeps late messages away
    } else {
      ++it;
    }
  }
  // Together every kAckFlushPeriodS (urgent ones at once, AckPacer::Urgent);
  // a lost one is said again (AckPacer).
  (void)acks.FlushIfDue(*bus, now);
}

Counters StoreService::Impl::StatusCounters() const {
  int64_t active = 0;
  for (const auto& [id, r] : runs) active += !r.done;
  return {{"runs_active", active},
          {"runs_archived", runs_done},
          {"messages_received", received.load()},
          {"chunks_inserted", chunks_inserted},
          {"batches_damaged", damaged},
          {"duplicates", duplicates},
          {"absurd_seq", absurd},
          {"rejected", rejected},
          {"waiting_dropped", waiting_dropped},
          {"late_messages", late_messages},
          {"judgements_superseded", judgements_superseded},
          {"stale_results", stale_results},
          {"runs_refused", runs_refused},
          {"announcements_refused", announcements_refused},
          {"messages_of_refused_runs", messages_of_refused_runs},
          {"results_conflicting", results_conflicting},
          {"settled_messages", settled_messages},
          {"foreign_runs", static_cast<int64_t>(foreign_runs.size())},
          {"stopped_ms", std::llround(ListeningPausedSeconds() * 1e3)},
          {"foreign_messages", foreign_messages},
          {"commits", commits},
          {"commit_failures", commit_failures},
          {"apply_errors", apply_errors},
          {"resend_requests", resend_requests},
          {"batches_given_up", batches_given_up},
          {"write_failing_s",
           write_failing ? std::llround(ListeningSeconds() - write_failing_since_s) : 0},
          {"write_retries", write_retries},
          {"batches_unwritten", held_batches},
          {"unwritten_bytes", held_bytes},
          {"unwritten_dropped", unwritten_dropped},
          {"batches_served", batches_served},
          {"resends_throttled", resends_throttled},
          {"runs_taken_over", runs_taken_over},
          {"queue_depth", static_cast<int64_t>(queue.size())},
          {"queue_high_water", static_cast<int64_t>(queue.high_water())},
          {"queue_dropped", static_cast<int64_t>(queue.dropped())},
          {"decode_errors", static_cast<int64_t>(bus->decode_errors())},
          {"values_archived", values_archived},
          {"cpu_ms", std::llround(ProcessCpuSeconds() * 1e3)},
          {"latency_batches", sample_to_archive.count()},
          {"sample_to_archive_p50_us", sample_to_archive.QuantileUs(0.5)},
          {"sample_to_archive_p99_us", sample_to_archive.QuantileUs(0.99)},
          {"sample_to_archive_max_us", sample_to_archive.max_us()},
          {"sent_to_archive_p50_us", sent_to_archive.QuantileUs(0.5)},
          {"sent_to_archive_p99_us", sent_to_archive.QuantileUs(0.99)},
          {"sent_to_archive_max_us", sent_to_archive.max_us()}};
}

void StoreService::Impl::LogSummary() const {
  LogInfo("archived " + std::to_string(values_archived) + " values in " +
          std::to_string(chunks_inserted) + " chunks, " + std::to_string(commits) +
          " commits; cpu " + Fixed(ProcessCpuSeconds(), 2) + " s");
  auto summary = [](const std::string& what, const LatencyHistogram& h) {
    if (h.count() == 0) return;
    LogInfo(what + " latency p50 " + Ms(h.QuantileUs(0.5)) + " ms p99 " + Ms(h.QuantileUs(0.99)) +
            " ms max " + Ms(h.max_us()) + " ms over " + std::to_string(h.count()) +
            " batches archived on first arrival");
  };
  summary("sample-to-archive", sample_to_archive);
  summary("sent-to-archive", sent_to_archive);
}

Status StoreService::Run() {
  Impl& s = *impl_;
  BusSecurity security = s.options.security;
  security.role = BusRole::kStore;
  auto bus = LcmBus::Open(s.options.lcm_url, std::move(security));
  if (!bus.ok()) return bus.status();
  s.bus = std::move(*bus);
  auto enqueue = [&s](auto&& msg) {
    ++s.received;
    s.queue.TryPush(Item(std::forward<decltype(msg)>(msg)));
  };
  s.bus->Subscribe<imuqual::run_t>(channels::kRun, 1000,
                                   [enqueue, &s](const std::string&, imuqual::run_t&& m, int64_t) {
                                     if (m.announcer != "store") s.acquire_heard.Note(m.run_id);
                                     enqueue(std::move(m));
                                   });
  s.bus->Subscribe<imuqual::rate_batch_t>(
      channels::kRawAll, s.options.queue_capacity,
      [enqueue](const std::string&, imuqual::rate_batch_t&& m, int64_t) { enqueue(std::move(m)); });
  const double resend_rate = ResendBytesPerS(s.options.resend_budget_mb_s, BusTtl(s.options.lcm_url));
  s.resend_budget = std::make_unique<ResendBudget>(resend_rate, 2 * resend_rate);
  // A request's requester is who its seal says sent it, not what it writes.
  s.bus->SubscribeWithOrigin<imuqual::resend_t>(
      channels::kResend, 1000, nullptr,
      [enqueue, &s](const std::string&, imuqual::resend_t&& m, const MessageOrigin& from) {
        if (from.instance == s.bus->instance()) return;  // its own
        // The budget is the requesting role's (its seal names it): a new
        // instance of a role gets no budget of its own.
        m.requester = std::to_string(static_cast<int>(from.role));
        enqueue(std::move(m));
      });
  s.bus->Subscribe<imuqual::allan_curve_t>(
      channels::kCurveAll, 10000, [enqueue](const std::string&, imuqual::allan_curve_t&& m, int64_t) {
        if (m.is_final) enqueue(std::move(m));
      });
  s.bus->Subscribe<imuqual::unit_result_t>(
      channels::kResultAll, 10000,
      [enqueue](const std::string&, imuqual::unit_result_t&& m, int64_t) {
        if (m.is_final) enqueue(std::move(m));
      });

  std::atomic<bool> stop{false};
  std::thread writer([&s, &stop] {
    double next_status = 0;
    for (;;) {
      std::vector<Item> items = s.queue.PopAll(std::chrono::milliseconds(5),
                                               static_cast<size_t>(s.options.max_transaction));
      // Every timer (silence, give-up) on the listening clock: a store that
      // was frozen does not find acquire silent or its holes unrepairable.
      const double now = ListeningSeconds();
      // Held items are retried even when nothing new comes.
      if (!items.empty() || !s.held.empty()) s.Transaction(items, now);
      if (items.empty() && stop.load() && s.queue.size() == 0) {
        // A last attempt at what is held, then the acks of what it wrote.
        if (!s.held.empty()) s.Transaction(items, now, /*force=*/true);
        s.Tick(ListeningSeconds());
        (void)s.acks.Flush(*s.bus);
        break;
      }
      s.Tick(now);
      if (now >= next_status) {
        (void)PublishStatus(*s.bus, "store", s.health_message.empty(), s.health_message,
                            s.StatusCounters());
        next_status = now + 1.0;
      }
    }
    (void)PublishStatus(*s.bus, "store", s.health_message.empty(), "stopped", s.StatusCounters());
  });
  LogInfo("bus: " + s.bus->security_description() + "; plans accepted: " +
          (s.admission.restricts_plans() ? s.admission.AcceptedNames()
                                         : std::string("any (give --accept-plan to name them)")));
  LogInfo("archiving " + s.options.lcm_url + " into " + s.options.db_path);
  if (!s.options.sync_to.empty()) {
    ShipperOptions ship;
    ship.station_db = s.options.db_path;
    ship.plant_url = s.options.sync_to;
    ship.period_s = s.options.sync_period_s;
    ship.sync.claimed_by = "imuqual-store " + InstanceName() + " " + s.options.db_path;
    auto shipper = PlantShipper::Start(ship);
    if (!shipper.ok()) {
      LogError(shipper.status().message());
    } else {
      s.shipper = std::move(*shipper);
      LogInfo("shipping finalised runs to the plant archive " + s.options.sync_to);
    }
  }
  Status result;
  while (!ShutdownRequested() && !s.gave_up_writing) {
    Status st = s.bus->HandleFor(100);
    (void)ListeningSeconds();  // observed while the writer is busy too
    if (!st.ok()) {
      result = st;
      break;
    }
  }
  stop = true;
  s.queue.Close();
  writer.join();
  s.shipper.reset();  // a last shipment of what was finalised last
  s.LogSummary();
  if (result.ok() && (s.gave_up_writing || s.UnwrittenBatches() > 0 || s.unwritten_dropped > 0)) {
    std::string why = s.gave_up_writing ? "the archive could not be written for " +
                                              Fixed(s.options.write_give_up_s, 0) + " s"
                                        : "stopped while the archive could not be written";
    why += " (" + s.write_error + "): " + std::to_string(s.UnwrittenBatches()) +
           " batches received are not archived and were not acknowledged";
    if (s.unwritten_dropped > 0) {
      why += "; " + std::to_string(s.unwritten_dropped) + " more were left to acquire's retention";
    }
    result = Status::IoError(why);
  }
  return result;
}

}  // namespace imuqual::store
