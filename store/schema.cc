#include "store/schema.h"

#include <algorithm>
#include <string>
#include <vector>

#include "common/clock.h"
#include "store/chain.h"
#include "store/checksums.h"

namespace imuqual::store {
namespace {

// Migration i takes the schema from version i to version i + 1.
const std::vector<std::string>& Migrations() {
  static const std::vector<std::string> kMigrations = {
      // 0 -> 1: the initial schema.
      R"sql(
CREATE TABLE lots (
  lot               TEXT PRIMARY KEY,
  first_seen_utime  INTEGER NOT NULL
);
CREATE TABLE units (
  serial            TEXT PRIMARY KEY,
  first_seen_utime  INTEGER NOT NULL
);
CREATE TABLE runs (
  run_key           INTEGER PRIMARY KEY,
  run_id            TEXT NOT NULL UNIQUE,
  serial            TEXT NOT NULL REFERENCES units(serial),
  lot               TEXT NOT NULL REFERENCES lots(lot),
  station           TEXT NOT NULL DEFAULT '',
  slot              TEXT NOT NULL DEFAULT '',
  operator          TEXT NOT NULL DEFAULT '',
  source            TEXT NOT NULL DEFAULT '',
  software_version  TEXT NOT NULL DEFAULT '',
  start_utime       INTEGER NOT NULL,
  end_utime         INTEGER,
  state             TEXT NOT NULL CHECK (state IN ('running', 'complete', 'aborted', 'incomplete')),
  nominal_rate_hz   REAL NOT NULL,
  last_seq          INTEGER NOT NULL DEFAULT -1,
  samples_announced INTEGER NOT NULL DEFAULT 0,
  first_sample      INTEGER NOT NULL DEFAULT -1,
  end_sample        INTEGER NOT NULL DEFAULT -1,
  plan              BLOB,
  plan_sha256       TEXT,
  truth             BLOB,
  samples           INTEGER,
  gap_samples       INTEGER,
  invalid_samples   INTEGER,
  verdict           TEXT CHECK (verdict IN ('PASS', 'MARGINAL', 'FAIL')),
  reasons           TEXT,
  record            BLOB,
  result_utime      INTEGER,
  finalized_utime   INTEGER,
  end_reason        TEXT NOT NULL DEFAULT ''
);
CREATE INDEX runs_by_lot ON runs(lot, serial, start_utime);
CREATE INDEX runs_by_serial ON runs(serial, start_utime);

CREATE TABLE run_axes (
  run_key     INTEGER NOT NULL REFERENCES runs(run_key),
  axis_index  INTEGER NOT NULL,
  axis        TEXT NOT NULL,
  kind        TEXT NOT NULL CHECK (kind IN ('gyro', 'accel')),
  unit        TEXT NOT NULL,
  PRIMARY KEY (run_key, axis_index)
) WITHOUT ROWID;

CREATE TABLE raw_chunks (
  run_key       INTEGER NOT NULL REFERENCES runs(run_key),
  seq           INTEGER NOT NULL,
  first_sample  INTEGER NOT NULL,
  num_samples   INTEGER NOT NULL,
  host_utime    INTEGER NOT NULL,
  temperature_c REAL,
  codec         INTEGER NOT NULL,
  data          BLOB NOT NULL,
  sample_utime  INTEGER NOT NULL DEFAULT 0,
  PRIMARY KEY (run_key, seq)
);

CREATE TABLE gaps (
  run_key        INTEGER NOT NULL REFERENCES runs(run_key),
  first_seq      INTEGER NOT NULL,
  last_seq       INTEGER NOT NULL,
  first_sample   INTEGER,
  num_samples    INTEGER,
  reason         TEXT NOT NULL,
  detected_utime INTEGER NOT NULL,
  PRIMARY KEY (run_key, first_seq)
);

CREATE TABLE curves (
  run_key        INTEGER NOT NULL REFERENCES runs(run_key),
  axis           TEXT NOT NULL,
  estimator      TEXT NOT NULL,
  ci_method      TEXT NOT NULL,
  tau0_s         REAL NOT NULL,
  samples        INTEGER NOT NULL,
  valid_samples  INTEGER NOT NULL,
  computed_utime INTEGER NOT NULL,
  PRIMARY KEY (run_key, axis, estimator)
);
CREATE TABLE curve_points (
  run_key    INTEGER NOT NULL,
  axis       TEXT NOT NULL,
  estimator  TEXT NOT NULL,
  m          INTEGER NOT NULL,
  tau_s      REAL NOT NULL,
  dev        REAL NOT NULL,
  lo         REAL,
  hi         REAL,
  edf        REAL,
  n_terms    INTEGER NOT NULL,
  stride     INTEGER NOT NULL,
  PRIMARY KEY (run_key, axis, estimator, m),
  FOREIGN KEY (run_key, axis, estimator) REFERENCES curves(run_key, axis, estimator)
) WITHOUT ROWID;

CREATE TABLE measurements (
  run_key        INTEGER NOT NULL REFERENCES runs(run_key),
  axis           TEXT NOT NULL,
  name           TEXT NOT NULL,
  value          REAL,
  uncertainty    REAL,
  unit           TEXT NOT NULL,
  low            REAL,
  high           REAL,
  marginal_low   REAL,
  marginal_high  REAL,
  outcome        TEXT CHECK (outcome IN ('PASS', 'MARGINAL', 'FAIL')),
  note           TEXT NOT NULL DEFAULT '',
  PRIMARY KEY (run_key, axis, name)
) WITHOUT ROWID;
CREATE INDEX measurements_by_name ON measurements(name, axis);

-- One row per run and axis with the headline figures.
CREATE VIEW axis_results AS
SELECT r.lot, r.serial AS unit, r.run_id, r.run_key, r.start_utime, r.state, ra.axis_index, ra.axis, ra.kind,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.value END) AS random_walk,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.unit END) AS random_walk_unit,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.value END) AS bias_instability,
       MAX(CASE WHEN m.name = 'bias_instability_ieee' THEN m.value END) AS bias_instability_ieee,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.unit END) AS bias_instability_unit,
       MAX(CASE WHEN m.name = 'tau_at_minimum' THEN m.value END) AS tau_min_s,
       MAX(CASE WHEN m.name = 'rate_random_walk' THEN m.value END) AS rate_random_walk,
       r.gap_samples, r.invalid_samples, r.samples,
       CASE WHEN SUM(m.outcome = 'FAIL') > 0 THEN 'FAIL'
            WHEN SUM(m.outcome = 'MARGINAL') > 0 THEN 'MARGINAL'
            WHEN SUM(m.outcome = 'PASS') > 0 THEN 'PASS' END AS axis_verdict,
       r.verdict AS run_verdict
FROM runs r
JOIN run_axes ra ON ra.run_key = r.run_key
LEFT JOIN measurements m ON m.run_key = r.run_key AND m.axis = ra.axis
GROUP BY r.lot, r.run_key, ra.axis_index;  -- lot first: WHERE lot = ? reaches the index

-- Every judged value with its run's lot and unit, for generic lot queries.
CREATE VIEW lot_measurements AS
SELECT r.lot, r.serial AS unit, r.run_id, r.start_utime, m.axis,
       COALESCE(ra.kind, '') AS kind, m.name, m.value, m.unit, m.low, m.high,
       m.marginal_low, m.marginal_high, m.outcome
FROM measurements m
JOIN runs r ON r.run_key = m.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;

-- Each unit's latest run in each lot (a retested unit counts once, as retested).
CREATE VIEW latest_runs AS
SELECT r.* FROM runs r
WHERE r.start_utime = (SELECT MAX(x.start_utime) FROM runs x
                       WHERE x.lot = r.lot AND x.serial = r.serial);

-- Per lot: runs, units and their verdicts (latest run per unit) and yield.
CREATE VIEW lot_overview AS
SELECT l.lot, (SELECT COUNT(*) FROM runs x WHERE x.lot = l.lot) AS runs, COUNT(*) AS units,
       SUM(l.verdict = 'PASS') AS pass, SUM(l.verdict = 'MARGINAL') AS marginal,
       SUM(l.verdict = 'FAIL') AS fail, SUM(l.verdict IS NULL) AS unjudged,
       1.0 * SUM(l.verdict IN ('PASS', 'MARGINAL')) / NULLIF(SUM(l.verdict IS NOT NULL), 0) AS yield,
       MIN(l.start_utime) AS first_start_utime, MAX(l.start_utime) AS last_start_utime
FROM latest_runs l GROUP BY l.lot;

-- Per lot, measurement and axis kind: count, mean, sd, min, max, pass rate.
CREATE VIEW lot_statistics AS
SELECT lot, kind, name, unit, COUNT(value) AS n, AVG(value) AS mean,
       SQRT(MAX(AVG(value * value) - AVG(value) * AVG(value), 0) * COUNT(value) / NULLIF(COUNT(value) - 1, 0)) AS sd,
       MIN(value) AS min, MAX(value) AS max,
       1.0 * SUM(outcome IN ('PASS', 'MARGINAL')) / NULLIF(SUM(outcome IS NOT NULL), 0) AS pass_rate
FROM lot_measurements GROUP BY lot, kind, name, unit;

-- Archive completeness per run: chunks and samples held, gaps recorded.
CREATE VIEW run_archive AS
SELECT r.run_id, r.lot, r.serial AS unit, r.state, r.last_seq,
       (SELECT COUNT(*) FROM raw_chunks c WHERE c.run_key = r.run_key) AS chunks,
       (SELECT COALESCE(SUM(num_samples), 0) FROM raw_chunks c WHERE c.run_key = r.run_key) AS samples_archived,
       (SELECT COUNT(*) FROM gaps g WHERE g.run_key = r.run_key) AS gap_ranges,
       (SELECT COALESCE(SUM(MAX(num_samples, 0)), 0) FROM gaps g WHERE g.run_key = r.run_key) AS gap_samples
FROM runs r;
)sql",
      // 1 -> 2: each axis its own count of invalid samples (axis_results
      // showed the run's total, summed over the axes, on every axis). Runs
      // archived before keep their final curves, whose valid_samples are the
      // axis's own: samples - valid_samples - gap samples is that count.
      R"sql(
ALTER TABLE run_axes ADD COLUMN invalid_samples INTEGER;
UPDATE run_axes SET invalid_samples = (
  SELECT c.samples - c.valid_samples - r.gap_samples
  FROM curves c JOIN runs r ON r.run_key = c.run_key
  WHERE c.run_key = run_axes.run_key AND c.axis = run_axes.axis AND r.result_utime IS NOT NULL
  ORDER BY c.estimator LIMIT 1);
DROP VIEW IF EXISTS axis_results;
-- One row per run and axis with the headline figures.
CREATE VIEW axis_results AS
SELECT r.lot, r.serial AS unit, r.run_id, r.run_key, r.start_utime, r.state, ra.axis_index, ra.axis, ra.kind,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.value END) AS random_walk,
       MAX(CASE WHEN m.name IN ('angle_random_walk', 'velocity_random_walk') THEN m.unit END) AS random_walk_unit,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.value END) AS bias_instability,
       MAX(CASE WHEN m.name = 'bias_instability_ieee' THEN m.value END) AS bias_instability_ieee,
       MAX(CASE WHEN m.name = 'bias_instability' THEN m.unit END) AS bias_instability_unit,
       MAX(CASE WHEN m.name = 'tau_at_minimum' THEN m.value END) AS tau_min_s,
       MAX(CASE WHEN m.name = 'rate_random_walk' THEN m.value END) AS rate_random_walk,
       r.gap_samples, ra.invalid_samples, r.samples,
       CASE WHEN SUM(m.outcome = 'FAIL') > 0 THEN 'FAIL'
            WHEN SUM(m.outcome = 'MARGINAL') > 0 THEN 'MARGINAL'
            WHEN SUM(m.outcome = 'PASS') > 0 THEN 'PASS' END AS axis_verdict,
       r.verdict AS run_verdict
FROM runs r
JOIN run_axes ra ON ra.run_key = r.run_key
LEFT JOIN measurements m ON m.run_key = r.run_key AND m.axis = ra.axis
GROUP BY r.lot, r.run_key, ra.axis_index;  -- lot first: WHERE lot = ? reaches the index
)sql",
      // 2 -> 3: checksums against damage at rest (store/checksums.h). Rows
      // archived before get theirs computed right after this, in the same
      // transaction (ComputeMissingChecksums): they attest the data as it
      // was found at the migration.
      R"sql(
ALTER TABLE raw_chunks ADD COLUMN crc32c INTEGER;
ALTER TABLE runs ADD COLUMN results_crc32c INTEGER;
)sql",
      // 3 -> 4: judgements made again. A run ended early by a fault (acquire
      // silent, then back) or judged on other data than the archive holds is
      // judged again on all its data; the judgement it replaces is kept, with
      // why. `revision` counts the rounds; the result columns say what the
      // archived judgement covered (batches 0..result_last_seq, of which
      // result_gap_batches never arrived). Existing checksums stay valid:
      // these columns and rows enter a run's checksum only when set.
      R"sql(
ALTER TABLE runs ADD COLUMN revision INTEGER NOT NULL DEFAULT 0;
ALTER TABLE runs ADD COLUMN result_last_seq INTEGER;
ALTER TABLE runs ADD COLUMN result_gap_batches INTEGER;
CREATE TABLE superseded_judgements (
  run_key           INTEGER NOT NULL REFERENCES runs(run_key),
  revision          INTEGER NOT NULL,   -- the round this judgement answered
  verdict           TEXT,
  reasons           TEXT,
  samples           INTEGER,
  gap_samples       INTEGER,
  record            BLOB,               -- its pb::RunRecord (measurements, reasons)
  result_utime      INTEGER,
  superseded_utime  INTEGER NOT NULL,
  cause             TEXT NOT NULL,      -- why it was judged again
  PRIMARY KEY (run_key, revision)
);
)sql",
      // 4 -> 5: views that answer what they say. lot_measurements had two
      // columns named `unit` (the serial and the measurement unit; SQLite
      // called the second `unit:1`), so lot_statistics grouped by serial; it
      // also counted every run of a retested unit, and its one-pass variance
      // (mean of squares - square of mean) cancelled for large means. Now
      // `serial` is a unit's serial number and `unit` a value's unit;
      // lot_measurements holds what `imuqual lot --stats` summarizes and
      // all_runs_measurements every run. axis_results and run_archive name
      // the serial `serial` and keep `unit` (the same serial, last column)
      // for queries written before.
      R"sql(
DROP VIEW IF EXISTS lot_statistics;
DROP VIEW IF EXISTS lot_measurements;
DROP VIEW IF EXISTS all_runs_measurements;
DROP VIEW IF EXISTS axis_results;
DROP VIEW IF EXISTS run_archive;

-- One row per run and axis with the headline figures.
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
       CASE WHEN SUM(m.outcome = 'FAIL') > 0 THEN 'FAIL'
            WHEN SUM(m.outcome = 'MARGINAL') > 0 THEN 'MARGINAL'
            WHEN SUM(m.outcome = 'PASS') > 0 THEN 'PASS' END AS axis_verdict,
       r.verdict AS run_verdict,
       r.serial AS unit  -- before schema 5; new queries say serial
FROM runs r
JOIN run_axes ra ON ra.run_key = r.run_key
LEFT JOIN measurements m ON m.run_key = r.run_key AND m.axis = ra.axis
GROUP BY r.lot, r.run_key, ra.axis_index;  -- lot first: WHERE lot = ? reaches the index

-- Every judged value of each unit's latest run in its lot: what
-- `imuqual lot LOT --stats` summarizes. A retested unit counts once, by its
-- latest run; a unit whose latest run is not judged (yet) has no values here.
CREATE VIEW lot_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome
FROM latest_runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;

-- Every judged value of every run (each run's current judgement), retests
-- included: a unit's history.
CREATE VIEW all_runs_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome
FROM runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;

-- Per lot, axis kind, measurement and unit, over lot_measurements without
-- the noise-model parameters (model_*: each unit's own model), as
-- `imuqual lot --stats` counts them: n finite values, their mean, sample sd,
-- min, max; pass_rate = (PASS + MARGINAL) / values with an outcome.
-- sd is two-pass, sqrt(sum((x - mean)^2) / (n - 1)) with the group's mean
-- from the inner query: sum(x^2) - n mean^2 loses every digit when
-- |mean| >> sd. The correlated sum reaches its lot's runs through the lot
-- index (`+x.name`: not through measurements_by_name, which would visit
-- that measurement in every lot), so WHERE lot = ? stays a per-lot query.
CREATE VIEW lot_statistics AS
SELECT g.lot, g.kind, g.name, g.unit, g.n, g.mean,
       SQRT((SELECT SUM((x.value - g.mean) * (x.value - g.mean)) FROM lot_measurements x
             WHERE x.lot = g.lot AND x.kind = g.kind AND +x.name = g.name AND x.unit = g.unit
               AND x.value > -1e999 AND x.value < 1e999)
            / NULLIF(g.n - 1, 0)) AS sd,
       g.min, g.max, g.pass_rate
FROM (SELECT lot, kind, name, unit, COUNT(x) AS n, AVG(x) AS mean, MIN(x) AS min, MAX(x) AS max,
             1.0 * SUM(outcome IN ('PASS', 'MARGINAL')) / NULLIF(SUM(outcome IS NOT NULL), 0) AS pass_rate
      FROM (SELECT lot, kind, name, unit, outcome,
                   CASE WHEN value > -1e999 AND value < 1e999 THEN value END AS x  -- finite
            FROM lot_measurements WHERE substr(name, 1, 6) <> 'model_')
      GROUP BY lot, kind, name, unit) g;

-- Archive completeness per run: chunks and samples held, gaps recorded.
CREATE VIEW run_archive AS
SELECT r.run_id, r.lot, r.serial, r.state, r.last_seq,
       (SELECT COUNT(*) FROM raw_chunks c WHERE c.run_key = r.run_key) AS chunks,
       (SELECT COALESCE(SUM(num_samples), 0) FROM raw_chunks c WHERE c.run_key = r.run_key) AS samples_archived,
       (SELECT COUNT(*) FROM gaps g WHERE g.run_key = r.run_key) AS gap_ranges,
       (SELECT COALESCE(SUM(MAX(num_samples, 0)), 0) FROM gaps g WHERE g.run_key = r.run_key) AS gap_samples,
       r.serial AS unit  -- before schema 5; new queries say serial
FROM runs r;
)sql",
      // 5 -> 6: outcomes that say what they mean. A run's verdict may also
      // be INCONCLUSIVE (a value within the guard band of a limit: retest),
      // ABORTED (stopped) or ERROR (the source or station failed); a
      // measurement's outcome INCONCLUSIVE. The CHECKs of runs.verdict and
      // measurements.outcome are widened before this SQL, by
      // WidenOutcomeChecks (a table rebuild would have to drop the foreign
      // keys into it). A measurement says what kind of value it is, how its
      // uncertainty was obtained and the decision rule that judged it; these
      // enter a run's checksum only when set, so checksums computed before
      // still hold. Yields count judged units only: each unit's final run in
      // a lot is its latest judged one (PASS, MARGINAL, FAIL, INCONCLUSIVE),
      // else its latest; ABORTED and ERROR runs never enter a yield.
      R"sql(
ALTER TABLE measurements ADD COLUMN qualifier TEXT
  CHECK (qualifier IN ('upper_bound', 'minimum_not_resolved', 'not_measurable', 'model_inadequate'));
ALTER TABLE measurements ADD COLUMN uncertainty_method TEXT;
ALTER TABLE measurements ADD COLUMN decision_rule TEXT
  CHECK (decision_rule IN ('simple', 'guarded', 'guarded_acceptance', 'guarded_rejection'));
ALTER TABLE measurements ADD COLUMN guard_band REAL;
-- A chi-square point's noise identification: the power-law exponent behind
-- its edf, identified at the point or taken from the nearest identified
-- point (the long-tau rule).
ALTER TABLE curve_points ADD COLUMN alpha INTEGER;
ALTER TABLE curve_points ADD COLUMN alpha_from TEXT CHECK (alpha_from IN ('identified', 'nearest'));

DROP VIEW IF EXISTS lot_statistics;
DROP VIEW IF EXISTS lot_overview;
DROP VIEW IF EXISTS lot_measurements;
DROP VIEW IF EXISTS all_runs_measurements;
DROP VIEW IF EXISTS axis_results;

-- One row per run and axis with the headline figures; axis_verdict is the
-- worst outcome of the axis: FAIL > INCONCLUSIVE > MARGINAL > PASS.
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
       CASE WHEN SUM(m.outcome = 'FAIL') > 0 THEN 'FAIL'
            WHEN SUM(m.outcome = 'INCONCLUSIVE') > 0 THEN 'INCONCLUSIVE'
            WHEN SUM(m.outcome = 'MARGINAL') > 0 THEN 'MARGINAL'
            WHEN SUM(m.outcome = 'PASS') > 0 THEN 'PASS' END AS axis_verdict,
       r.verdict AS run_verdict,
       r.serial AS unit  -- before schema 5; new queries say serial
FROM runs r
JOIN run_axes ra ON ra.run_key = r.run_key
LEFT JOIN measurements m ON m.run_key = r.run_key AND m.axis = ra.axis
GROUP BY r.lot, r.run_key, ra.axis_index;  -- lot first: WHERE lot = ? reaches the index

-- Each unit's final run in each lot: its latest judged run (verdict PASS,
-- MARGINAL, FAIL or INCONCLUSIVE: the unit was measured to the end), else
-- its latest run. An aborted or failed retest does not replace a judgement.
CREATE VIEW final_runs AS
SELECT r.* FROM runs r
WHERE r.run_key = (SELECT x.run_key FROM runs x
                   WHERE x.lot = r.lot AND x.serial = r.serial
                   ORDER BY x.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE') DESC,
                            x.start_utime DESC, x.run_key DESC
                   LIMIT 1);

-- Every value of each unit's final run in its lot, when that run is judged
-- (PASS, MARGINAL, FAIL, INCONCLUSIVE): what `imuqual lot LOT --stats`
-- summarizes. A retested unit counts once, by its final run; a unit whose
-- runs were all aborted, failed by the station or not judged yet has no
-- values here (partial records say nothing about the lot).
CREATE VIEW lot_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome,
       m.uncertainty, m.qualifier, m.uncertainty_method, m.decision_rule, m.guard_band
FROM final_runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis
WHERE r.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE');

-- Every value of every run (each run's current judgement), retests
-- included: a unit's history.
CREATE VIEW all_runs_measurements AS
SELECT r.lot, r.serial, r.run_id, r.start_utime, m.axis, COALESCE(ra.kind, '') AS kind,
       m.name, m.value, m.unit, m.low, m.high, m.marginal_low, m.marginal_high, m.outcome,
       m.uncertainty, m.qualifier, m.uncertainty_method, m.decision_rule, m.guard_band
FROM runs r
JOIN measurements m ON m.run_key = r.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;

-- Per lot: runs, units, the units' final verdicts and the yields (SCHEMA.md,
-- Yields). yield = final_yield = (PASS + MARGINAL) / (PASS + MARGINAL + FAIL)
-- over final runs; first_pass_yield = units whose first judged run is PASS
-- or MARGINAL / units with a judged run (an INCONCLUSIVE first run did not
-- pass first time); NULL when no unit counts.
CREATE VIEW lot_overview AS
SELECT f.lot, (SELECT COUNT(*) FROM runs x WHERE x.lot = f.lot) AS runs, COUNT(*) AS units,
       SUM(f.verdict IS 'PASS') AS pass, SUM(f.verdict IS 'MARGINAL') AS marginal,
       SUM(f.verdict IS 'FAIL') AS fail, SUM(f.verdict IS NULL) AS unjudged,
       1.0 * SUM(f.verdict IN ('PASS', 'MARGINAL'))
           / NULLIF(SUM(f.verdict IN ('PASS', 'MARGINAL', 'FAIL')), 0) AS yield,
       (SELECT MIN(x.start_utime) FROM runs x WHERE x.lot = f.lot) AS first_start_utime,
       (SELECT MAX(x.start_utime) FROM runs x WHERE x.lot = f.lot) AS last_start_utime,
       SUM(f.verdict IS 'INCONCLUSIVE') AS inconclusive, SUM(f.verdict IS 'ABORTED') AS aborted,
       SUM(f.verdict IS 'ERROR') AS error,
       1.0 * SUM(f.verdict IN ('PASS', 'MARGINAL'))
           / NULLIF(SUM(f.verdict IN ('PASS', 'MARGINAL', 'FAIL')), 0) AS final_yield,
       1.0 * SUM(f.first_verdict IN ('PASS', 'MARGINAL'))
           / NULLIF(SUM(f.first_verdict IS NOT NULL), 0) AS first_pass_yield,
       (SELECT COUNT(*) FROM runs x WHERE x.lot = f.lot) - COUNT(*) AS retests,
       SUM(f.verdict IS 'INCONCLUSIVE') AS retest_candidates
FROM (SELECT l.lot, l.verdict,
             (SELECT y.verdict FROM runs y
              WHERE y.lot = l.lot AND y.serial = l.serial
                AND y.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
              ORDER BY y.start_utime, y.run_key LIMIT 1) AS first_verdict
      FROM final_runs l) f
GROUP BY f.lot;

-- Runs followed by a later run of the same unit in the same lot: why the
-- unit was tested again (its verdict and reasons).
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

-- Per lot, axis kind, measurement and unit, over lot_measurements without
-- the noise-model parameters (model_*: each unit's own model), as
-- `imuqual lot --stats` counts them: n finite values, their mean, sample sd,
-- min, max; pass_rate = (PASS + MARGINAL) / (PASS + MARGINAL + FAIL) (an
-- INCONCLUSIVE value is neither). sd is two-pass (schema 5).
CREATE VIEW lot_statistics AS
SELECT g.lot, g.kind, g.name, g.unit, g.n, g.mean,
       SQRT((SELECT SUM((x.value - g.mean) * (x.value - g.mean)) FROM lot_measurements x
             WHERE x.lot = g.lot AND x.kind = g.kind AND +x.name = g.name AND x.unit = g.unit
               AND x.value > -1e999 AND x.value < 1e999)
            / NULLIF(g.n - 1, 0)) AS sd,
       g.min, g.max, g.pass_rate
FROM (SELECT lot, kind, name, unit, COUNT(x) AS n, AVG(x) AS mean, MIN(x) AS min, MAX(x) AS max,
             1.0 * SUM(outcome IN ('PASS', 'MARGINAL'))
                 / NULLIF(SUM(outcome IN ('PASS', 'MARGINAL', 'FAIL')), 0) AS pass_rate
      FROM (SELECT lot, kind, name, unit, outcome,
                   CASE WHEN value > -1e999 AND value < 1e999 THEN value END AS x  -- finite
            FROM lot_measurements WHERE substr(name, 1, 6) <> 'model_')
      GROUP BY lot, kind, name, unit) g;
)sql",
      // 6 -> 7: a tamper-evident archive (store/chain.h). Each raw chunk
      // gets a BLAKE2b-256 digest when it is written (chunks archived before
      // keep NULL: their runs are unsigned); the covering index lets the
      // store read a run's chunk digests at finalisation without reading
      // its samples. archive_chain holds one entry per finalised run and per
      // judgement round opened again, each linked to the one before and
      // signed with the store's key; it is append-only (the triggers stop
      // honest tools; verify finds dishonest ones).
      // runs.bus_auth: what authenticated the messages the run was archived
      // from (the store's bus: station key, role signatures, replays taken
      // by choice; or an unauthenticated bus, and why).
      R"sql(
ALTER TABLE runs ADD COLUMN bus_auth TEXT;
ALTER TABLE raw_chunks ADD COLUMN digest BLOB;
CREATE INDEX raw_chunks_digests ON raw_chunks(run_key, seq, digest);
CREATE TABLE archive_chain (
  entry          INTEGER PRIMARY KEY CHECK (entry >= 1),  -- 1, 2, ... without gaps
  kind           TEXT NOT NULL CHECK (kind IN ('finalized', 'reopened', 'migrated')),
  run_id         TEXT NOT NULL,         -- '' for the migration entry
  revision       INTEGER NOT NULL,      -- the run's judgement round
  record         BLOB NOT NULL,         -- the run's signed record (SCHEMA.md)
  created_utime  INTEGER NOT NULL,
  key_id         TEXT NOT NULL DEFAULT '',  -- the signer's public key id; '' unsigned
  signature      BLOB,                  -- Ed25519 over the entry's body; NULL unsigned
  prev_hash      BLOB NOT NULL,         -- entry_hash of entry - 1 (zeros for entry 1)
  entry_hash     BLOB NOT NULL
);
CREATE TRIGGER archive_chain_no_update BEFORE UPDATE ON archive_chain
BEGIN SELECT RAISE(ABORT, 'archive_chain is append-only'); END;
CREATE TRIGGER archive_chain_no_delete BEFORE DELETE ON archive_chain
BEGIN SELECT RAISE(ABORT, 'archive_chain is append-only'); END;
)sql",
  };
  return kMigrations;
}

Status CheckIdentity(Db& db, bool* empty) {
  // The first read of the file: a non-SQLite file fails here. The tables
  // before the application id: a station creating the file at this moment
  // commits both at once, so tables seen means its id is there too.
  auto tables = db.QueryInt("SELECT COUNT(*) FROM sqlite_schema");
  if (!tables.ok()) {
    return Status::Corruption(db.path() + " is not an imuqual archive (" +
                              tables.status().message() + ")");
  }
  auto app = db.QueryInt("PRAGMA application_id");
  if (!app.ok()) {
    return Status::Corruption(db.path() + " is not an imuqual archive (" + app.status().message() +
                              ")");
  }
  *empty = *tables == 0;
  if (!*empty && *app != kApplicationId) {
    return Status::InvalidArgument(db.path() + " is an SQLite database but not an imuqual archive");
  }
  auto version = db.QueryInt("PRAGMA user_version");
  if (!version.ok()) return version.status();
  if (*version > SchemaVersion()) {
    return Status::InvalidArgument(db.path() + " has schema version " + std::to_string(*version) +
                                   ", newer than this imuqual's " +
                                   std::to_string(SchemaVersion()) + "; upgrade imuqual");
  }
  return Status::Ok();
}

// PRAGMA quick_check (the integrity check without the index contents) or
// integrity_check: OK, or Corruption with SQLite's first complaint.
Status CheckSqlite(Db& db, const std::string& check) {
  std::string first;
  int64_t problems = 0;
  auto s = db.Prepare("PRAGMA " + check + "(1)");
  if (!s.ok()) {
    first = s.status().message();
    ++problems;
  } else {
    for (;;) {
      auto row = s->Step();
      if (!row.ok()) {
        first = row.status().message();
        ++problems;
        break;
      }
      if (!*row) break;
      if (s->Text(0) != "ok") {
        if (first.empty()) first = s->Text(0);
        ++problems;
      }
    }
  }
  if (problems == 0) return Status::Ok();
  std::replace(first.begin(), first.end(), '\n', ' ');  // SQLite's report spans lines
  return Status::Corruption(db.path() + " is damaged (SQLite " + check + ": " + first +
                            "); refusing to write into it (imuqual verify --db lists the damage)");
}

// A damaged file is never written into.
Status CheckIntact(Db& db) { return CheckSqlite(db, "quick_check"); }

// Schema 6 widens the CHECKs on runs.verdict and measurements.outcome in
// place, by SQLite's documented procedure for changes that do not alter the
// stored rows (https://sqlite.org/lang_altertable.html, "Making Other Kinds
// Of Table Schema Changes"): a rebuilt table would have to drop and remake
// the foreign keys that point into runs. Runs inside the migration's
// transaction; every old value is valid under the wider CHECK.
struct CheckChange {
  const char* table;
  const char* from;
  const char* to;
};
constexpr CheckChange kOutcomeChecks[] = {
    {"runs", "CHECK (verdict IN ('PASS', 'MARGINAL', 'FAIL'))",
     "CHECK (verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE', 'ABORTED', 'ERROR'))"},
    {"measurements", "CHECK (outcome IN ('PASS', 'MARGINAL', 'FAIL'))",
     "CHECK (outcome IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE'))"},
};

Status RewriteChecks(Db& db) {
  for (const CheckChange& c : kOutcomeChecks) {
    auto up = db.Prepare(
        "UPDATE sqlite_schema SET sql = replace(sql, ?1, ?2) "
        "WHERE type = 'table' AND name = ?3 AND instr(sql, ?1) > 0");
    if (!up.ok()) return up.status();
    IMUQUAL_RETURN_IF_ERROR(up->Bind(1, c.from).Bind(2, c.to).Bind(3, c.table).Run());
  }
  return Status::Ok();
}

Status WidenOutcomeChecks(Db& db) {
  auto version = db.QueryInt("PRAGMA schema_version");
  if (!version.ok()) return version.status();
  IMUQUAL_RETURN_IF_ERROR(db.Exec("PRAGMA writable_schema = ON"));
  Status st = RewriteChecks(db);
  if (st.ok()) st = db.Exec("PRAGMA schema_version = " + std::to_string(*version + 1));
  const Status off = db.Exec("PRAGMA writable_schema = OFF");
  IMUQUAL_RETURN_IF_ERROR(st);
  IMUQUAL_RETURN_IF_ERROR(off);
  for (const CheckChange& c : kOutcomeChecks) {
    auto s = db.Prepare(
        "SELECT COUNT(*) FROM sqlite_schema WHERE type = 'table' AND name = ?1 "
        "AND instr(sql, ?2) > 0 AND instr(sql, ?3) = 0");
    if (!s.ok()) return s.status();
    s->Bind(1, c.table).Bind(2, c.to).Bind(3, c.from);
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row || s->Int(0) != 1) {
      return Status::Corruption(db.path() + ": table " + c.table +
                                " does not have the CHECK of schema 5 (" + c.from +
                                "); not migrated");
    }
  }
  // quick_check verifies the schema and every row's CHECK and NOT NULL
  // constraints (what the edit could break) without integrity_check's
  // index-against-table pass, which takes minutes on a large archive.
  return CheckSqlite(db, "quick_check");
}

}  // namespace

int SchemaVersion() { return static_cast<int>(Migrations().size()); }

Status CheckReadable(Db& db) {
  bool empty = false;
  IMUQUAL_RETURN_IF_ERROR(CheckIdentity(db, &empty));
  if (empty) return Status::NotFound(db.path() + " is an empty database (no imuqual archive yet)");
  auto version = db.QueryInt("PRAGMA user_version");
  if (!version.ok()) return version.status();
  if (*version != SchemaVersion()) {
    return Status::InvalidArgument(db.path() + " has schema version " + std::to_string(*version) +
                                   "; open it once with imuqual-store to migrate it");
  }
  return Status::Ok();
}

// How long a migration waits for another station's migration step, and the
// usual wait (store/sqlite.cc), in ms.
constexpr int kMigrationWaitMs = 30 * 60 * 1000;
constexpr int kUsualWaitMs = 5000;

static Status MigrateSteps(Db& db);

Status Migrate(Db& db) {
  bool empty = false;
  IMUQUAL_RETURN_IF_ERROR(CheckIdentity(db, &empty));
  IMUQUAL_RETURN_IF_ERROR(CheckIntact(db));
  // Current already: no write lock taken (another process may be writing).
  auto current = db.QueryInt("PRAGMA user_version");
  if (!current.ok()) return current.status();
  if (*current >= SchemaVersion()) return Status::Ok();
  // Another station may hold the lock for a whole step (checksums of a large
  // archive take minutes): wait for it, then restore the usual patience.
  IMUQUAL_RETURN_IF_ERROR(db.Exec("PRAGMA busy_timeout = " + std::to_string(kMigrationWaitMs)));
  Status st = MigrateSteps(db);
  const Status restored = db.Exec("PRAGMA busy_timeout = " + std::to_string(kUsualWaitMs));
  return st.ok() ? restored : st;
}

static Status MigrateSteps(Db& db) {
  // One step per transaction, the version read under the write lock: a
  // station that creates or migrates the same file at the same moment has
  // either done a step (seen here, skipped) or waits for this one.
  for (;;) {
    IMUQUAL_RETURN_IF_ERROR(db.Exec("BEGIN IMMEDIATE"));
    auto version = db.QueryInt("PRAGMA user_version");
    if (!version.ok()) {
      (void)db.Exec("ROLLBACK");
      return version.status();
    }
    const int v = static_cast<int>(*version);
    if (v >= SchemaVersion()) return db.Exec("COMMIT");
    Status st = v == 5 ? WidenOutcomeChecks(db) : Status::Ok();
    if (st.ok()) st = db.Exec(Migrations()[v]);
    if (st.ok()) st = db.Exec("PRAGMA user_version = " + std::to_string(v + 1));
    if (st.ok() && v == 0)
      st = db.Exec("PRAGMA application_id = " + std::to_string(kApplicationId));
    // The runs an older archive holds enter the chain as unsigned, listed.
    if (st.ok() && v == 6) st = AppendMigrationEntry(db, NowUtime());
    // Checksums of rows archived before schema 3, with today's definition.
    if (st.ok() && v + 1 == SchemaVersion() && v >= 2) st = ComputeMissingChecksums(db);
    if (!st.ok()) {
      (void)db.Exec("ROLLBACK");
      return st.WithContext("migrating " + db.path() + " to schema " + std::to_string(v + 1));
    }
    IMUQUAL_RETURN_IF_ERROR(db.Exec("COMMIT"));
  }
}

}  // namespace imuqual::store
