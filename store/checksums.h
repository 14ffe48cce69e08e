// Checksums of what the archive holds, so that damage at rest (a flipped
// bit on disk, a page overwritten, an edit behind imuqual's back) is found:
//  - raw_chunks.crc32c: CRC-32C of one chunk row (its seq, counters, times,
//    temperature, codec and data BLOB), written with the row;
//  - runs.results_crc32c: CRC-32C of the run's result rows (the result
//    columns of runs, run_axes.invalid_samples, curves, curve_points,
//    measurements, in primary-key order), rewritten whenever a result or a
//    curve is stored.
// Both are 32-bit values stored as INTEGER (0..2^32-1). Schema version 3
// added them; a file migrated from version 2 got them computed at migration.
#ifndef IMUQUAL_STORE_CHECKSUMS_H_
#define IMUQUAL_STORE_CHECKSUMS_H_

#include <cstdint>
#include <functional>
#include <string>

#include "common/status.h"
#include "store/sqlite.h"

namespace imuqual::store {

struct ChunkRecord;

uint32_t ChunkChecksum(const ChunkRecord& chunk);

// The checksum of the run's result rows as they are in `db` now.
Result<uint32_t> ResultsChecksum(Db& db, int64_t run_key);

// Stores ResultsChecksum() in runs.results_crc32c (inside the caller's
// transaction).
Status SealResults(Db& db, int64_t run_key);

// Computes every missing checksum (the migration to schema 3).
Status ComputeMissingChecksums(Db& db);

// Checks the stored checksums of one run (run_key >= 0) or of every run
// (run_key < 0): calls `problem` with one line per chunk or run whose rows do
// not match their checksum (naming the run id and the chunk's seq). Returns
// the number of problems; fails only if the archive cannot be read.
Result<int64_t> CheckChecksums(Db& db, int64_t run_key,
                               const std::function<void(const std::string&)>& problem);

// PRAGMA integrity_check: one line per problem SQLite reports (or the error
// that stopped it); returns their number.
Result<int64_t> CheckIntegrity(Db& db, const std::function<void(const std::string&)>& problem);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CHECKSUMS_H_
