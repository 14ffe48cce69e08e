#include "store/store_service.h"

#include <atomic>
#include <map>
#include <optional>
#include <thread>
#include <variant>

#include "common/ack.h"
#include "common/bounded_queue.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "common/process_status.h"
#include "common/seq_tracker.h"
#include "common/shutdown.h"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "store/records.h"

namespace imuqual::store {
namespace {

using Item = std::variant<imuqual::run_t, imuqual::rate_batch_t, imuqual::allan_curve_t,
                          imuqual::unit_result_t, imuqual::resend_t>;

constexpr size_t kMaxWaitingPerRun = 4096;  // batches held until the run is announced
constexpr double kDoneAckForS = 60.0;
constexpr int64_t kMaxServedPerRequest = 512;  // archived batches resent per request

struct StoreRun {
  int64_t key = -1;
  RunInfo info;
  SeqTracker tracker;
  std::vector<imuqual::rate_batch_t> waiting;
  std::vector<CurveRecord> curves_waiting;
  std::optional<ResultRecord> result;  // the final result, once received
  bool result_stored = false;
  bool done = false;
  double done_s = 0;
  AckPacer ack;
  // acquire's side: when it last announced the run and what it still retains.
  double acquire_seen_s = 0;
  int64_t acquire_retained_first = 0;
  bool acquire_gone = false;
  double next_announce_s = 0;
  explicit StoreRun(const SeqTracker::Options& o) : tracker(0, o) {}
};

// What a transaction changed, applied to the in-memory state after COMMIT.
struct Staged {
  std::vector<std::pair<std::string, int64_t>> chunks;  // (run, seq) now durable
  std::vector<std::string> results;                       // runs whose result is durable
};

}  // namespace

Status StoreOptions::Validate() const {
  if (lcm_url.empty()) return Status::InvalidArgument("lcm_url: required");
  if (db_path.empty()) return Status::InvalidArgument("db_path: required");
  if (queue_capacity < 16) return Status::InvalidArgument("queue_capacity: must be >= 16");
  if (max_transaction < 1) return Status::InvalidArgument("max_transaction: must be >= 1");
  if (!(hole_give_up_s > 0)) return Status::InvalidArgument("hole_give_up_s: must be > 0");
  if (!(stale_after_s > 0)) return Status::InvalidArgument("stale_after_s: must be > 0");
  if (!(heartbeat_s > 0)) return Status::InvalidArgument("heartbeat_s: must be > 0");
  return Status::Ok();
}

struct StoreService::Impl {
  StoreOptions options;
  std::unique_ptr<Archive> archive;
  std::unique_ptr<LcmBus> bus;
  BoundedQueue<Item> queue;
  std::map<std::string, StoreRun> runs;
  SeqTracker::Options tracker_options;
  std::string instance = InstanceName();
  std::string health_message;
  ThrottledLog write_errors;
  std::atomic<int64_t> received{0};
  int64_t chunks_inserted = 0, duplicates = 0, absurd = 0, rejected = 0, waiting_dropped = 0,
          commits = 0, commit_failures = 0, apply_errors = 0, resend_requests = 0,
          batches_given_up = 0, runs_done = 0, batches_served = 0, runs_taken_over = 0;

  explicit Impl(const StoreOptions& o) : options(o), queue(static_cast<size_t>(o.queue_capacity)) {
    tracker_options.give_up_after_s = o.hole_give_up_s;
  }

  StoreRun& Run(const std::string& run_id) { return runs.try_emplace(run_id, tracker_options).first->second; }
  Status Apply(Item& item, Staged* staged);
  Status ApplyRun(const imuqual::run_t& msg, Staged* staged);
  Status ApplyBatch(StoreRun& r, const imuqual::rate_batch_t& b, Staged* staged);
  Status StoreResult(StoreRun& r, Staged* staged);
  Status Resume(const std::string& run_id, double now);
  Status ServeResend(const imuqual::resend_t& req);
  void TakeOver(const std::string& run_id, StoreRun& r, double now);
  void Transaction(std::vector<Item>& items);
  void Tick(double now);
  Status Finalize(StoreRun& r);
  Counters StatusCounters() const;
};

StoreService::StoreService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
StoreService::~StoreService() = default;

Result<std::unique_ptr<StoreService>> StoreService::Create(const StoreOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  auto impl = std::make_unique<Impl>(options);
  auto archive = Archive::Open(options.db_path, Archive::Mode::kWrite);
  if (!archive.ok()) return archive.status();
  impl->archive = std::move(*archive);
  auto unfinished = impl->archive->UnfinishedRunIds();
  if (!unfinished.ok()) return unfinished.status();
  for (const std::string& id : *unfinished) {
    IMUQUAL_RETURN_IF_ERROR(impl->Resume(id, MonotonicSeconds()));
  }
  return std::unique_ptr<StoreService>(new StoreService(std::move(impl)));
}

// A run the archive holds but has not finalized (this store stopped before
// its end): its tracker starts from what is archived; acquire has
// stale_after_s to show up before the store takes the run over.
Status StoreService::Impl::Resume(const std::string& run_id, double now) {
  auto info = archive->LoadRun(run_id);
  if (!info.ok()) return info.status();
  auto key = archive->FindRunKey(run_id);
  if (!key.ok()) return key.status();
  StoreRun& r = Run(run_id);
  r.key = **key;
  r.info = *info;
  auto next = archive->NextMissingSeq(r.key);
  if (!next.ok()) return next.status();
  auto held = archive->ArchivedSeqsFrom(r.key, *next);
  if (!held.ok()) return held.status();
  r.tracker = SeqTracker(*next, tracker_options);
  for (int64_t seq : *held) r.tracker.Offer(seq);
  r.tracker.SetAnnouncedLast(r.info.last_seq);
  if (r.info.state != "running") r.tracker.SetFinal();
  auto result = archive->LoadResult(r.key);
  if (!result.ok()) return result.status();
  if (result->has_value()) {
    r.result = std::move(**result);
    r.result_stored = true;
  }
  r.acquire_seen_s = now;
  LogInfo("run " + run_id + ": resuming an unfinished run, " + std::to_string(*next) +
          " batches archived in order");
  return Status::Ok();
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
    Status st = archive->Begin();
    if (st.ok()) st = archive->UpsertRun(r.info).status();
    if (st.ok()) st = archive->Commit();
    if (!st.ok()) {
      (void)archive->Rollback();
      LogError("run " + run_id + ": cannot mark it incomplete: " + st.message());
    }
    LogWarning("run " + run_id + ": acquire silent for " +
               std::to_string(static_cast<int>(options.stale_after_s)) +
               " s; the run is incomplete after " + std::to_string(r.info.last_seq + 1) + " batches");
  }
  r.tracker.SetFinal();
  for (const SeqRange& h : r.tracker.GiveUpAll()) {
    batches_given_up += h.last - h.first + 1;
    LogWarning("run " + run_id + ": batches " + std::to_string(h.first) + ".." +
               std::to_string(h.last) + " can no longer be resent; recorded as a gap");
  }
  r.next_announce_s = now;
}

// Resends from the archive what acquire cannot: batches it no longer
// retains, or all of them once it is gone.
Status StoreService::Impl::ServeResend(const imuqual::resend_t& req) {
  if (req.requester == instance) return Status::Ok();
  auto it = runs.find(req.run_id);
  if (it == runs.end() || it->second.key < 0) return Status::Ok();
  StoreRun& r = it->second;
  const int64_t first = std::max<int64_t>(req.first_seq, 0);
  int64_t last = std::min(req.last_seq, first + kMaxServedPerRequest - 1);
  if (!r.acquire_gone) last = std::min(last, r.acquire_retained_first - 1);
  if (last < first) return Status::Ok();
  return archive->ForEachChunk(
      r.key,
      [&](const ChunkRecord& c) -> Status {
        auto batch = BatchFromChunk(r.info, c);
        if (!batch.ok()) return batch.status();
        ++batches_served;
        return bus->Publish(channels::Raw(r.info.serial), *batch);
      },
      first, last);
}

Status StoreService::Impl::ApplyRun(const imuqual::run_t& msg, Staged* staged) {
  if (msg.announcer == "store") return Status::Ok();  // a store's own re-announcement
  StoreRun& r = Run(msg.run_id);
  const bool first = r.key < 0;
  r.acquire_seen_s = MonotonicSeconds();
  r.acquire_retained_first = msg.retained_first_seq;
  r.acquire_gone = false;
  r.info = RunInfoFromMessage(msg);
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
    std::vector<imuqual::rate_batch_t> waiting = std::move(r.waiting);
    r.waiting.clear();
    for (const imuqual::rate_batch_t& b : waiting) IMUQUAL_RETURN_IF_ERROR(ApplyBatch(r, b, staged));
    for (const CurveRecord& c : r.curves_waiting) IMUQUAL_RETURN_IF_ERROR(archive->PutCurve(r.key, c));
    r.curves_waiting.clear();
    if (r.result && !r.result_stored) IMUQUAL_RETURN_IF_ERROR(StoreResult(r, staged));
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
  if (b.seq < 0 || b.seq > r.tracker.next_seq() + (int64_t{1} << 20)) {
    ++absurd;
    return Status::Ok();
  }
  if (b.num_axes != static_cast<int>(r.info.axes.size()) || b.num_samples < 1 ||
      b.nominal_rate_hz != r.info.nominal_rate_hz) {
    ++rejected;
    LogWarning("run " + b.run_id + " seq " + std::to_string(b.seq) +
               ": batch does not match the run's axes or rate; rejected");
    return Status::Ok();
  }
  bool inserted = false;
  IMUQUAL_RETURN_IF_ERROR(archive->InsertChunk(r.key, ChunkFromBatch(b), &inserted));
  if (inserted) {
    staged->chunks.emplace_back(b.run_id, b.seq);
  } else {
    ++duplicates;
  }
  return Status::Ok();
}

Status StoreService::Impl::StoreResult(StoreRun& r, Staged* staged) {
  int64_t gap_ranges = 0;
  if (r.done) {
    auto gaps = archive->LoadGaps(r.key);
    if (!gaps.ok()) return gaps.status();
    gap_ranges = static_cast<int64_t>(gaps->size());
  }
  r.result->record = BuildRunRecord(r.info, *r.result, gap_ranges).SerializeAsString();
  IMUQUAL_RETURN_IF_ERROR(archive->PutResult(r.key, *r.result));
  staged->results.push_back(r.info.run_id);
  return Status::Ok();
}

Status StoreService::Impl::Apply(Item& item, Staged* staged) {
  if (auto* run = std::get_if<imuqual::run_t>(&item)) return ApplyRun(*run, staged);
  if (auto* b = std::get_if<imuqual::rate_batch_t>(&item)) return ApplyBatch(Run(b->run_id), *b, staged);
  if (auto* c = std::get_if<imuqual::allan_curve_t>(&item)) {
    StoreRun& r = Run(c->run_id);
    CurveRecord rec = CurveFromMessage(*c);
    if (r.key < 0) {
      r.curves_waiting.push_back(std::move(rec));
      return Status::Ok();
    }
    return archive->PutCurve(r.key, rec);
  }
  auto& res = std::get<imuqual::unit_result_t>(item);
  StoreRun& r = Run(res.run_id);
  r.result = ResultFromMessage(res);
  r.result_stored = false;
  return r.key < 0 ? Status::Ok() : StoreResult(r, staged);
}

// One transaction for everything popped; the in-memory state (trackers,
// acks) moves only after COMMIT, so an acknowledged batch is durable.
void StoreService::Impl::Transaction(std::vector<Item>& items) {
  Staged staged;
  std::vector<imuqual::resend_t> resends;  // served after the commit, outside the transaction
  Status st = archive->Begin();
  for (Item& item : items) {
    if (!st.ok()) break;
    if (auto* req = std::get_if<imuqual::resend_t>(&item)) {
      resends.push_back(std::move(*req));
      continue;
    }
    Status ap = Apply(item, &staged);
    if (!ap.ok()) {
      ++apply_errors;
      write_errors.Error(ap.message());
      // Disk or file trouble fails the whole transaction; anything else
      // loses only the message at fault.
      if (ap.code() == Status::Code::kIoError || ap.code() == Status::Code::kCorruption) st = ap;
    }
  }
  if (st.ok()) st = archive->Commit();
  if (!st.ok()) {
    (void)archive->Rollback();
    ++commit_failures;
    health_message = st.message();
    write_errors.Error("archive write failed, nothing of this transaction is acknowledged: " +
                       st.message());
    // Keys of runs created in the failed transaction are gone again.
    for (auto& [id, r] : runs) {
      if (r.key >= 0) {
        auto key = archive->FindRunKey(id);
        if (!key.ok() || !key->has_value()) r.key = -1;
      }
    }
    return;
  }
  ++commits;
  health_message.clear();
  for (const auto& [run_id, seq] : staged.chunks) {
    if (Run(run_id).tracker.Offer(seq) == SeqTracker::Arrival::kNew) ++chunks_inserted;
  }
  for (const std::string& run_id : staged.results) Run(run_id).result_stored = true;
  for (const imuqual::resend_t& req : resends) {
    Status served = ServeResend(req);
    if (!served.ok()) LogWarning("cannot resend from the archive: " + served.message());
  }
}

Status StoreService::Impl::Finalize(StoreRun& r) {
  IMUQUAL_RETURN_IF_ERROR(archive->Begin());
  Staged staged;
  Status st = archive->RecomputeGaps(r.key, r.info.last_seq, NowUtime());
  if (st.ok()) {
    r.done = true;  // gap ranges go into the record
    st = StoreResult(r, &staged);
  }
  if (st.ok()) st = archive->MarkFinalized(r.key, NowUtime());
  if (st.ok()) st = archive->Commit();
  if (!st.ok()) {
    r.done = false;
    (void)archive->Rollback();
    return st;
  }
  return Status::Ok();
}

void StoreService::Impl::Tick(double now) {
  for (auto it = runs.begin(); it != runs.end();) {
    const std::string& id = it->first;
    StoreRun& r = it->second;
    if (r.key >= 0 && !r.done && !r.acquire_gone &&
        now - r.acquire_seen_s > options.stale_after_s) {
      TakeOver(id, r, now);
    }
    if (r.key >= 0 && !r.done && r.acquire_gone && now >= r.next_announce_s) {
      imuqual::run_t msg = MessageFromRunInfo(r.info);
      msg.host_utime = NowUtime();
      (void)bus->Publish(channels::kRun, msg);
      r.next_announce_s = now + options.heartbeat_s;
    }
    if (r.key >= 0 && !r.done) {
      for (const SeqRange& h : r.tracker.DueRequests(now)) {
        imuqual::resend_t req;
        req.host_utime = NowUtime();
        req.requester = instance;
        req.run_id = id;
        req.first_seq = h.first;
        req.last_seq = h.last;
        if (bus->Publish(channels::kResend, req).ok()) ++resend_requests;
      }
      for (const SeqRange& h : r.tracker.TakeGivenUp(now)) {
        batches_given_up += h.last - h.first + 1;
        LogWarning("run " + id + ": batches " + std::to_string(h.first) + ".." +
                   std::to_string(h.last) + " never arrived; recorded as a gap");
      }
      if (r.tracker.complete() && r.result_stored) {
        Status st = Finalize(r);
        if (!st.ok()) {
          LogError("run " + id + ": " + st.message());
        } else {
          r.done_s = now;
          ++runs_done;
          LogInfo("run " + id + " archived: " + std::to_string(r.tracker.next_seq()) +
                  " batches, verdict " + (r.result->verdict.empty() ? "-" : r.result->verdict));
        }
      }
    }
    if (r.key >= 0 && r.ack.Due(r.tracker.next_seq(), r.done, now, false)) {
      if (PublishAck(*bus, "store", instance, id, r.tracker.next_seq(), r.done).ok()) {
        r.ack.Sent(r.tracker.next_seq(), r.done, now);
      }
    }
    if (r.done && now - r.done_s > kDoneAckForS) {
      it = runs.erase(it);
    } else {
      ++it;
    }
  }
}

Counters StoreService::Impl::StatusCounters() const {
  int64_t active = 0;
  for (const auto& [id, r] : runs) active += !r.done;
  return {{"runs_active", active},
          {"runs_archived", runs_done},
          {"messages_received", received.load()},
          {"chunks_inserted", chunks_inserted},
          {"duplicates", duplicates},
          {"absurd_seq", absurd},
          {"rejected", rejected},
          {"waiting_dropped", waiting_dropped},
          {"commits", commits},
          {"commit_failures", commit_failures},
          {"apply_errors", apply_errors},
          {"resend_requests", resend_requests},
          {"batches_given_up", batches_given_up},
          {"batches_served", batches_served},
          {"runs_taken_over", runs_taken_over},
          {"queue_depth", static_cast<int64_t>(queue.size())},
          {"queue_high_water", static_cast<int64_t>(queue.high_water())},
          {"queue_dropped", static_cast<int64_t>(queue.dropped())},
          {"decode_errors", static_cast<int64_t>(bus->decode_errors())}};
}

Status StoreService::Run() {
  Impl& s = *impl_;
  auto bus = LcmBus::Open(s.options.lcm_url);
  if (!bus.ok()) return bus.status();
  s.bus = std::move(*bus);
  auto enqueue = [&s](auto&& msg) {
    ++s.received;
    s.queue.TryPush(Item(std::forward<decltype(msg)>(msg)));
  };
  s.bus->Subscribe<imuqual::run_t>(channels::kRun, 1000,
                                   [enqueue](const std::string&, imuqual::run_t&& m, int64_t) {
                                     enqueue(std::move(m));
                                   });
  s.bus->Subscribe<imuqual::rate_batch_t>(
      channels::kRawAll, s.options.queue_capacity,
      [enqueue](const std::string&, imuqual::rate_batch_t&& m, int64_t) { enqueue(std::move(m)); });
  s.bus->Subscribe<imuqual::resend_t>(channels::kResend, 1000,
                                      [enqueue](const std::string&, imuqual::resend_t&& m, int64_t) {
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
      std::vector<Item> items =
          s.queue.PopAll(std::chrono::milliseconds(5), static_cast<size_t>(s.options.max_transaction));
      if (!items.empty()) s.Transaction(items);
      const double now = MonotonicSeconds();
      if (items.empty() && stop.load() && s.queue.size() == 0) break;
      s.Tick(now);
      if (now >= next_status) {
        (void)PublishStatus(*s.bus, "store", s.health_message.empty(), s.health_message,
                            s.StatusCounters());
        next_status = now + 1.0;
      }
    }
    (void)PublishStatus(*s.bus, "store", s.health_message.empty(), "stopped", s.StatusCounters());
  });
  LogInfo("archiving " + s.options.lcm_url + " into " + s.options.db_path);
  Status result;
  while (!ShutdownRequested()) {
    Status st = s.bus->HandleFor(100);
    if (!st.ok()) {
      result = st;
      break;
    }
  }
  stop = true;
  s.queue.Close();
  writer.join();
  return result;
}

}  // namespace imuqual::store
