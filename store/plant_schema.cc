#include "store/plant_schema.h"

#include <string>

namespace imuqual::store {
namespace {

constexpr int kPlantVersion = 2;

// Column for column the station schema (store/schema.cc at its current
// version): INTEGER -> bigint, REAL -> double precision, BLOB -> bytea, TEXT
// -> text in the "C" collation (bytewise, as SQLite orders: the same rows in
// the same order whatever the database's locale). A
// run is identified at the plant by its run id (which names its station);
// station_archive says which station archive shipped it.
constexpr char kPlantSchema[] = R"sql(
CREATE TABLE imuqual_plant (
  version        integer NOT NULL,
  created_utime  bigint NOT NULL
);
CREATE TABLE lots (
  lot               text COLLATE "C" PRIMARY KEY,
  first_seen_utime  bigint NOT NULL
);
CREATE TABLE units (
  serial            text COLLATE "C" PRIMARY KEY,
  first_seen_utime  bigint NOT NULL
);
-- One row per station archive that ships here: its identity is the hash of
-- its chain's first entry (unique to the file); shipped_entries is the
-- cursor (its chain entries 1..n are here, head_hash the n-th's hash).
CREATE TABLE station_archives (
  archive_id          text COLLATE "C" PRIMARY KEY,
  station             text COLLATE "C" NOT NULL,
  source              text COLLATE "C" NOT NULL,
  shipped_entries     bigint NOT NULL DEFAULT 0,
  head_hash           bytea,
  first_synced_utime  bigint NOT NULL,
  last_synced_utime   bigint NOT NULL
);
CREATE TABLE runs (
  run_key           bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  run_id            text COLLATE "C" NOT NULL UNIQUE,
  serial            text COLLATE "C" NOT NULL REFERENCES units(serial),
  lot               text COLLATE "C" NOT NULL REFERENCES lots(lot),
  station           text COLLATE "C" NOT NULL DEFAULT '',
  slot              text COLLATE "C" NOT NULL DEFAULT '',
  operator          text COLLATE "C" NOT NULL DEFAULT '',
  source            text COLLATE "C" NOT NULL DEFAULT '',
  software_version  text COLLATE "C" NOT NULL DEFAULT '',
  start_utime       bigint NOT NULL,
  end_utime         bigint,
  state             text COLLATE "C" NOT NULL CHECK (state IN ('running', 'complete', 'aborted', 'incomplete')),
  nominal_rate_hz   double precision NOT NULL,
  last_seq          bigint NOT NULL DEFAULT -1,
  samples_announced bigint NOT NULL DEFAULT 0,
  first_sample      bigint NOT NULL DEFAULT -1,
  end_sample        bigint NOT NULL DEFAULT -1,
  plan              bytea,
  plan_sha256       text COLLATE "C",
  truth             bytea,
  samples           bigint,
  gap_samples       bigint,
  invalid_samples   bigint,
  verdict           text COLLATE "C" CHECK (verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE', 'ABORTED', 'ERROR')),
  reasons           text COLLATE "C",
  record            bytea,
  result_utime      bigint,
  finalized_utime   bigint,
  end_reason        text COLLATE "C" NOT NULL DEFAULT '',
  results_crc32c    bigint,
  revision          bigint NOT NULL DEFAULT 0,
  result_last_seq   bigint,
  result_gap_batches bigint,
  bus_auth          text COLLATE "C",
  station_archive   text COLLATE "C" NOT NULL REFERENCES station_archives(archive_id)
);
CREATE INDEX runs_by_lot ON runs(lot, serial, start_utime);
CREATE INDEX runs_by_serial ON runs(serial, start_utime);
CREATE INDEX runs_by_station ON runs(station, start_utime);
-- Each unit's final run in each lot, found from the index alone.
CREATE INDEX runs_final ON runs(lot, serial)
  INCLUDE (verdict, start_utime, run_key, station, operator, run_id, plan_sha256);
CREATE TABLE run_axes (
  run_key     bigint NOT NULL REFERENCES runs(run_key),
  axis_index  bigint NOT NULL,
  axis        text COLLATE "C" NOT NULL,
  kind        text COLLATE "C" NOT NULL CHECK (kind IN ('gyro', 'accel')),
  unit        text COLLATE "C" NOT NULL,
  invalid_samples bigint,
  PRIMARY KEY (run_key, axis_index)
);
-- Partitioned by month (YYYYMM of the run's start, UTC): a month of raw
-- samples is one table, backed up, moved to slower storage or detached on
-- its own. A sync creates each month's partition as the first run of that
-- month arrives (when its role may; else the chunks wait in the default
-- partition, README "The plant archive"). month is the plant's own column:
-- left out of every digest, as run_key is.
CREATE TABLE raw_chunks (
  run_key       bigint NOT NULL REFERENCES runs(run_key),
  seq           bigint NOT NULL,
  first_sample  bigint NOT NULL,
  num_samples   bigint NOT NULL,
  host_utime    bigint NOT NULL,
  temperature_c double precision,
  codec         bigint NOT NULL,
  data          bytea NOT NULL,
  sample_utime  bigint NOT NULL DEFAULT 0,
  crc32c        bigint,
  digest        bytea,
  month         integer NOT NULL,
  PRIMARY KEY (run_key, seq, month)
) PARTITION BY RANGE (month);
CREATE TABLE raw_chunks_default PARTITION OF raw_chunks DEFAULT;
-- Chunks are zstd frames already: stored out of line as they are, not
-- compressed again (each partition inherits it).
ALTER TABLE raw_chunks ALTER COLUMN data SET STORAGE EXTERNAL;
CREATE TABLE gaps (
  run_key        bigint NOT NULL REFERENCES runs(run_key),
  first_seq      bigint NOT NULL,
  last_seq       bigint NOT NULL,
  first_sample   bigint,
  num_samples    bigint,
  reason         text COLLATE "C" NOT NULL,
  detected_utime bigint NOT NULL,
  PRIMARY KEY (run_key, first_seq)
);
CREATE TABLE curves (
  run_key        bigint NOT NULL REFERENCES runs(run_key),
  axis           text COLLATE "C" NOT NULL,
  estimator      text COLLATE "C" NOT NULL,
  ci_method      text COLLATE "C" NOT NULL,
  tau0_s         double precision NOT NULL,
  samples        bigint NOT NULL,
  valid_samples  bigint NOT NULL,
  computed_utime bigint NOT NULL,
  PRIMARY KEY (run_key, axis, estimator)
);
CREATE TABLE curve_points (
  run_key    bigint NOT NULL,
  axis       text COLLATE "C" NOT NULL,
  estimator  text COLLATE "C" NOT NULL,
  m          bigint NOT NULL,
  tau_s      double precision NOT NULL,
  dev        double precision NOT NULL,
  lo         double precision,
  hi         double precision,
  edf        double precision,
  n_terms    bigint NOT NULL,
  stride     bigint NOT NULL,
  alpha      bigint,
  alpha_from text COLLATE "C" CHECK (alpha_from IN ('identified', 'nearest')),
  PRIMARY KEY (run_key, axis, estimator, m),
  FOREIGN KEY (run_key, axis, estimator) REFERENCES curves(run_key, axis, estimator)
);
CREATE TABLE measurements (
  run_key        bigint NOT NULL REFERENCES runs(run_key),
  axis           text COLLATE "C" NOT NULL,
  name           text COLLATE "C" NOT NULL,
  value          double precision,
  uncertainty    double precision,
  unit           text COLLATE "C" NOT NULL,
  low            double precision,
  high           double precision,
  marginal_low   double precision,
  marginal_high  double precision,
  outcome        text COLLATE "C" CHECK (outcome IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')),
  note           text COLLATE "C" NOT NULL DEFAULT '',
  qualifier      text COLLATE "C" CHECK (qualifier IN ('upper_bound', 'minimum_not_resolved', 'not_measurable', 'model_inadequate')),
  uncertainty_method text COLLATE "C",
  decision_rule  text COLLATE "C" CHECK (decision_rule IN ('simple', 'guarded', 'guarded_acceptance', 'guarded_rejection')),
  guard_band     double precision,
  PRIMARY KEY (run_key, axis, name)
);
-- A control chart's values (imuqual chart: one measurement of one axis over
-- the archive) read from the index alone.
CREATE INDEX measurements_values ON measurements(name, axis, run_key)
  INCLUDE (value, unit, low, high);
CREATE TABLE superseded_judgements (
  run_key           bigint NOT NULL REFERENCES runs(run_key),
  revision          bigint NOT NULL,
  verdict           text COLLATE "C",
  reasons           text COLLATE "C",
  samples           bigint,
  gap_samples       bigint,
  record            bytea,
  result_utime      bigint,
  superseded_utime  bigint NOT NULL,
  cause             text COLLATE "C" NOT NULL,
  PRIMARY KEY (run_key, revision)
);
-- Each station archive's chain (store/chain.h), entry for entry: the signed
-- record of every finalised run and every judgement round opened again.
CREATE TABLE archive_chain (
  archive_id     text COLLATE "C" NOT NULL REFERENCES station_archives(archive_id),
  entry          bigint NOT NULL CHECK (entry >= 1),
  kind           text COLLATE "C" NOT NULL CHECK (kind IN ('finalized', 'reopened', 'migrated')),
  run_id         text COLLATE "C" NOT NULL,
  revision       bigint NOT NULL,
  record         bytea NOT NULL,
  created_utime  bigint NOT NULL,
  key_id         text COLLATE "C" NOT NULL DEFAULT '',
  signature      bytea,
  prev_hash      bytea NOT NULL,
  entry_hash     bytea NOT NULL,
  PRIMARY KEY (archive_id, entry)
);
CREATE INDEX archive_chain_by_run ON archive_chain(run_id, entry);

CREATE VIEW axis_results AS
SELECT r.lot, r.serial, r.run_id, r.run_key, r.start_utime, r.state, ra.axis_index, ra.axis, ra.kind,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.value END) AS random_walk,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.unit END) AS random_walk_unit,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.value END) AS bias_instability,
       MAX(CASE WHEN m.name = 'bias_instability_ieee' THEN m.value END) AS bias_instability_ieee,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.unit END) AS bias_instability_unit,
       MAX(CASE WHEN m.name = 'tau_at_minimum' THEN m.value END) AS tau_min_s,
       MAX(CASE WHEN m.name = 'rate_random_walk' THEN m.value END) AS rate_random_walk,
       r.gap_samples, ra.invalid_samples, r.samples,
       CASE WHEN bool_or(m.outcome = 'FAIL') THEN 'FAIL'
            WHEN bool_or(m.outcome = 'INCONCLUSIVE') THEN 'INCONCLUSIVE'
            WHEN bool_or(m.outcome = 'MARGINAL') THEN 'MARGINAL'
            WHEN bool_or(m.outcome = 'PASS') THEN 'PASS' END AS axis_verdict,
       r.verdict AS run_verdict,
       r.serial AS unit
FROM runs r
JOIN run_axes ra ON ra.run_key = r.run_key
LEFT JOIN measurements m ON m.run_key = r.run_key AND m.axis = ra.axis
GROUP BY r.run_key, ra.run_key, ra.axis_index;

CREATE VIEW final_runs AS
SELECT r.* FROM runs r
WHERE r.run_key = (SELECT x.run_key FROM runs x
                   WHERE x.lot = r.lot AND x.serial = r.serial
                   ORDER BY COALESCE(x.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE'), false) DESC,
                            x.start_utime DESC, x.run_key DESC
                   LIMIT 1);

CREATE VIEW latest_runs AS
SELECT r.* FROM runs r
WHERE r.start_utime = (SELECT MAX(x.start_utime) FROM runs x
                       WHERE x.lot = r.lot AND x.serial = r.serial);

CREATE VIEW lot_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome,
       m.uncertainty, m.qualifier, m.uncertainty_method, m.decision_rule, m.guard_band
FROM final_runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis
WHERE r.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE');

CREATE VIEW all_runs_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome,
       m.uncertainty, m.qualifier, m.uncertainty_method, m.decision_rule, m.guard_band
FROM runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;

CREATE VIEW lot_overview AS
SELECT f.lot, (SELECT COUNT(*) FROM runs x WHERE x.lot = f.lot) AS runs, COUNT(*) AS units,
       COUNT(*) FILTER (WHERE f.verdict = 'PASS') AS pass,
       COUNT(*) FILTER (WHERE f.verdict = 'MARGINAL') AS marginal,
       COUNT(*) FILTER (WHERE f.verdict = 'FAIL') AS fail,
       COUNT(*) FILTER (WHERE f.verdict IS NULL) AS unjudged,
       (COUNT(*) FILTER (WHERE f.verdict IN ('PASS', 'MARGINAL')))::double precision
           / NULLIF(COUNT(*) FILTER (WHERE f.verdict IN ('PASS', 'MARGINAL', 'FAIL')), 0) AS yield,
       (SELECT MIN(x.start_utime) FROM runs x WHERE x.lot = f.lot) AS first_start_utime,
       (SELECT MAX(x.start_utime) FROM runs x WHERE x.lot = f.lot) AS last_start_utime,
       COUNT(*) FILTER (WHERE f.verdict = 'INCONCLUSIVE') AS inconclusive,
       COUNT(*) FILTER (WHERE f.verdict = 'ABORTED') AS aborted,
       COUNT(*) FILTER (WHERE f.verdict = 'ERROR') AS error,
       (COUNT(*) FILTER (WHERE f.verdict IN ('PASS', 'MARGINAL')))::double precision
           / NULLIF(COUNT(*) FILTER (WHERE f.verdict IN ('PASS', 'MARGINAL', 'FAIL')), 0) AS final_yield,
       (COUNT(*) FILTER (WHERE f.first_verdict IN ('PASS', 'MARGINAL')))::double precision
           / NULLIF(COUNT(*) FILTER (WHERE f.first_verdict IS NOT NULL), 0) AS first_pass_yield,
       (SELECT COUNT(*) FROM runs x WHERE x.lot = f.lot) - COUNT(*) AS retests,
       COUNT(*) FILTER (WHERE f.verdict = 'INCONCLUSIVE') AS retest_candidates
FROM (SELECT l.lot, l.verdict,
             (SELECT y.verdict FROM runs y
              WHERE y.lot = l.lot AND y.serial = l.serial
                AND y.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
              ORDER BY y.start_utime, y.run_key LIMIT 1) AS first_verdict
      FROM final_runs l) f
GROUP BY f.lot;

CREATE VIEW retest_reasons AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, r.state, r.verdict, r.reasons,
       (SELECT x.run_id FROM runs x
        WHERE x.lot = r.lot AND x.serial = r.serial
          AND (x.start_utime, x.run_key) > (r.start_utime, r.run_key)
        ORDER BY x.start_utime, x.run_key LIMIT 1) AS next_run_id
FROM runs r
WHERE EXISTS (SELECT 1 FROM runs x
              WHERE x.lot = r.lot AND x.serial = r.serial
                AND (x.start_utime, x.run_key) > (r.start_utime, r.run_key));

CREATE VIEW run_archive AS
SELECT r.run_id, r.lot, r.serial, r.state, r.last_seq,
       (SELECT COUNT(*) FROM raw_chunks c WHERE c.run_key = r.run_key) AS chunks,
       (SELECT COALESCE(SUM(num_samples), 0) FROM raw_chunks c WHERE c.run_key = r.run_key) AS samples_archived,
       (SELECT COUNT(*) FROM gaps g WHERE g.run_key = r.run_key) AS gap_ranges,
       (SELECT COALESCE(SUM(GREATEST(num_samples, 0)), 0) FROM gaps g WHERE g.run_key = r.run_key) AS gap_samples,
       r.serial AS unit
FROM runs r;
)sql";

// Schema 2: which station archive holds each station id (the first to ship
// a run of it). A second archive claiming the id is refused, unless it is
// named as that station's new archive (a rebuilt station): then the claim
// moves, and the row keeps the archive it moved from and who moved it.
constexpr char kStationIds[] = R"sql(
CREATE TABLE station_ids (
  station           text COLLATE "C" PRIMARY KEY,
  archive_id        text COLLATE "C" NOT NULL REFERENCES station_archives(archive_id),
  claimed_utime     bigint NOT NULL,
  previous_archive  text COLLATE "C" REFERENCES station_archives(archive_id),
  claimed_by        text COLLATE "C" NOT NULL DEFAULT ''
);
)sql";

// From schema 1: each station id to the archive of its latest run.
constexpr char kStationIdsFromRuns[] = R"sql(
INSERT INTO station_ids (station, archive_id, claimed_utime, claimed_by)
SELECT DISTINCT ON (station) station, station_archive,
       (extract(epoch FROM clock_timestamp()) * 1000000)::bigint, 'plant schema 2 (from runs)'
FROM runs ORDER BY station, start_utime DESC;
DROP INDEX IF EXISTS measurements_by_name;
CREATE INDEX IF NOT EXISTS measurements_values ON measurements(name, axis, run_key)
  INCLUDE (value, unit, low, high);
CREATE INDEX IF NOT EXISTS runs_final ON runs(lot, serial)
  INCLUDE (verdict, start_utime, run_key, station, operator, run_id, plan_sha256);
UPDATE imuqual_plant SET version = 2;
)sql";

Result<bool> HasTable(Db& db, const char* name) {
  auto s = db.Prepare(
      "SELECT count(*) FROM pg_catalog.pg_tables WHERE schemaname = current_schema() AND "
      "tablename = ?1");
  if (!s.ok()) return s.status();
  s->Bind(1, name);
  auto row = s->Step();
  if (!row.ok()) return row.status();
  return *row && s->Int(0) > 0;
}

Status CheckVersion(Db& db) {
  auto v = db.QueryInt("SELECT version FROM imuqual_plant");
  if (!v.ok()) {
    return Status::Corruption(db.path() + " is not an imuqual plant archive (" +
                              v.status().message() + ")");
  }
  if (*v > kPlantVersion) {
    return Status::InvalidArgument(db.path() + " holds plant schema " + std::to_string(*v) +
                                   ", newer than this build's " + std::to_string(kPlantVersion) +
                                   ": use a newer imuqual");
  }
  if (*v < kPlantVersion) {
    return Status::InvalidArgument(db.path() + " holds plant schema " + std::to_string(*v) +
                                   "; this build reads " + std::to_string(kPlantVersion) +
                                   " (a sync or store --sync-to upgrades it)");
  }
  return Status::Ok();
}

// Upgrades schema 1 to 2 in one transaction (two clients at once: the
// version row is locked, the second finds 2).
Status Upgrade(Db& db) {
  IMUQUAL_RETURN_IF_ERROR(db.Exec("BEGIN"));
  auto v = db.QueryInt("SELECT version FROM imuqual_plant FOR UPDATE");
  Status st = v.ok() ? Status::Ok() : v.status();
  if (st.ok() && *v == 1) {
    st = db.Exec(kStationIds);
    if (st.ok()) st = db.Exec(kStationIdsFromRuns);
  }
  if (!st.ok()) {
    (void)db.Exec("ROLLBACK");
    return st;
  }
  return db.Exec("COMMIT");
}

}  // namespace

int PlantSchemaVersion() { return kPlantVersion; }

Status MigratePlant(Db& db) {
  auto has = HasTable(db, "imuqual_plant");
  if (!has.ok()) return has.status();
  if (*has) {
    auto v = db.QueryInt("SELECT version FROM imuqual_plant");
    if (v.ok() && *v < kPlantVersion) IMUQUAL_RETURN_IF_ERROR(Upgrade(db));
    return CheckVersion(db);
  }
  auto tables = db.QueryInt(
      "SELECT count(*) FROM pg_catalog.pg_tables WHERE schemaname = current_schema()");
  if (!tables.ok()) return tables.status();
  if (*tables > 0) {
    return Status::InvalidArgument(db.path() + " holds other tables: not an imuqual plant archive "
                                   "(give an empty database)");
  }
  IMUQUAL_RETURN_IF_ERROR(db.Exec("BEGIN"));
  Status st = db.Exec(kPlantSchema);
  if (st.ok()) st = db.Exec(kStationIds);
  if (st.ok()) {
    st = db.Exec("INSERT INTO imuqual_plant(version, created_utime) VALUES (" +
                 std::to_string(kPlantVersion) +
                 ", (extract(epoch FROM clock_timestamp()) * 1000000)::bigint)");
  }
  if (!st.ok()) {
    (void)db.Exec("ROLLBACK");
    // Two clients creating it at once: the other one's schema is there now.
    auto again = HasTable(db, "imuqual_plant");
    if (again.ok() && *again) return CheckVersion(db);
    return st;
  }
  return db.Exec("COMMIT");
}

Status CheckPlantReadable(Db& db) { return CheckVersion(db); }

}  // namespace imuqual::store
