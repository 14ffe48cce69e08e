#include "store/archive.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <functional>
#include <map>
#include <set>
#include <thread>

#include "common/clock.h"
#include "store/canonical.h"
#include "store/chain.h"
#include "store/checksums.h"
#include "store/outcome.h"
#include "store/plant_schema.h"
#include "store/schema.h"

namespace imuqual::store {
namespace {

// Statement cache slots.
enum StmtId { kInsertLot, kInsertUnit, kUpsertRun, kInsertAxis, kInsertChunk, kFindRun, kNumStmts };

const char* UnitOf(pb::AxisKind kind) { return kind == pb::ACCEL ? "m/s^2" : "deg/s"; }

}  // namespace

const char* AxisKindName(pb::AxisKind kind) { return kind == pb::ACCEL ? "accel" : "gyro"; }
pb::AxisKind ParseAxisKind(const std::string& name) {
  return name == "accel" ? pb::ACCEL : pb::GYRO;
}

Archive::~Archive() = default;

namespace {
// How long opening for writing retries the switch to WAL while other
// connections hold the new file (several stations creating it at once).
constexpr double kWalSwitchWaitS = 60;
}  // namespace

Result<std::unique_ptr<Archive>> Archive::Open(const std::string& path, Mode mode) {
  if (IsPostgresUrl(path)) {
    IMUQUAL_RETURN_IF_ERROR(InitCrypto());
    auto db = Db::Open(path, mode == Mode::kWrite ? Db::Mode::kReadWrite : Db::Mode::kReadOnly);
    if (!db.ok()) return db.status();
    std::unique_ptr<Archive> archive(new Archive(std::move(*db)));
    IMUQUAL_RETURN_IF_ERROR(mode == Mode::kWrite ? MigratePlant(*archive->db_)
                                                 : CheckPlantReadable(*archive->db_));
    archive->cache_.resize(kNumStmts);
    return archive;
  }
  if (mode == Mode::kRead && ::access(path.c_str(), F_OK) != 0) {
    return Status::NotFound("no archive at " + path);
  }
  if (mode == Mode::kWrite) {
    // Say plainly when the directory is not writable: SQLite's own error
    // ("unable to open database file") does not.
    const size_t slash = path.find_last_of('/');
    const std::string dir =
        slash == std::string::npos ? std::string(".") : path.substr(0, slash + 1);
    if (::access(dir.c_str(), W_OK) != 0) {
      return Status::IoError("cannot write the archive " + path + ": directory " + dir + ": " +
                             std::strerror(errno));
    }
  }
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());  // chunk digests, the chain's hashes and signatures
  auto db = Db::Open(path, mode == Mode::kWrite ? Db::Mode::kReadWrite : Db::Mode::kReadOnly);
  if (!db.ok()) return db.status();
  std::unique_ptr<Archive> archive(new Archive(std::move(*db)));
  Db& d = *archive->db_;
  if (mode == Mode::kWrite) {
    IMUQUAL_RETURN_IF_ERROR(Migrate(d));
    // Switching a new file to WAL needs it to itself, and SQLite answers
    // "database is locked" at once (no busy wait) while another station's
    // connection is opening the same new archive: retry for a while.
    const double give_up = MonotonicSeconds() + kWalSwitchWaitS;
    for (int attempt = 0;; ++attempt) {
      auto wal = d.Prepare("PRAGMA journal_mode=WAL");
      if (!wal.ok()) return wal.status();
      auto row = wal->Step();
      if (row.ok()) break;
      if (row.status().code() != Status::Code::kUnavailable || MonotonicSeconds() > give_up)
        return row.status();
      std::this_thread::sleep_for(std::chrono::milliseconds(5 + (attempt % 8) * 5));
    }
    IMUQUAL_RETURN_IF_ERROR(d.Exec("PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;"));
  } else {
    IMUQUAL_RETURN_IF_ERROR(CheckReadable(d));
  }
  archive->cache_.resize(kNumStmts);
  return archive;
}

Result<Stmt*> Archive::Cached(int id, const char* sql) {
  if (!cache_[id]) {
    auto stmt = db_->Prepare(sql);
    if (!stmt.ok()) return stmt.status();
    cache_[id] = std::make_unique<Stmt>(std::move(*stmt));
  }
  return cache_[id].get();
}

Status Archive::Begin() {
  unsealed_.clear();
  return db_->BeginWrite();
}

Status Archive::Commit() {
  // Each run's results checksum once per transaction, over its final rows.
  for (int64_t run_key : unsealed_) IMUQUAL_RETURN_IF_ERROR(SealResults(*db_, run_key));
  unsealed_.clear();
  return db_->Exec("COMMIT");
}

Status Archive::Rollback() {
  unsealed_.clear();
  return db_->Exec("ROLLBACK");
}

Status Archive::SealResultsOf(int64_t run_key) {
  if (db_->InAutocommit()) return SealResults(*db_, run_key);  // no transaction
  unsealed_.insert(run_key);
  return Status::Ok();
}

Result<int64_t> Archive::UpsertRun(const RunInfo& run) {
  auto lot = Cached(kInsertLot, "INSERT OR IGNORE INTO lots(lot, first_seen_utime) VALUES(?, ?)");
  if (!lot.ok()) return lot.status();
  IMUQUAL_RETURN_IF_ERROR((*lot)->Bind(1, run.lot).Bind(2, run.start_utime).Run());
  auto unit =
      Cached(kInsertUnit, "INSERT OR IGNORE INTO units(serial, first_seen_utime) VALUES(?, ?)");
  if (!unit.ok()) return unit.status();
  IMUQUAL_RETURN_IF_ERROR((*unit)->Bind(1, run.serial).Bind(2, run.start_utime).Run());

  auto up = Cached(kUpsertRun, R"sql(
INSERT INTO runs(run_id, serial, lot, station, slot, operator, source, software_version,
                 start_utime, end_utime, state, nominal_rate_hz, last_seq, samples_announced,
                 plan, plan_sha256, truth, first_sample, end_sample, end_reason, bus_auth)
VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20,
       NULLIF(?21, ''))
ON CONFLICT(run_id) DO UPDATE SET
  bus_auth = CASE WHEN excluded.bus_auth IS NULL THEN runs.bus_auth
                  WHEN runs.bus_auth IS NULL THEN excluded.bus_auth
                  WHEN instr(runs.bus_auth, excluded.bus_auth) > 0 THEN runs.bus_auth
                  ELSE runs.bus_auth || '; then ' || excluded.bus_auth END,
  state = CASE WHEN runs.state IN ('complete', 'aborted') THEN runs.state ELSE excluded.state END,
  end_reason = CASE WHEN runs.state IN ('complete', 'aborted') OR excluded.end_reason = ''
                    THEN runs.end_reason ELSE excluded.end_reason END,
  end_utime = COALESCE(runs.end_utime, excluded.end_utime),
  last_seq = MAX(runs.last_seq, excluded.last_seq),
  samples_announced = MAX(runs.samples_announced, excluded.samples_announced),
  first_sample = CASE WHEN runs.first_sample < 0 THEN excluded.first_sample ELSE runs.first_sample END,
  end_sample = MAX(runs.end_sample, excluded.end_sample)
RETURNING run_key)sql");
  if (!up.ok()) return up.status();
  Stmt& s = **up;
  s.Bind(1, run.run_id).Bind(2, run.serial).Bind(3, run.lot).Bind(4, run.station);
  s.Bind(5, run.slot).Bind(6, run.operator_name).Bind(7, run.source).Bind(8, run.software_version);
  s.Bind(9, run.start_utime);
  if (run.end_utime) {
    s.Bind(10, *run.end_utime);
  } else {
    s.BindNull(10);
  }
  s.Bind(11, run.state).Bind(12, run.nominal_rate_hz).Bind(13, run.last_seq);
  s.Bind(14, run.samples_announced);
  s.BindBlob(15, {reinterpret_cast<const uint8_t*>(run.plan.data()), run.plan.size()});
  s.Bind(16, run.plan_sha256);
  s.BindBlob(17, {reinterpret_cast<const uint8_t*>(run.truth.data()), run.truth.size()});
  s.Bind(18, run.first_sample).Bind(19, run.end_sample).Bind(20, run.end_reason);
  s.Bind(21, run.bus_auth);
  auto row = s.Step();
  if (!row.ok()) return row.status();
  if (!*row) {
    s.Reset();
    return Status::InvalidArgument("upsert of run " + run.run_id + " returned no key");
  }
  const int64_t key = s.Int(0);
  s.Reset();

  auto axis = Cached(kInsertAxis,
                     "INSERT OR IGNORE INTO run_axes(run_key, axis_index, axis, kind, unit) "
                     "VALUES(?, ?, ?, ?, ?)");
  if (!axis.ok()) return axis.status();
  for (size_t i = 0; i < run.axes.size(); ++i) {
    IMUQUAL_RETURN_IF_ERROR((*axis)
                                ->Bind(1, key)
                                .Bind(2, static_cast<int64_t>(i))
                                .Bind(3, run.axes[i].name)
                                .Bind(4, AxisKindName(run.axes[i].kind))
                                .Bind(5, UnitOf(run.axes[i].kind))
                                .Run());
  }
  return key;
}

Status Archive::InsertChunk(int64_t run_key, const ChunkRecord& c, bool* inserted) {
  auto st = Cached(kInsertChunk,
                   "INSERT OR IGNORE INTO raw_chunks(run_key, seq, first_sample, num_samples, "
                   "host_utime, temperature_c, codec, data, sample_utime, crc32c, digest) "
                   "VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!st.ok()) return st.status();
  Stmt& s = **st;
  s.Bind(1, run_key).Bind(2, c.seq).Bind(3, c.first_sample).Bind(4, c.num_samples);
  s.Bind(5, c.host_utime)
      .Bind(6, c.temperature_c)
      .Bind(7, c.codec)
      .BindBlob(8, c.data)
      .Bind(9, c.sample_utime)
      .Bind(10, static_cast<int64_t>(ChunkChecksum(c)))
      .BindBlob(11, ChunkDigest(c));
  IMUQUAL_RETURN_IF_ERROR(s.Run());
  if (inserted) *inserted = db_->Changes() > 0;
  return Status::Ok();
}

Status Archive::RecomputeGaps(int64_t run_key, int64_t last_seq, int64_t now_utime) {
  auto del = db_->Prepare("DELETE FROM gaps WHERE run_key = ?");
  if (!del.ok()) return del.status();
  IMUQUAL_RETURN_IF_ERROR(del->Bind(1, run_key).Run());
  // Holes between consecutive archived seqs, plus a leading hole before the
  // first chunk and a trailing one after the last (up to last_seq). Sample
  // ranges come from the device counters around the hole where known.
  auto ins = db_->Prepare(R"sql(
WITH c AS (
  SELECT seq, first_sample, num_samples,
         LAG(seq) OVER w AS prev_seq,
         LAG(first_sample + num_samples) OVER w AS prev_end
  FROM raw_chunks WHERE run_key = ?1 WINDOW w AS (ORDER BY seq)
),
holes AS (
  -- A seq hole spans the missing batches; a counter jump is at one batch.
  SELECT CASE WHEN seq - COALESCE(prev_seq, -1) > 1 THEN COALESCE(prev_seq + 1, 0) ELSE seq END AS first_seq,
         CASE WHEN seq - COALESCE(prev_seq, -1) > 1 THEN seq - 1 ELSE seq END AS last_seq,
         prev_end AS first_sample,
         CASE WHEN prev_end IS NULL THEN NULL ELSE first_sample - prev_end END AS num_samples,
         CASE WHEN seq - COALESCE(prev_seq, -1) > 1 THEN 'seq'
              WHEN first_sample < prev_end THEN 'counter_backwards' ELSE 'counter' END AS reason
  FROM c
  WHERE seq - COALESCE(prev_seq, -1) > 1
     OR (prev_end IS NOT NULL AND first_sample <> prev_end)
  UNION ALL
  SELECT COALESCE(MAX(seq) + 1, 0), ?2, MAX(first_sample + num_samples),
         (SELECT NULLIF(end_sample, -1) FROM runs WHERE run_key = ?1) - MAX(first_sample + num_samples),
         'seq'
  FROM raw_chunks WHERE run_key = ?1
  HAVING COALESCE(MAX(seq), -1) < ?2
)
INSERT INTO gaps(run_key, first_seq, last_seq, first_sample, num_samples, reason, detected_utime)
SELECT ?1, first_seq, last_seq, first_sample, num_samples, reason, ?3 FROM holes)sql");
  if (!ins.ok()) return ins.status();
  return ins->Bind(1, run_key).Bind(2, last_seq).Bind(3, now_utime).Run();
}

Status Archive::LabelSeqGaps(int64_t run_key, int64_t first_seq, int64_t last_seq,
                             const std::string& reason) {
  auto up = db_->Prepare(
      "UPDATE gaps SET reason = ?1 WHERE run_key = ?2 AND reason = 'seq' AND first_seq <= ?4 "
      "AND last_seq >= ?3");
  if (!up.ok()) return up.status();
  return up->Bind(1, reason).Bind(2, run_key).Bind(3, first_seq).Bind(4, last_seq).Run();
}

Status Archive::InsertGap(int64_t run_key, const GapRecord& g) {
  auto ins = db_->Prepare(
      "INSERT OR REPLACE INTO gaps(run_key, first_seq, last_seq, first_sample, num_samples, "
      "reason, "
      "detected_utime) VALUES(?, ?, ?, ?, ?, ?, ?)");
  if (!ins.ok()) return ins.status();
  ins->Bind(1, run_key).Bind(2, g.first_seq).Bind(3, g.last_seq);
  if (g.first_sample) {
    ins->Bind(4, *g.first_sample);
  } else {
    ins->BindNull(4);
  }
  if (g.num_samples) {
    ins->Bind(5, *g.num_samples);
  } else {
    ins->BindNull(5);
  }
  return ins->Bind(6, g.reason).Bind(7, g.detected_utime).Run();
}

namespace {

// curve_points.alpha_from: how a point's alpha was obtained (NULL: none).
std::optional<std::string> AlphaFrom(const allan::CurvePoint& p) {
  if (!p.alpha) return std::nullopt;
  return p.alpha_inherited ? "nearest" : "identified";
}
}  // namespace

Status Archive::PutCurve(int64_t run_key, const CurveRecord& rec) {
  const std::string est(allan::DeviationName(rec.curve.deviation));
  auto del =
      db_->Prepare("DELETE FROM curve_points WHERE run_key = ? AND axis = ? AND estimator = ?");
  if (!del.ok()) return del.status();
  IMUQUAL_RETURN_IF_ERROR(del->Bind(1, run_key).Bind(2, rec.axis).Bind(3, est).Run());
  auto cur = db_->Prepare(
      "INSERT OR REPLACE INTO curves(run_key, axis, estimator, ci_method, tau0_s, samples, "
      "valid_samples, computed_utime) VALUES(?, ?, ?, ?, ?, ?, ?, ?)");
  if (!cur.ok()) return cur.status();
  IMUQUAL_RETURN_IF_ERROR(cur->Bind(1, run_key)
                              .Bind(2, rec.axis)
                              .Bind(3, est)
                              .Bind(4, allan::CiMethodName(rec.curve.ci))
                              .Bind(5, rec.curve.tau0_s)
                              .Bind(6, rec.samples)
                              .Bind(7, rec.valid_samples)
                              .Bind(8, rec.computed_utime)
                              .Run());
  auto pt = db_->Prepare(
      "INSERT INTO curve_points(run_key, axis, estimator, m, tau_s, dev, lo, hi, edf, n_terms, "
      "stride, alpha, alpha_from) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!pt.ok()) return pt.status();
  for (const allan::CurvePoint& p : rec.curve.points) {
    IMUQUAL_RETURN_IF_ERROR(pt->Bind(1, run_key)
                                .Bind(2, rec.axis)
                                .Bind(3, est)
                                .Bind(4, p.m)
                                .Bind(5, p.tau_s)
                                .Bind(6, p.dev)
                                .Bind(7, p.lo)
                                .Bind(8, p.hi)
                                .Bind(9, p.edf)
                                .Bind(10, p.n)
                                .Bind(11, p.stride)
                                .Bind(12, p.alpha ? std::optional<int64_t>(*p.alpha) : std::nullopt)
                                .Bind(13, AlphaFrom(p))
                                .Run());
  }
  return SealResultsOf(run_key);
}

Status Archive::PutResult(int64_t run_key, const ResultRecord& r) {
  auto del = db_->Prepare("DELETE FROM measurements WHERE run_key = ?");
  if (!del.ok()) return del.status();
  IMUQUAL_RETURN_IF_ERROR(del->Bind(1, run_key).Run());
  auto ins = db_->Prepare(
      "INSERT OR REPLACE INTO measurements(run_key, axis, name, value, unit, low, high, "
      "marginal_low, marginal_high, outcome, note, uncertainty, qualifier, uncertainty_method, "
      "decision_rule, guard_band) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!ins.ok()) return ins.status();
  for (const pb::Measurement& m : r.measurements) {
    auto opt = [](bool has, double v) { return has ? std::optional<double>(v) : std::nullopt; };
    Stmt& s = *ins;
    s.Bind(1, run_key).Bind(2, m.axis()).Bind(3, m.name()).Bind(4, m.value()).Bind(5, m.unit());
    s.Bind(6, opt(m.has_low(), m.low())).Bind(7, opt(m.has_high(), m.high()));
    s.Bind(8, opt(m.has_marginal_low(), m.marginal_low()));
    s.Bind(9, opt(m.has_marginal_high(), m.marginal_high()));
    // Unset (and unknown) codes are NULL: the columns' CHECKs name the rest.
    auto text_or_null = [&s](int col, const char* text) {
      if (*text == '\0') {
        s.BindNull(col);
      } else {
        s.Bind(col, text);
      }
    };
    text_or_null(10, OutcomeText(m.outcome()));
    s.Bind(11, m.note());
    s.Bind(12, opt(m.has_uncertainty(), m.uncertainty()));
    text_or_null(13, QualifierText(m.qualifier()));
    if (m.uncertainty_method().empty()) {
      s.BindNull(14);
    } else {
      s.Bind(14, m.uncertainty_method());
    }
    text_or_null(15, DecisionRuleText(m.decision_rule()));
    s.Bind(16, opt(m.has_guard_band(), m.guard_band()));
    IMUQUAL_RETURN_IF_ERROR(s.Run());
  }
  std::string reasons;
  for (const std::string& reason : r.reasons) reasons += (reasons.empty() ? "" : "\n") + reason;
  auto up = db_->Prepare(
      "UPDATE runs SET verdict = ?, reasons = ?, samples = ?, gap_samples = ?, "
      "invalid_samples = ?, record = ?, result_utime = ?, result_last_seq = ?, "
      "result_gap_batches = ? WHERE run_key = ?");
  if (!up.ok()) return up.status();
  if (r.verdict.empty()) {
    up->BindNull(1);
  } else {
    up->Bind(1, r.verdict);
  }
  IMUQUAL_RETURN_IF_ERROR(
      up->Bind(2, reasons)
          .Bind(3, r.samples)
          .Bind(4, r.gap_samples)
          .Bind(5, r.invalid_samples)
          .BindBlob(6, {reinterpret_cast<const uint8_t*>(r.record.data()), r.record.size()})
          .Bind(7, r.result_utime)
          .Bind(8, r.last_seq)
          .Bind(9, r.gap_batches)
          .Bind(10, run_key)
          .Run());
  // Each axis its own count: one per axis of the run, else none is known.
  auto count = db_->Prepare("SELECT COUNT(*) FROM run_axes WHERE run_key = ?");
  if (!count.ok()) return count.status();
  count->Bind(1, run_key);
  auto counted = count->Step();
  if (!counted.ok()) return counted.status();
  const int64_t num_axes = *counted ? count->Int(0) : 0;
  count->Reset();
  const bool one_per_axis = r.axis_invalid_samples.size() == static_cast<size_t>(num_axes);
  auto axes =
      db_->Prepare("UPDATE run_axes SET invalid_samples = ? WHERE run_key = ? AND axis_index = ?");
  if (!axes.ok()) return axes.status();
  for (int64_t a = 0; a < num_axes; ++a) {
    if (one_per_axis) {
      axes->Bind(1, r.axis_invalid_samples[static_cast<size_t>(a)]);
    } else {
      axes->BindNull(1);
    }
    IMUQUAL_RETURN_IF_ERROR(axes->Bind(2, run_key).Bind(3, a).Run());
  }
  return SealResultsOf(run_key);
}

Status Archive::SetSigningKey(const SigningKey& key) {
  if (key.role != "store") {
    return Status::InvalidArgument("the archive is signed with a key of role 'store', not '" +
                                   key.role + "'");
  }
  signing_key_ = key;
  return Status::Ok();
}

Status Archive::MarkFinalized(int64_t run_key, int64_t utime) {
  IMUQUAL_RETURN_IF_ERROR(db_->Exec("SAVEPOINT mark_finalized"));
  auto up = db_->Prepare("UPDATE runs SET finalized_utime = ? WHERE run_key = ?");
  Status st = up.ok() ? up->Bind(1, utime).Bind(2, run_key).Run() : up.status();
  if (st.ok()) {
    st = AppendRunEntry(*db_, run_key, kEntryFinalized, signing_key_ ? &*signing_key_ : nullptr,
                        utime);
  }
  if (!st.ok()) {
    (void)db_->Exec("ROLLBACK TO mark_finalized; RELEASE mark_finalized");
    return st;
  }
  return db_->Exec("RELEASE mark_finalized");
}

Result<int> Archive::SupersedeJudgement(int64_t run_key, int64_t utime, const std::string& cause) {
  auto keep = db_->Prepare(
      "INSERT OR REPLACE INTO superseded_judgements(run_key, revision, verdict, reasons, samples, "
      "gap_samples, record, result_utime, superseded_utime, cause) SELECT run_key, revision, "
      "verdict, reasons, samples, gap_samples, record, result_utime, ?, ? FROM runs "
      "WHERE run_key = ? AND result_utime IS NOT NULL");
  if (!keep.ok()) return keep.status();
  IMUQUAL_RETURN_IF_ERROR(keep->Bind(1, utime).Bind(2, cause).Bind(3, run_key).Run());
  for (const char* sql :
       {"DELETE FROM measurements WHERE run_key = ?", "DELETE FROM curve_points WHERE run_key = ?",
        "DELETE FROM curves WHERE run_key = ?",
        "UPDATE run_axes SET invalid_samples = NULL WHERE run_key = ?",
        "UPDATE runs SET verdict = NULL, reasons = NULL, samples = NULL, gap_samples = NULL, "
        "invalid_samples = NULL, record = NULL, result_utime = NULL, result_last_seq = NULL, "
        "result_gap_batches = NULL, finalized_utime = NULL, revision = revision + 1 "
        "WHERE run_key = ?"}) {
    auto s = db_->Prepare(sql);
    if (!s.ok()) return s.status();
    IMUQUAL_RETURN_IF_ERROR(s->Bind(1, run_key).Run());
  }
  IMUQUAL_RETURN_IF_ERROR(SealResults(*db_, run_key));
  IMUQUAL_RETURN_IF_ERROR(AppendRunEntry(*db_, run_key, kEntryReopened,
                                         signing_key_ ? &*signing_key_ : nullptr, utime));
  auto revision = db_->Prepare("SELECT revision FROM runs WHERE run_key = ?");
  if (!revision.ok()) return revision.status();
  revision->Bind(1, run_key);
  auto row = revision->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::NotFound("no run with key " + std::to_string(run_key));
  return static_cast<int>(revision->Int(0));
}

Result<std::vector<std::string>> Archive::UnfinishedRunIds() {
  auto s = db_->Prepare("SELECT run_id FROM runs WHERE finalized_utime IS NULL ORDER BY run_key");
  if (!s.ok()) return s.status();
  std::vector<std::string> ids;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return ids;
    ids.push_back(s->Text(0));
  }
}

namespace {

// The columns of a run's result in runs, and how a row of them reads.
constexpr char kResultColumns[] =
    "COALESCE(verdict, ''), COALESCE(reasons, ''), samples, gap_samples, invalid_samples, "
    "result_utime, record, revision, result_last_seq, result_gap_batches";
// The same without the signed record (15 KB a run, hex on the wire from
// PostgreSQL): what a lot's report reads.
constexpr char kResultColumnsNoRecord[] =
    "COALESCE(verdict, ''), COALESCE(reasons, ''), samples, gap_samples, invalid_samples, "
    "result_utime, NULL, revision, result_last_seq, result_gap_batches";
ResultRecord ResultFromRow(Stmt& r, int at) {
  ResultRecord res;
  res.verdict = r.Text(at);
  const std::string reasons = r.Text(at + 1);
  for (size_t start = 0; start < reasons.size();) {
    const size_t end = reasons.find('\n', start);
    res.reasons.push_back(reasons.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  res.samples = r.Int(at + 2);
  res.gap_samples = r.Int(at + 3);
  res.invalid_samples = r.Int(at + 4);
  res.result_utime = r.Int(at + 5);
  const std::vector<uint8_t> record = r.Blob(at + 6);
  res.record.assign(record.begin(), record.end());
  res.revision = static_cast<int>(r.Int(at + 7));
  if (!r.IsNull(at + 8)) res.last_seq = r.Int(at + 8);
  if (!r.IsNull(at + 9)) res.gap_batches = r.Int(at + 9);
  return res;
}

constexpr char kMeasurementColumns[] =
    "axis, name, value, unit, low, high, marginal_low, marginal_high, outcome, note, "
    "uncertainty, qualifier, uncertainty_method, decision_rule, guard_band";
pb::Measurement MeasurementFromRow(Stmt& m, int at) {
  pb::Measurement pm;
  pm.set_axis(m.Text(at));
  pm.set_name(m.Text(at + 1));
  pm.set_value(m.Real(at + 2));
  pm.set_unit(m.Text(at + 3));
  if (!m.IsNull(at + 4)) pm.set_low(m.Real(at + 4));
  if (!m.IsNull(at + 5)) pm.set_high(m.Real(at + 5));
  if (!m.IsNull(at + 6)) pm.set_marginal_low(m.Real(at + 6));
  if (!m.IsNull(at + 7)) pm.set_marginal_high(m.Real(at + 7));
  pm.set_outcome(OutcomeFromText(m.Text(at + 8)));
  pm.set_note(m.Text(at + 9));
  if (!m.IsNull(at + 10)) pm.set_uncertainty(m.Real(at + 10));
  pm.set_qualifier(QualifierFromText(m.Text(at + 11)));
  pm.set_uncertainty_method(m.Text(at + 12));
  pm.set_decision_rule(DecisionRuleFromText(m.Text(at + 13)));
  if (!m.IsNull(at + 14)) pm.set_guard_band(m.Real(at + 14));
  return pm;
}

constexpr char kRunColumns[] =
    "run_key, serial, lot, station, slot, operator, source, software_version, start_utime, "
    "end_utime, state, nominal_rate_hz, last_seq, samples_announced, plan, plan_sha256, truth, "
    "first_sample, end_sample, end_reason, revision, bus_auth, run_id";
RunInfo RunFromRow(Stmt& s) {
  RunInfo r;
  r.serial = s.Text(1);
  r.lot = s.Text(2);
  r.station = s.Text(3);
  r.slot = s.Text(4);
  r.operator_name = s.Text(5);
  r.source = s.Text(6);
  r.software_version = s.Text(7);
  r.start_utime = s.Int(8);
  if (!s.IsNull(9)) r.end_utime = s.Int(9);
  r.state = s.Text(10);
  r.nominal_rate_hz = s.Real(11);
  r.last_seq = s.Int(12);
  r.samples_announced = s.Int(13);
  const std::vector<uint8_t> plan = s.Blob(14);
  r.plan.assign(plan.begin(), plan.end());
  r.plan_sha256 = s.Text(15);
  const std::vector<uint8_t> truth = s.Blob(16);
  r.truth.assign(truth.begin(), truth.end());
  r.first_sample = s.Int(17);
  r.end_sample = s.Int(18);
  r.end_reason = s.Text(19);
  r.revision = static_cast<int>(s.Int(20));
  r.bus_auth = s.IsNull(21) ? "" : s.Text(21);
  r.run_id = s.Text(22);
  return r;
}

constexpr char kCurveColumns[] =
    "c.axis, c.estimator, c.ci_method, c.tau0_s, c.samples, c.valid_samples, c.computed_utime, "
    "p.m, p.tau_s, p.dev, p.lo, p.hi, p.edf, p.n_terms, p.stride, p.alpha, p.alpha_from";
// Appends the curve point of row `s` (columns from `at`) to `curves`,
// starting a new curve when the axis or estimator changes.
void AddCurveRow(Stmt& s, int at, std::vector<CurveRecord>* curves) {
  const std::string axis = s.Text(at), est = s.Text(at + 1);
  if (curves->empty() || curves->back().axis != axis ||
      allan::DeviationName(curves->back().curve.deviation) != est) {
    CurveRecord rec;
    rec.axis = axis;
    rec.curve.deviation = allan::ParseDeviation(est).value_or(allan::Deviation::kOadev);
    rec.curve.ci = allan::ParseCiMethod(s.Text(at + 2)).value_or(allan::CiMethod::kNone);
    rec.curve.tau0_s = s.Real(at + 3);
    rec.samples = s.Int(at + 4);
    // Rate samples in, phase points behind the curve: one more.
    rec.curve.n_phase = rec.samples > 0 ? rec.samples + 1 : 0;
    rec.valid_samples = s.Int(at + 5);
    rec.computed_utime = s.Int(at + 6);
    curves->push_back(std::move(rec));
  }
  allan::CurvePoint p;
  p.m = s.Int(at + 7);
  p.tau_s = s.Real(at + 8);
  p.dev = s.Real(at + 9);
  p.lo = s.Real(at + 10);
  p.hi = s.Real(at + 11);
  p.edf = s.Real(at + 12);
  p.n = s.Int(at + 13);
  p.stride = s.Int(at + 14);
  if (!s.IsNull(at + 15)) {
    p.alpha = static_cast<int>(s.Int(at + 15));
    p.alpha_inherited = s.Text(at + 16) == "nearest";
  }
  curves->back().curve.points.push_back(p);
}

}  // namespace

Result<std::optional<ResultRecord>> Archive::LoadResult(int64_t run_key) {
  auto r = db_->Prepare(std::string("SELECT ") + kResultColumns +
                        " FROM runs WHERE run_key = ? AND result_utime IS NOT NULL");
  if (!r.ok()) return r.status();
  r->Bind(1, run_key);
  auto row = r->Step();
  if (!row.ok()) return row.status();
  if (!*row) return std::optional<ResultRecord>();
  ResultRecord res = ResultFromRow(*r, 0);
  auto ax =
      db_->Prepare("SELECT invalid_samples FROM run_axes WHERE run_key = ? ORDER BY axis_index");
  if (!ax.ok()) return ax.status();
  ax->Bind(1, run_key);
  for (;;) {
    auto arow = ax->Step();
    if (!arow.ok()) return arow.status();
    if (!*arow) break;
    if (ax->IsNull(0)) {  // not known for every axis: not known
      res.axis_invalid_samples.clear();
      break;
    }
    res.axis_invalid_samples.push_back(ax->Int(0));
  }
  auto m = db_->Prepare(std::string("SELECT ") + kMeasurementColumns +
                        " FROM measurements WHERE run_key = ? ORDER BY axis, name");
  if (!m.ok()) return m.status();
  m->Bind(1, run_key);
  for (;;) {
    auto mrow = m->Step();
    if (!mrow.ok()) return mrow.status();
    if (!*mrow) break;
    res.measurements.push_back(MeasurementFromRow(*m, 0));
  }
  return std::optional<ResultRecord>(std::move(res));
}

Result<std::optional<int64_t>> Archive::FindRunKey(const std::string& run_id) {
  auto st = Cached(kFindRun, "SELECT run_key FROM runs WHERE run_id = ?");
  if (!st.ok()) return st.status();
  Stmt& s = **st;
  s.Bind(1, run_id);
  auto row = s.Step();
  if (!row.ok()) return row.status();
  std::optional<int64_t> key;
  if (*row) key = s.Int(0);
  s.Reset();
  return key;
}

Result<bool> Archive::IsFinalized(const std::string& run_id) {
  auto s = db_->Prepare("SELECT finalized_utime IS NOT NULL FROM runs WHERE run_id = ?");
  if (!s.ok()) return s.status();
  s->Bind(1, run_id);
  auto row = s->Step();
  if (!row.ok()) return row.status();
  return *row && s->Int(0) != 0;
}

Result<RunInfo> Archive::LoadRun(const std::string& run_id) {
  auto s = db_->Prepare(std::string("SELECT ") + kRunColumns + " FROM runs WHERE run_id = ?");
  if (!s.ok()) return s.status();
  s->Bind(1, run_id);
  auto row = s->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::NotFound("no run '" + run_id + "' in " + path());
  RunInfo r = RunFromRow(*s);
  const int64_t key = s->Int(0);
  auto ax = db_->Prepare("SELECT axis, kind FROM run_axes WHERE run_key = ? ORDER BY axis_index");
  if (!ax.ok()) return ax.status();
  ax->Bind(1, key);
  for (;;) {
    auto arow = ax->Step();
    if (!arow.ok()) return arow.status();
    if (!*arow) break;
    r.axes.push_back({ax->Text(0), ParseAxisKind(ax->Text(1))});
  }
  return r;
}

Result<std::vector<LotRunRecord>> Archive::LoadLotRuns(const std::string& lot, LotRunParts parts) {
  std::vector<LotRunRecord> runs;
  std::map<int64_t, size_t> at;  // run key -> index in runs
  {
    auto s = db_->Prepare(std::string("SELECT ") + kRunColumns + ", " + kResultColumnsNoRecord +
                          ", result_utime IS NOT NULL FROM runs WHERE lot = ?1 ORDER BY run_key");
    if (!s.ok()) return s.status();
    s->Bind(1, lot);
    for (;;) {
      auto row = s->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      LotRunRecord r;
      r.run_key = s->Int(0);
      r.info = RunFromRow(*s);
      constexpr int kResultAt = 23;
      if (s->Int(kResultAt + 10) != 0) r.result = ResultFromRow(*s, kResultAt);
      at[r.run_key] = runs.size();
      runs.push_back(std::move(r));
    }
  }
  if (runs.empty()) return runs;
  // Each query below reads the lot's rows in run-key order.
  auto each = [&](const std::string& sql, const std::function<void(LotRunRecord&, Stmt&)>& fn)
      -> Status {
    auto s = db_->Prepare(sql);
    if (!s.ok()) return s.status();
    s->Bind(1, lot);
    for (;;) {
      auto row = s->Step();
      if (!row.ok()) return row.status();
      if (!*row) return Status::Ok();
      auto it = at.find(s->Int(0));
      if (it != at.end()) fn(runs[it->second], *s);
    }
  };
  std::set<int64_t> invalid_unknown;
  IMUQUAL_RETURN_IF_ERROR(each(
      "SELECT a.run_key, a.axis, a.kind, a.invalid_samples FROM run_axes a JOIN runs r USING "
      "(run_key) WHERE r.lot = ?1 ORDER BY a.run_key, a.axis_index",
      [&](LotRunRecord& r, Stmt& s) {
        r.info.axes.push_back({s.Text(1), ParseAxisKind(s.Text(2))});
        if (!r.result) return;
        if (s.IsNull(3)) invalid_unknown.insert(r.run_key);
        r.result->axis_invalid_samples.push_back(s.IsNull(3) ? 0 : s.Int(3));
      }));
  for (int64_t key : invalid_unknown) runs[at[key]].result->axis_invalid_samples.clear();
  if (parts == LotRunParts::kRuns) return runs;
  IMUQUAL_RETURN_IF_ERROR(each(
      std::string("SELECT m.run_key, ") + kMeasurementColumns +
          " FROM measurements m JOIN runs r USING (run_key) WHERE r.lot = ?1 AND "
          "r.result_utime IS NOT NULL ORDER BY m.run_key, m.axis, m.name",
      [&](LotRunRecord& r, Stmt& s) {
        if (r.result) r.result->measurements.push_back(MeasurementFromRow(s, 1));
      }));
  IMUQUAL_RETURN_IF_ERROR(each(
      std::string("SELECT c.run_key, ") + kCurveColumns +
          " FROM curves c JOIN curve_points p USING (run_key, axis, estimator) JOIN runs r ON "
          "r.run_key = c.run_key WHERE r.lot = ?1 ORDER BY c.run_key, c.axis, c.estimator, p.m",
      [&](LotRunRecord& r, Stmt& s) { AddCurveRow(s, 1, &r.curves); }));
  return runs;
}

Result<int64_t> Archive::NextMissingSeq(int64_t run_key) {
  auto s = db_->Prepare(R"sql(
SELECT CASE WHEN NOT EXISTS (SELECT 1 FROM raw_chunks WHERE run_key = ?1 AND seq = 0) THEN 0
       ELSE (SELECT MIN(c.seq + 1) FROM raw_chunks c WHERE c.run_key = ?1 AND NOT EXISTS
               (SELECT 1 FROM raw_chunks d WHERE d.run_key = ?1 AND d.seq = c.seq + 1)) END)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, run_key);
  auto row = s->Step();
  if (!row.ok()) return row.status();
  return *row ? s->Int(0) : 0;
}

Result<std::vector<int64_t>> Archive::ArchivedSeqsFrom(int64_t run_key, int64_t from_seq) {
  auto s = db_->Prepare("SELECT seq FROM raw_chunks WHERE run_key = ? AND seq >= ? ORDER BY seq");
  if (!s.ok()) return s.status();
  s->Bind(1, run_key).Bind(2, from_seq);
  std::vector<int64_t> seqs;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    seqs.push_back(s->Int(0));
  }
  return seqs;
}

Status Archive::ForEachChunk(int64_t run_key, const std::function<Status(const ChunkRecord&)>& fn,
                             int64_t first_seq, int64_t last_seq) {
  auto s = db_->Prepare(
      "SELECT seq, first_sample, num_samples, host_utime, temperature_c, codec, data, sample_utime, "
      "crc32c FROM raw_chunks WHERE run_key = ? AND seq BETWEEN ? AND ? ORDER BY seq");
  if (!s.ok()) return s.status();
  s->Bind(1, run_key).Bind(2, first_seq).Bind(3, last_seq);
  ChunkRecord c;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return Status::Ok();
    c.seq = s->Int(0);
    c.first_sample = s->Int(1);
    c.num_samples = s->Int(2);
    c.host_utime = s->Int(3);
    c.temperature_c = s->IsNull(4) ? std::nullopt : std::optional<double>(s->Real(4));
    c.codec = static_cast<int>(s->Int(5));
    c.data = s->Blob(6);
    c.sample_utime = s->Int(7);
    // Damage at rest is never served (a resend) nor analysed: the chunk's
    // stored checksum must match what it holds.
    if (!s->IsNull(8) && static_cast<uint32_t>(s->Int(8)) != ChunkChecksum(c)) {
      return Status::Corruption("archived chunk seq " + std::to_string(c.seq) +
                                " does not match its checksum (damaged at rest; imuqual verify "
                                "lists every damaged row)");
    }
    IMUQUAL_RETURN_IF_ERROR(fn(c));
  }
}

Result<std::vector<GapRecord>> Archive::LoadGaps(int64_t run_key) {
  auto s = db_->Prepare(
      "SELECT first_seq, last_seq, first_sample, num_samples, reason, detected_utime "
      "FROM gaps WHERE run_key = ? ORDER BY first_seq");
  if (!s.ok()) return s.status();
  s->Bind(1, run_key);
  std::vector<GapRecord> gaps;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    GapRecord g;
    g.first_seq = s->Int(0);
    g.last_seq = s->Int(1);
    if (!s->IsNull(2)) g.first_sample = s->Int(2);
    if (!s->IsNull(3)) g.num_samples = s->Int(3);
    g.reason = s->Text(4);
    g.detected_utime = s->Int(5);
    gaps.push_back(g);
  }
  return gaps;
}

Result<std::vector<CurveRecord>> Archive::LoadCurves(int64_t run_key) {
  auto s = db_->Prepare(std::string("SELECT ") + kCurveColumns +
                        " FROM curves c JOIN curve_points p USING (run_key, axis, estimator) "
                        "WHERE c.run_key = ? ORDER BY c.axis, c.estimator, p.m");
  if (!s.ok()) return s.status();
  s->Bind(1, run_key);
  std::vector<CurveRecord> curves;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    AddCurveRow(*s, 0, &curves);
  }
  return curves;
}

}  // namespace imuqual::store
