#include "acquire/acquire_service.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <limits>
#include <map>
#include <set>

#include "acquire/random.h"
#include "acquire/retention.h"
#include "acquire/source_spec.h"
#include "analyze/judge/plan.h"
#include "common/batch_integrity.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/lcm_bus.h"
#include "common/log.h"
#include "common/process_status.h"
#include "common/resend_budget.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "common/version.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "imuqual/run_t.hpp"

namespace imuqual::acquire {
namespace {

// LCM 1.3 sends a message as one datagram when channel + 1 + payload is
// under 1400 bytes; bigger ones go as 1400-byte fragments and are lost whole
// if any fragment is lost. Across a LAN a batch is one datagram; on one host
// (ttl=0, where datagrams are lost only to a full receive buffer, which flow
// control prevents) a batch of several fragments costs each process one
// message instead of six: half the CPU per sample. A time-warped source
// (pace 0: a simulator, a file or archive replay) waits for no clock, so the
// time a batch takes to fill does not matter: twice that again (12
// fragments) spares the station about a sixth of its CPU per sample (one
// decode, queue entry, archive row and analysis step per batch); bigger
// gains nothing more.
constexpr int kDatagramPayloadBytes = 1399;
constexpr int kLocalBatchBytes = 8191;
constexpr int kLocalWarpedBatchBytes = 16383;
constexpr int kMaxBatchSamples = 4096;

constexpr int kMaxResendRange = 4096;
constexpr int kBatchesPerRunPerRound = 8;
constexpr int kFinalAnnouncements = 3;  // an end is said more than once (datagrams get lost)
constexpr double kResendQuietS = 2.0;   // without consumers to wait for: linger until requests stop
constexpr double kRetentionWarningS = 10.0;  // an unacknowledged drop stays in status this long
constexpr double kResendDedupS = 0.05;  // a batch resent this recently already answers a request

std::string CompactUtc(int64_t utime) {
  std::string iso = FormatUtimeIso(utime);  // 2026-11-21T11:05:00Z
  std::string out;
  for (char c : iso) {
    if (c != '-' && c != ':') out += c;
  }
  return out;  // 20261121T110500Z
}

int8_t KindCode(pb::AxisKind kind) {
  return kind == pb::ACCEL ? imuqual::rate_batch_t::KIND_ACCEL : imuqual::rate_batch_t::KIND_GYRO;
}

struct RunState {
  UnitSpec unit;
  std::string run_id;
  std::string channel;
  int batch_samples = 0;
  int64_t next_seq = 0;
  int64_t samples_published = 0;
  int64_t first_counter = -1;  // device counter of the first sample published
  int64_t end_counter = -1;    // device counter after the last sample published
  double pace_origin_s = 0;
  bool source_done = false;
  int8_t state = imuqual::run_t::STATE_RUNNING;
  std::map<std::string, int64_t> acked;  // role -> next_seq acknowledged
  double last_ack_progress_s = 0;
  Retention retained;
  imuqual::run_t announcement;
  // The run's judgement round as the store announces it (run_t.revision of
  // its announcements): a decision of an older round is stale.
  int revision_heard = 0;
};

// "decided PASS at 740 s (early decision)": run_t.end_reason of a run ended
// by its unit's early decision.
std::string DecidedEndReason(const imuqual::decision_t& d) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "decided %s at %g s (early decision)",
                d.state == imuqual::decision_t::STATE_FAIL ? "FAIL" : "PASS", d.decided_at_s);
  return buf;
}

}  // namespace

Status AcquireOptions::Validate() const {
  if (lcm_url.empty()) return Status::InvalidArgument("lcm_url: required");
  IMUQUAL_RETURN_IF_ERROR(LcmBus::CheckSecurity(lcm_url, security));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("lot", lot));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("station", station));
  if (!run_prefix.empty()) IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("run_prefix", run_prefix));
  for (const std::string& role : await) {
    if (role != "store" && role != "analyze") {
      return Status::InvalidArgument("await: unknown consumer role '" + role +
                                     "' (store, analyze)");
    }
  }
  if (window_batches < 1 || window_batches > 100000) {
    return Status::InvalidArgument("window_batches: must be 1..100000");
  }
  if (batch_samples < 0 || batch_samples > 32767) {
    return Status::InvalidArgument("batch_samples: must be 0 (auto) or 1..32767");
  }
  if (batch_bytes != 0 && (batch_bytes < 256 || batch_bytes > 65536)) {
    return Status::InvalidArgument("batch_bytes: must be 0 (auto) or 256..65536");
  }
  if (!(heartbeat_s > 0)) return Status::InvalidArgument("heartbeat_s: must be > 0");
  if (!(heartbeat_runs_per_s > 0)) {
    return Status::InvalidArgument("heartbeat_runs_per_s: must be > 0");
  }
  if (!(retention_s >= 0)) return Status::InvalidArgument("retention_s: must be >= 0");
  if (retention_mb < 1) return Status::InvalidArgument("retention_mb: must be >= 1");
  if (!(pace >= 0) || !std::isfinite(pace)) return Status::InvalidArgument("pace: must be >= 0");
  if (!(consumer_timeout_s > 0)) return Status::InvalidArgument("consumer_timeout_s: must be > 0");
  if (!(linger_s >= 0)) return Status::InvalidArgument("linger_s: must be >= 0");
  if (!(resend_budget_mb_s >= 0) || !std::isfinite(resend_budget_mb_s)) {
    return Status::InvalidArgument("resend_budget_mb_s: must be >= 0");
  }
  if (!(inject_drop >= 0 && inject_drop < 1)) {
    return Status::InvalidArgument("inject_drop: must be in [0, 1)");
  }
  if (!(inject_bitflip >= 0 && inject_bitflip < 1)) {
    return Status::InvalidArgument("inject_bitflip: must be in [0, 1)");
  }
  return Status::Ok();
}

struct AcquireService::Impl {
  AcquireOptions options;
  std::vector<RunState> runs;
  std::unique_ptr<LcmBus> bus;
  sim::Random drop_rng{1};
  sim::Random bitflip_rng{2};
  // Resend requests with the sender role of their seal, for the loop.
  std::deque<std::pair<imuqual::resend_t, uint64_t>> resend_queue;
  std::unique_ptr<ResendBudget> resend_budget;  // per requester
  double resend_bytes_per_s = 0;
  std::deque<imuqual::decision_t> decision_queue;  // PASS/FAIL decisions for the loop
  // Counters.
  int64_t published = 0, resent = 0, resend_misses = 0, injected_drops = 0, injected_bitflips = 0,
          acks = 0, resend_requests = 0, publish_errors = 0, evicted_unacknowledged = 0,
          runs_decided = 0, decisions_ignored = 0, decisions_dropped = 0, acks_refused = 0,
          resends_throttled = 0;
  ThrottledLog refusal_log;
  double last_resend_request_s = 0;
  ThrottledLog publish_log;
  ThrottledLog retention_log;
  ThrottledLog decision_log;
  std::string retention_warning;  // the last batches dropped unacknowledged
  double retention_warning_s = -1e300;
  std::vector<std::string> failures;  // runs whose source failed, with why

  // Ok, or the failure of the runs whose source failed.
  Status FinalStatus() const {
    if (failures.empty()) return Status::Ok();
    return Status::Unavailable(std::to_string(failures.size()) + " of " +
                               std::to_string(runs.size()) +
                               " runs aborted; first: " + failures[0]);
  }

  void Publish(RunState& run, bool fresh_batch_dropped, const std::vector<uint8_t>& bytes);
  // Sends encoded batch bytes (--inject-bitflip damages a copy first).
  Status SendBatch(const RunState& run, const std::vector<uint8_t>& bytes);
  // Publishes the run's announcement `times` times; failures are counted.
  void Announce(RunState& run, int times = 1);
  // An acknowledgement message, from a sender of role `sender`, and one
  // run's word in it.
  void OnAck(const imuqual::ack_t& ack, BusRole sender);
  void OnRunAck(const std::string& process, const std::string& run_id, int64_t next_seq,
                bool run_done);
  // A store's announcement: the judgement round of one of our runs.
  void OnStoreRun(const imuqual::run_t& run);
  Status ServeResends();
  // Ends every running run whose unit a queued decision decided.
  void EndDecidedRuns();
  void Prune(double now_s);
  bool GateOpen(const RunState& run) const;
  bool AllAcknowledged() const;
  Status PublishOneBatch(RunState& run, double now_s, bool* published_one);
  Status Abort(const std::string& why);
  Counters StatusCounters() const;
  // Running runs whose serial device is gone (SampleSource::Reconnecting),
  // and that set as last published: a change is published at once.
  std::vector<std::string> ReconnectingRuns() const;
  std::vector<std::string> reconnecting_published;
  void LogSummary(const std::string& how) const {
    LogInfo(how + ": " + std::to_string(published) + " batches published, " +
            std::to_string(resent) + " resent, " + std::to_string(injected_drops) +
            " dropped on purpose (--inject-drop), " + std::to_string(injected_bitflips) +
            " damaged on purpose (--inject-bitflip), " + std::to_string(resend_misses) +
            " resend misses; cpu " + std::to_string(ProcessCpuSeconds()) + " s");
  }
};

AcquireService::AcquireService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AcquireService::~AcquireService() = default;

std::vector<std::string> AcquireService::run_ids() const {
  std::vector<std::string> ids;
  for (const RunState& r : impl_->runs) ids.push_back(r.run_id);
  return ids;
}

Result<std::unique_ptr<AcquireService>> AcquireService::Create(AcquireOptions options,
                                                               std::vector<UnitSpec> units) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (units.empty()) return Status::InvalidArgument("no units to acquire");
  auto impl = std::make_unique<Impl>();
  const int64_t now = NowUtime();
  if (options.run_prefix.empty()) options.run_prefix = CompactUtc(now);
  impl->drop_rng = sim::Random(options.inject_seed);
  impl->bitflip_rng = sim::Random(options.inject_seed ^ 0x9E3779B97F4A7C15ULL);

  std::set<std::string> serials;
  for (UnitSpec& unit : units) {
    IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("unit serial", unit.serial));
    if (!serials.insert(unit.serial).second) {
      return Status::InvalidArgument("unit serial '" + unit.serial + "' given twice");
    }
    if (!unit.source) return Status::InvalidArgument("unit " + unit.serial + ": no source");
    const SourceInfo& info = unit.source->info();
    if (info.axes.empty() || info.axes.size() > 64) {
      return Status::InvalidArgument("unit " + unit.serial + ": source has " +
                                     std::to_string(info.axes.size()) + " axes (1..64)");
    }
    IMUQUAL_RETURN_IF_ERROR(CheckSourceAxes(unit.serial, info, options.plan));
    if (options.plan.nominal_rate_hz() > 0 &&
        std::abs(info.nominal_rate_hz / options.plan.nominal_rate_hz() - 1) > 0.01) {
      LogWarning("unit " + unit.serial + ": source rate " + std::to_string(info.nominal_rate_hz) +
                 " Hz differs from the plan's " + std::to_string(options.plan.nominal_rate_hz()) +
                 " Hz");
    }

    RunState run;
    run.run_id = options.run_prefix + "-" + unit.serial;
    run.channel = channels::Raw(unit.serial);
    imuqual::run_t& a = run.announcement;
    a.run_id = run.run_id;
    a.unit_serial = unit.serial;
    a.lot = options.lot;
    a.station = options.station;
    a.slot = unit.slot;
    a.operator_name = options.operator_name;
    a.source = info.description;
    a.software_version = kSoftwareVersion;
    a.start_utime = now;
    a.nominal_rate_hz = info.nominal_rate_hz;
    a.planned_s = info.planned_s;
    a.num_axes = static_cast<int8_t>(info.axes.size());
    for (const pb::Axis& axis : info.axes) {
      a.axis_names.push_back(axis.name());
      a.axis_kinds.push_back(KindCode(axis.kind()));
    }
    // The run's plan: the one given, completed from the source where it is
    // silent (a run without a plan is measured, not judged).
    const pb::TestPlan plan = judge::CompletedPlan(options.plan, info.nominal_rate_hz, info.axes);
    const std::string plan_bytes = plan.SerializeAsString();
    a.plan_size = static_cast<int32_t>(plan_bytes.size());
    a.plan.assign(plan_bytes.begin(), plan_bytes.end());
    a.plan_sha256 = Sha256Hex(plan_bytes);
    a.truth_size = static_cast<int32_t>(info.truth.size());
    a.truth.assign(info.truth.begin(), info.truth.end());
    a.state = imuqual::run_t::STATE_RUNNING;
    a.last_seq = -1;
    a.samples_published = 0;

    // Batch size: the most samples that fit the message budget.
    if (options.batch_samples > 0) {
      run.batch_samples = options.batch_samples;
    } else {
      imuqual::rate_batch_t probe;
      probe.run_id = run.run_id;
      probe.unit_serial = unit.serial;
      probe.num_axes = a.num_axes;
      probe.axis_names = a.axis_names;
      probe.axis_kinds = a.axis_kinds;
      probe.num_samples = 0;
      probe.samples.assign(info.axes.size(), {});
      probe.num_flagged = 0;
      probe.has_temperature = 1;
      const int header = probe.getEncodedSize();
      const bool warped = options.pace == 0 && !info.paced_by_device;
      const int message_bytes = options.batch_bytes > 0        ? options.batch_bytes
                                : BusTtl(options.lcm_url) != 0 ? kDatagramPayloadBytes
                                : warped                       ? kLocalWarpedBatchBytes
                                                               : kLocalBatchBytes;
      // The seal (common/bus_seal.h) rides in the same datagram.
      const int budget = message_bytes - static_cast<int>(run.channel.size()) - 1 - header -
                         static_cast<int>(kMaxUnsignedTrailerBytes);
      run.batch_samples =
          std::clamp(budget / (4 * static_cast<int>(info.axes.size())), 1, kMaxBatchSamples);
    }
    run.unit = std::move(unit);
    impl->runs.push_back(std::move(run));
  }
  impl->options = std::move(options);
  return std::unique_ptr<AcquireService>(new AcquireService(std::move(impl)));
}

void AcquireService::Impl::Announce(RunState& run, int times) {
  run.announcement.host_utime = NowUtime();
  run.announcement.state = run.state;
  run.announcement.last_seq = run.next_seq - 1;
  run.announcement.samples_published = run.samples_published;
  run.announcement.first_sample = run.first_counter;
  run.announcement.end_sample = run.end_counter;
  run.announcement.announcer = "acquire";
  run.announcement.revision = 0;  // the store keeps the judgement rounds
  run.announcement.retained_first_seq =
      run.retained.empty() ? run.next_seq : run.retained.first_seq();
  for (int i = 0; i < times; ++i) {
    Status st = bus->Publish(channels::kRun, run.announcement);
    if (!st.ok()) {
      ++publish_errors;
      publish_log.Error(st.message());
    }
  }
}

// The store's acknowledgements free retained batches, whether or not it is
// awaited; an awaited consumer's also open the flow-control window. An
// acknowledgement must come from the role it names, and cannot cover
// batches never published (except the store's "run done", which says the
// whole run is archived).
void AcquireService::Impl::OnAck(const imuqual::ack_t& ack, BusRole sender) {
  const bool awaited =
      std::find(options.await.begin(), options.await.end(), ack.process) != options.await.end();
  if (ack.process != "store" && !awaited) return;
  if (ack.process != RoleName(sender)) {
    ++acks_refused;
    refusal_log.Warning("refused an acknowledgement naming " + ack.process.substr(0, 32) +
                        " sent by " + RoleName(sender));
    return;
  }
  for (int i = 0; i < ack.num_runs; ++i) OnRunAck(ack.process, ack.run_ids[i], ack.next_seq[i], ack.run_done[i]);
}

void AcquireService::Impl::OnRunAck(const std::string& process, const std::string& run_id,
                                    int64_t acked_seq, bool run_done) {
  for (RunState& run : runs) {
    if (run.run_id != run_id) continue;
    int64_t next_seq = acked_seq;
    if (next_seq > run.next_seq) {
      if (!(process == "store" && run_done)) {
        ++acks_refused;
        refusal_log.Warning("run " + run.run_id + ": refused an acknowledgement from " + process +
                            " of batches up to " + std::to_string(next_seq) + ", beyond the " +
                            std::to_string(run.next_seq) + " published");
        return;
      }
      next_seq = run.next_seq;  // the store archived the whole run
    }
    ++acks;
    auto it = run.acked.find(process);
    if (it == run.acked.end() || next_seq > it->second) {
      run.acked[process] = next_seq;
      run.last_ack_progress_s = MonotonicSeconds();
    }
    return;
  }
}

void AcquireService::Impl::OnStoreRun(const imuqual::run_t& r) {
  if (r.announcer != "store") return;
  for (RunState& run : runs) {
    if (run.run_id == r.run_id) run.revision_heard = std::max<int>(run.revision_heard, r.revision);
  }
}

// A decided unit needs no more samples: its source is stopped and its run
// ends complete, with every batch published so far kept for resends as
// usual (the analysis used those up to decision_t.end_sample; the rest is
// archived, not analysed). Only a decision of the run's current judgement
// round counts, and only for a plan with early decisions (the analysis
// sends none otherwise: one that says so is not about this run's plan).
void AcquireService::Impl::EndDecidedRuns() {
  while (!decision_queue.empty()) {
    const imuqual::decision_t d = std::move(decision_queue.front());
    decision_queue.pop_front();
    for (RunState& run : runs) {
      if (run.run_id != d.run_id || run.state != imuqual::run_t::STATE_RUNNING || run.source_done) {
        continue;
      }
      if (d.revision < run.revision_heard || !options.plan.has_early_decision() ||
          d.end_sample > run.end_counter) {
        ++decisions_ignored;
        const std::string why =
            !options.plan.has_early_decision() ? std::string("the run's plan has no early_decision")
            : d.end_sample > run.end_counter
                ? "it claims samples up to device counter " + std::to_string(d.end_sample) +
                      ", beyond the " + std::to_string(run.end_counter) + " published"
                : "judgement round " + std::to_string(d.revision) + ", the run is at " +
                      std::to_string(run.revision_heard);
        decision_log.Warning("run " + run.run_id + ": decision ignored (" + why + ")");
        continue;
      }
      run.unit.source->Stop();
      run.source_done = true;
      run.state = imuqual::run_t::STATE_COMPLETE;
      run.announcement.end_reason = DecidedEndReason(d);
      ++runs_decided;
      LogInfo("run " + run.run_id + " " + run.announcement.end_reason + ": source stopped after " +
              std::to_string(run.next_seq) + " batches, " + std::to_string(run.samples_published) +
              " samples (analysed up to device counter " + std::to_string(d.end_sample) + ")");
      Announce(run, kFinalAnnouncements);
    }
  }
}

bool AcquireService::Impl::GateOpen(const RunState& run) const {
  if (run.unit.source->info().paced_by_device) return true;
  for (const std::string& role : options.await) {
    auto it = run.acked.find(role);
    if (it == run.acked.end()) return false;  // consumer not there yet
    if (run.next_seq >= it->second + options.window_batches) return false;
  }
  return true;
}

bool AcquireService::Impl::AllAcknowledged() const {
  for (const RunState& run : runs) {
    for (const std::string& role : options.await) {
      auto it = run.acked.find(role);
      if (it == run.acked.end() || it->second < run.next_seq) return false;
    }
  }
  return true;
}

// A failed send is counted, not fatal: the batch stays retained and is
// resent when a consumer asks for it.
void AcquireService::Impl::Publish(RunState& run, bool drop, const std::vector<uint8_t>& bytes) {
  if (drop) {
    ++injected_drops;
    return;
  }
  ++published;
  Status st = SendBatch(run, bytes);
  if (!st.ok()) {
    ++publish_errors;
    publish_log.Error(st.message());
  }
}

Status AcquireService::Impl::SendBatch(const RunState& run, const std::vector<uint8_t>& bytes) {
  if (options.inject_bitflip > 0 && !bytes.empty() &&
      bitflip_rng.Uniform() < options.inject_bitflip) {
    ++injected_bitflips;
    std::vector<uint8_t> damaged = bytes;
    const uint64_t bit = bitflip_rng.Next() % (damaged.size() * 8);
    damaged[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    return bus->PublishEncoded(run.channel, damaged);
  }
  return bus->PublishEncoded(run.channel, bytes);
}

void MoveBlockIntoBatch(SampleBlock&& block, imuqual::rate_batch_t* msg) {
  msg->first_sample = block.first_sample;
  msg->num_samples = static_cast<int16_t>(block.size());
  msg->samples = std::move(block.samples);
  msg->num_flagged = static_cast<int16_t>(block.flags.size());
  for (const SampleFlagEntry& f : block.flags) {
    msg->flagged_sample.push_back(static_cast<int16_t>(f.sample));
    msg->flagged_axis.push_back(static_cast<int8_t>(f.axis));
    msg->flagged_bits.push_back(static_cast<int8_t>(f.bits));
  }
  msg->has_temperature = block.temperature_c.has_value();
  msg->temperature_c = block.temperature_c.value_or(0.0f);
  msg->sample_utime = block.first_sample_utime;
}

Status AcquireService::Impl::PublishOneBatch(RunState& run, double now_s, bool* published_one) {
  *published_one = false;
  if (run.source_done || !GateOpen(run)) return Status::Ok();
  const SourceInfo& info = run.unit.source->info();
  if (options.pace > 0 && run.first_counter >= 0 && !info.paced_by_device) {
    // As a device would: a batch leaves once its newest sample is due.
    const double due =
        run.pace_origin_s + static_cast<double>(run.samples_published + run.batch_samples) /
                                (info.nominal_rate_hz * options.pace);
    if (now_s < due) return Status::Ok();
  }
  SampleBlock block;
  auto n = run.unit.source->Read(run.batch_samples, &block);
  if (!n.ok()) {
    // One unit's source failing (a device gone for good, a corrupt file)
    // ends that run only; what it published stays published.
    run.source_done = true;
    run.state = imuqual::run_t::STATE_ABORTED;
    const std::string why = "unit " + run.unit.serial + ": " + n.status().message();
    run.announcement.end_reason = n.status().message();
    failures.push_back(why);
    LogError("run " + run.run_id + " aborted after " + std::to_string(run.next_seq) +
             " batches: " + why);
    Announce(run, kFinalAnnouncements);
    return Status::Ok();
  }
  if (*n == kNoSamplesYet) return Status::Ok();
  if (*n == 0) {
    run.source_done = true;
    run.state = imuqual::run_t::STATE_COMPLETE;
    LogInfo("run " + run.run_id + " complete: " + std::to_string(run.next_seq) + " batches, " +
            std::to_string(run.samples_published) + " samples");
    Announce(run, kFinalAnnouncements);
    return Status::Ok();
  }
  if (run.first_counter < 0) {
    run.first_counter = block.first_sample;
    // The first batch goes at once, as if its samples had been taken over
    // the batch period before now.
    run.pace_origin_s = MonotonicSeconds();
    if (options.pace > 0)
      run.pace_origin_s -= static_cast<double>(*n) / (info.nominal_rate_hz * options.pace);
  }
  imuqual::rate_batch_t msg;
  msg.host_utime = NowUtime();
  msg.run_id = run.run_id;
  msg.unit_serial = run.unit.serial;
  msg.seq = run.next_seq;
  msg.nominal_rate_hz = info.nominal_rate_hz;
  msg.num_axes = run.announcement.num_axes;
  msg.axis_names = run.announcement.axis_names;
  msg.axis_kinds = run.announcement.axis_kinds;
  MoveBlockIntoBatch(std::move(block), &msg);

  std::vector<uint8_t> bytes;
  IMUQUAL_RETURN_IF_ERROR(EncodeSealedBatch(&msg, &bytes));
  const bool drop = options.inject_drop > 0 && drop_rng.Uniform() < options.inject_drop;
  Publish(run, drop, bytes);
  run.retained.Add({run.next_seq, now_s, std::move(bytes)});
  ++run.next_seq;
  run.samples_published += *n;
  run.end_counter = msg.first_sample + *n;
  *published_one = true;
  return Status::Ok();
}

// Requests are answered within each requester's budget (ResendBudget):
// beyond it the rest of a request is dropped and counted; a requester that
// still needs it asks again, with back-off.
Status AcquireService::Impl::ServeResends() {
  while (!resend_queue.empty()) {
    auto [req, requester] = std::move(resend_queue.front());
    resend_queue.pop_front();
    for (RunState& run : runs) {
      if (run.run_id != req.run_id) continue;
      const int64_t first = std::max<int64_t>(req.first_seq, 0);
      const int64_t last = std::min<int64_t>(req.last_seq, first + kMaxResendRange - 1);
      for (int64_t seq = first; seq <= last && seq < run.next_seq; ++seq) {
        RetainedBatch* it = run.retained.Find(seq);
        if (it == nullptr) {
          ++resend_misses;
          continue;
        }
        const double now = MonotonicSeconds();
        if (now - it->resent_s < kResendDedupS) continue;
        if (!resend_budget->Take(requester, static_cast<double>(it->bytes.size()), now)) {
          resends_throttled += std::min(last, run.next_seq - 1) - seq + 1;
          refusal_log.Warning("resend requests beyond a requester's budget (" +
                              ShortestReal(resend_bytes_per_s / 1e6) +
                              " MB/s): the rest dropped, counted in resends_throttled");
          break;
        }
        it->resent_s = now;
        ++resent;
        Status st = SendBatch(run, it->bytes);
        if (!st.ok()) {
          ++publish_errors;
          publish_log.Error(st.message());
        }
      }
    }
  }
  return Status::Ok();
}

// Batches the store acknowledged are kept for the window plus retention_s
// of data; the others until the store has them (a store that cannot write
// yet), within retention_mb over all runs; beyond, the oldest go, counted
// and warned about in the log, status_t and the console.
void AcquireService::Impl::Prune(double now_s) {
  for (RunState& run : runs) {
    // Device-paced sources publish part-filled batches: size by the average.
    const double batch =
        run.next_seq > 0
            ? std::min<double>(run.batch_samples, static_cast<double>(run.samples_published) /
                                                      static_cast<double>(run.next_seq))
            : run.batch_samples;
    const double batches_per_s = run.unit.source->info().nominal_rate_hz / std::max(batch, 1.0);
    const size_t cap = static_cast<size_t>(options.window_batches) +
                       static_cast<size_t>(std::ceil(options.retention_s * batches_per_s));
    // Only the store's acknowledgement frees a batch: it says the batch is
    // archived (an analyze's says only that it was analysed).
    auto store_acked = run.acked.find("store");
    const int64_t acked_all = store_acked == run.acked.end() ? 0 : store_acked->second;
    const int64_t max_bytes =
        (int64_t{options.retention_mb} << 20) / static_cast<int64_t>(runs.size());
    const Retention::Pruned pruned = run.retained.Prune(cap, acked_all, max_bytes);
    if (pruned.unacknowledged > 0) {
      evicted_unacknowledged += pruned.unacknowledged;
      retention_warning = RetentionExceededWarning(run.run_id, pruned, options.retention_mb);
      retention_warning_s = now_s;
      retention_log.Error(retention_warning);
    }
  }
}

Status AcquireService::Impl::Abort(const std::string& why) {
  for (RunState& run : runs) {
    if (run.state == imuqual::run_t::STATE_RUNNING) {
      run.state = imuqual::run_t::STATE_ABORTED;
      run.announcement.end_reason = why;
      Announce(run, kFinalAnnouncements);
      LogWarning("run " + run.run_id + " aborted after " + std::to_string(run.next_seq) +
                 " batches: " + why);
    }
  }
  return Status::Ok();
}

std::vector<std::string> AcquireService::Impl::ReconnectingRuns() const {
  std::vector<std::string> ids;
  for (const RunState& r : runs) {
    if (r.state == imuqual::run_t::STATE_RUNNING && r.unit.source->Reconnecting())
      ids.push_back(r.run_id);
  }
  return ids;
}

Counters AcquireService::Impl::StatusCounters() const {
  int64_t retained = 0, retained_bytes = 0, active = 0;
  std::map<std::string, int64_t> sources;
  for (const RunState& r : runs) {
    retained += static_cast<int64_t>(r.retained.size());
    retained_bytes += r.retained.bytes();
    active += r.state == imuqual::run_t::STATE_RUNNING;
    r.unit.source->AddCounters(&sources);
  }
  Counters out = {{"runs_active", active},
                  {"runs_failed", static_cast<int64_t>(failures.size())},
                  {"batches_published", published},
                  {"batches_resent", resent},
                  {"resend_requests", resend_requests},
                  {"resend_misses", resend_misses},
                  {"injected_drops", injected_drops},
                  {"injected_bitflips", injected_bitflips},
                  {"acks_received", acks},
                  {"batches_retained", retained},
                  {"retained_bytes", retained_bytes},
                  {"publish_errors", publish_errors},
                  {"evicted_unacknowledged", evicted_unacknowledged},
                  {"runs_decided", runs_decided},
                  {"decisions_ignored", decisions_ignored},
                  {"decisions_dropped", decisions_dropped},
                  {"acks_refused", acks_refused},
                  {"resends_throttled", resends_throttled},
                  {"decode_errors", static_cast<int64_t>(bus->decode_errors())}};
  for (const auto& [name, value] : sources) out.emplace_back(name, value);
  // Per run: a unit whose device is gone, for the station console.
  for (const std::string& id : ReconnectingRuns())
    out.emplace_back(std::string(channels::kReconnectingCounterPrefix) + id, 1);
  return out;
}

Status AcquireService::Run() {
  Impl& s = *impl_;
  BusSecurity security = s.options.security;
  security.role = BusRole::kAcquire;
  auto bus = LcmBus::Open(s.options.lcm_url, std::move(security));
  if (!bus.ok()) return bus.status();
  s.bus = std::move(*bus);
  // Acks and resend requests: small messages, many in flight at full speed.
  s.bus->SubscribeWithOrigin<imuqual::ack_t>(
      channels::kAck, 10000, nullptr,
      [&s](const std::string&, imuqual::ack_t&& ack, const MessageOrigin& from) {
        s.OnAck(ack, from.role);
      });
  s.resend_bytes_per_s = ResendBytesPerS(s.options.resend_budget_mb_s, BusTtl(s.options.lcm_url));
  s.resend_budget = std::make_unique<ResendBudget>(s.resend_bytes_per_s, 2 * s.resend_bytes_per_s);
  s.bus->SubscribeWithOrigin<imuqual::resend_t>(
      channels::kResend, 1000, nullptr,
      [&s](const std::string&, imuqual::resend_t&& req, const MessageOrigin& from) {
        ++s.resend_requests;
        s.last_resend_request_s = MonotonicSeconds();
        // The budget is the requesting role's (its seal names it): a new
        // instance of a role gets no budget of its own.
        if (s.resend_queue.size() < 10000)
          s.resend_queue.emplace_back(std::move(req), static_cast<uint64_t>(from.role));
      });
  // Early decisions (plans with early_decision): a decided unit's source stops.
  s.bus->Subscribe<imuqual::decision_t>(
      channels::kDecisionAll, 1000, [&s](const std::string&, imuqual::decision_t&& d, int64_t) {
        const bool decided = d.state == imuqual::decision_t::STATE_PASS ||
                             d.state == imuqual::decision_t::STATE_FAIL;
        if (!decided) return;
        if (s.decision_queue.size() >= 10000) {
          ++s.decisions_dropped;  // analyze says it again every interim period
          return;
        }
        s.decision_queue.push_back(std::move(d));
      });
  // The store's announcements carry each run's judgement round.
  s.bus->Subscribe<imuqual::run_t>(
      channels::kRun, 1000,
      [&s](const std::string&, imuqual::run_t&& r, int64_t) { s.OnStoreRun(r); });

  double now = MonotonicSeconds();
  for (RunState& run : s.runs) {
    run.last_ack_progress_s = now;
    s.Announce(run);
    LogInfo("run " + run.run_id + " started: unit " + run.unit.serial + ", " +
            run.unit.source->info().description + ", " + std::to_string(run.batch_samples) +
            " samples per batch");
  }
  const double heartbeat_s =
      std::max(s.options.heartbeat_s,
               static_cast<double>(s.runs.size()) / s.options.heartbeat_runs_per_s);
  double next_heartbeat = now + heartbeat_s;
  double next_status = now;
  double all_done_since = -1;

  for (;;) {
    now = MonotonicSeconds();
    if (ShutdownRequested()) {
      s.Abort(kShutdownEndReason);
      s.LogSummary("stopped");
      return Status::Ok();
    }
    bool progress = false;
    for (int round = 0; round < kBatchesPerRunPerRound; ++round) {
      bool any = false;
      for (RunState& run : s.runs) {
        bool one = false;
        Status st = s.PublishOneBatch(run, now, &one);
        if (!st.ok()) {
          s.Abort(st.message());
          return st;
        }
        any |= one;
      }
      progress |= any;
      if (!any) break;
    }
    IMUQUAL_RETURN_IF_ERROR(s.ServeResends());
    s.EndDecidedRuns();
    s.Prune(now);

    if (now >= next_heartbeat) {
      for (RunState& run : s.runs) s.Announce(run);
      next_heartbeat = now + heartbeat_s;
    }
    std::vector<std::string> reconnecting = s.ReconnectingRuns();
    if (now >= next_status || reconnecting != s.reconnecting_published) {
      s.reconnecting_published = std::move(reconnecting);
      // Unhealthy for a while after batches were dropped unacknowledged.
      const bool dropping = now - s.retention_warning_s < kRetentionWarningS;
      (void)PublishStatus(*s.bus, "acquire", !dropping, dropping ? s.retention_warning : "",
                          s.StatusCounters());
      next_status = now + 1.0;
    }

    const bool all_done =
        std::all_of(s.runs.begin(), s.runs.end(), [](const RunState& r) { return r.source_done; });
    if (all_done) {
      if (all_done_since < 0) all_done_since = now;
      // Without consumers to wait for, stay while anyone still asks for
      // resends (then they have what they need), within linger_s.
      const bool quiet = s.options.await.empty() && now - all_done_since > kResendQuietS &&
                         now - s.last_resend_request_s > kResendQuietS;
      if ((!s.options.await.empty() && s.AllAcknowledged()) || quiet) {
        for (RunState& run : s.runs) s.Announce(run, kFinalAnnouncements);
        s.LogSummary("all runs acknowledged");
        (void)PublishStatus(*s.bus, "acquire", true, "all runs acknowledged", s.StatusCounters());
        return s.FinalStatus();
      }
      if (now - all_done_since > s.options.linger_s) {
        LogWarning("consumers did not acknowledge every batch within " +
                   std::to_string(s.options.linger_s) + " s; leaving the rest to them");
        return s.FinalStatus();
      }
    }
    // A stalled gate: an awaited consumer stopped acknowledging.
    if (!all_done) {
      for (const RunState& run : s.runs) {
        if (run.source_done || s.GateOpen(run)) continue;
        if (now - run.last_ack_progress_s > s.options.consumer_timeout_s) {
          std::vector<std::string> silent;
          for (const std::string& role : s.options.await) {
            auto it = run.acked.find(role);
            if (it == run.acked.end() || run.next_seq >= it->second + s.options.window_batches) {
              silent.push_back("imuqual-" + role);
            }
          }
          const std::string missing = Join(silent, ", ");
          const std::string why = "no acknowledgement from " + missing + " for run " + run.run_id +
                                  " in " +
                                  std::to_string(static_cast<int>(s.options.consumer_timeout_s)) +
                                  " s (is it running on " + s.options.lcm_url + "?)";
          s.Abort(why);
          return Status::Unavailable(why);
        }
      }
    }
    IMUQUAL_RETURN_IF_ERROR(s.bus->HandleFor(progress ? 0 : 2));
  }
}

}  // namespace imuqual::acquire
