// The SQLite archive of a station: runs, raw chunks, gaps, curves and
// results (schema: store/SCHEMA.md). One Archive is one connection; a
// read-write Archive belongs to one writer thread, read-only ones (queries,
// re-analysis) may be opened by any number of readers at once (WAL: readers
// never block the writer).
#ifndef IMUQUAL_STORE_ARCHIVE_H_
#define IMUQUAL_STORE_ARCHIVE_H_

#include <climits>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "analyze/allan/curve.h"
#include "common/keys.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"
#include "store/sqlite.h"

namespace imuqual::store {

struct AxisInfo {
  std::string name;
  pb::AxisKind kind = pb::GYRO;
};

// What a run_t announces.
struct RunInfo {
  std::string run_id;
  std::string serial;
  std::string lot;
  std::string station;
  std::string slot;
  std::string operator_name;
  std::string source;
  std::string software_version;
  int64_t start_utime = 0;
  double nominal_rate_hz = 0;
  std::vector<AxisInfo> axes;
  std::string plan;         // serialized pb::TestPlan
  std::string plan_sha256;
  std::string truth;        // serialized pb::SimTruth, "" for real units
  std::string state = "running";  // running / complete / aborted / incomplete
  int64_t last_seq = -1;
  int64_t samples_announced = 0;
  int64_t first_sample = -1;  // device counter range announced by acquire
  int64_t end_sample = -1;
  std::optional<int64_t> end_utime;
  std::string end_reason;     // why an aborted or incomplete run ended early
  // The judgement round (run_t.revision), kept by the store: read from the
  // archive, never written by UpsertRun (SupersedeJudgement raises it).
  int revision = 0;
  // What authenticated the messages the run was archived from
  // (BusSecurity::Describe of the store's bus); "" unknown (archived before
  // schema 7). UpsertRun keeps the first and appends a different one ("...;
  // then ...": a store restarted with other keys or choices mid-run).
  std::string bus_auth;
};

struct ChunkRecord {
  int64_t seq = 0;
  int64_t first_sample = 0;
  int64_t num_samples = 0;
  int64_t host_utime = 0;
  std::optional<double> temperature_c;
  int codec = 0;
  std::vector<uint8_t> data;
  int64_t sample_utime = 0;  // arrival of the first sample (rate_batch_t.sample_utime)
};

struct GapRecord {
  int64_t first_seq = 0;
  int64_t last_seq = 0;
  std::optional<int64_t> first_sample;
  std::optional<int64_t> num_samples;
  // "seq": batches that never arrived; "store_write": batches that arrived
  // but the store could not write (full disk) and nobody could resend;
  // "counter": the device counter jumped
  // forward (num_samples missing); "counter_backwards": it went back
  // (num_samples negative: the overlap).
  std::string reason;
  int64_t detected_utime = 0;
};

struct CurveRecord {
  std::string axis;
  allan::Curve curve;
  int64_t samples = 0;
  int64_t valid_samples = 0;
  int64_t computed_utime = 0;
};

struct ResultRecord {
  std::string verdict;  // "PASS", "MARGINAL", "FAIL" or "" (not judged)
  std::vector<std::string> reasons;
  int64_t samples = 0;
  int64_t gap_samples = 0;
  int64_t invalid_samples = 0;                // over all axes
  std::vector<int64_t> axis_invalid_samples;  // per axis, run_axes order (empty: unknown)
  std::vector<pb::Measurement> measurements;
  std::string record;   // serialized pb::RunRecord
  int64_t result_utime = 0;
  // What the judgement covered: the run's round, batches 0..last_seq, of
  // which gap_batches never arrived (nullopt: not known, archived before
  // schema 4).
  int revision = 0;
  std::optional<int64_t> last_seq;
  std::optional<int64_t> gap_batches;
};

// How much of each run Archive::LoadLotRuns reads.
enum class LotRunParts {
  kRuns,  // the run, its axes and its result without measurements (two queries)
  kAll,   // and the result's measurements and the curves (four)
};

// One run of a lot with what a lot report shows of it (Archive::LoadLotRuns).
struct LotRunRecord {
  int64_t run_key = 0;
  RunInfo info;
  // As LoadResult, but its record left empty (and its measurements, with
  // LotRunParts::kRuns).
  std::optional<ResultRecord> result;
  std::vector<CurveRecord> curves;     // as LoadCurves
};

class Archive {
 public:
  enum class Mode { kWrite, kRead };
  // A station's SQLite file, or a plant archive at a postgresql:// URL
  // (kWrite creates its schema in an empty database; the plant is written
  // by store/plant_sync.h, read by every query of store/query.h).
  // kWrite creates/migrates the file and sets WAL + synchronous=NORMAL.
  // kRead requires an existing archive at the current schema. Errors name
  // the file and what is wrong with it (missing, not SQLite, not imuqual,
  // newer schema, read-only directory, ...).
  static Result<std::unique_ptr<Archive>> Open(const std::string& path, Mode mode);
  ~Archive();

  Status Begin();
  Status Commit();
  Status Rollback();

  // --- writes (kWrite) ---
  // Inserts the run (and its lot, unit and axes) or updates its state,
  // last_seq and counts. A finished run (complete/aborted) never goes back
  // to running. Returns the run's key.
  Result<int64_t> UpsertRun(const RunInfo& run);
  // Idempotent on (run, seq): a duplicate or resent chunk changes nothing.
  // *inserted says whether the row is new. The row carries its CRC-32C and
  // its BLAKE2b-256 digest (store/canonical.h ChunkDigest), computed here.
  Status InsertChunk(int64_t run_key, const ChunkRecord& chunk, bool* inserted);
  // Replaces the run's gap rows with the holes in seq 0..last_seq and the
  // jumps in the device counter between consecutive archived chunks.
  Status RecomputeGaps(int64_t run_key, int64_t last_seq, int64_t now_utime);
  // Records a hole as soon as it is given up (RecomputeGaps redoes them all
  // at the end), so a restarted store does not wait for it again.
  // Gives the "seq" gaps of a run that overlap first_seq..last_seq another
  // reason (e.g. "store_write": arrived but never written).
  Status LabelSeqGaps(int64_t run_key, int64_t first_seq, int64_t last_seq,
                      const std::string& reason);
  Status InsertGap(int64_t run_key, const GapRecord& gap);
  Status PutCurve(int64_t run_key, const CurveRecord& curve);
  Status PutResult(int64_t run_key, const ResultRecord& result);
  // The run is archived for good: every batch is in or recorded as a gap,
  // and its final result is stored. Appends the run's entry to the chain
  // (store/chain.h), its record as the archive holds it now, signed with the
  // signing key if one is set; atomic (a savepoint), in the caller's
  // transaction if there is one.
  Status MarkFinalized(int64_t run_key, int64_t utime);
  // Opens the run's judgement again (in the caller's transaction): the
  // archived judgement, if any, moves to superseded_judgements with `cause`;
  // its result, measurements and curves are removed; the run is no longer
  // finalized and its revision is raised; a "reopened" chain entry records
  // (and signs) the superseded judgement. Returns the new revision.
  Result<int> SupersedeJudgement(int64_t run_key, int64_t utime, const std::string& cause);

  // --- reads ---
  Result<std::optional<int64_t>> FindRunKey(const std::string& run_id);
  // Whether the run exists and has been finalized.
  Result<bool> IsFinalized(const std::string& run_id);
  Result<RunInfo> LoadRun(const std::string& run_id);
  // Every run of the lot, in run-key order, each as LoadRun, LoadResult and
  // LoadCurves read it (but the result's signed record, left empty), in
  // four queries however many runs (a lot report's units on a plant across
  // the network).
  // `parts` says how much (a lot page's first view needs no measurement).
  Result<std::vector<LotRunRecord>> LoadLotRuns(const std::string& lot,
                                                LotRunParts parts = LotRunParts::kAll);
  // The smallest seq not archived for the run (0 if none).
  Result<int64_t> NextMissingSeq(int64_t run_key);
  // Seqs archived at or above `from_seq`, ascending.
  Result<std::vector<int64_t>> ArchivedSeqsFrom(int64_t run_key, int64_t from_seq);
  // Every chunk with first_seq <= seq <= last_seq, in seq order. Corruption
  // (naming the seq) at the first chunk that does not match its stored
  // checksum: damage at rest is neither resent nor analysed.
  Status ForEachChunk(int64_t run_key, const std::function<Status(const ChunkRecord&)>& fn,
                      int64_t first_seq = 0, int64_t last_seq = INT64_MAX);
  // Runs not yet finalized (a store that stopped mid-run resumes them).
  Result<std::vector<std::string>> UnfinishedRunIds();
  // The stored final result, if any.
  Result<std::optional<ResultRecord>> LoadResult(int64_t run_key);
  Result<std::vector<GapRecord>> LoadGaps(int64_t run_key);
  Result<std::vector<CurveRecord>> LoadCurves(int64_t run_key);

  // Signs the chain entries this connection appends from now on (a key of
  // role "store"; InvalidArgument otherwise). Without one they are unsigned.
  Status SetSigningKey(const SigningKey& key);

  Db& db() { return *db_; }
  bool postgres() const { return db_->postgres(); }
  const std::string& path() const { return db_->path(); }

 private:
  explicit Archive(std::unique_ptr<Db> db) : db_(std::move(db)) {}
  Result<Stmt*> Cached(int id, const char* sql);

  std::unique_ptr<Db> db_;
  std::vector<std::unique_ptr<Stmt>> cache_;
  std::optional<SigningKey> signing_key_;
  // Runs whose result rows changed in the open transaction: their results
  // checksum is computed once, at Commit() (SealResultsOf).
  std::set<int64_t> unsealed_;
  // Seals now outside a transaction, else at Commit().
  Status SealResultsOf(int64_t run_key);
};

const char* AxisKindName(pb::AxisKind kind);  // "gyro" / "accel"
pb::AxisKind ParseAxisKind(const std::string& name);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_ARCHIVE_H_
