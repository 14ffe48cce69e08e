// Shipping a station's archive to the plant archive (PostgreSQL,
// store/plant_schema.h): every finalised run with everything it holds (its
// runs row, axes, raw chunks, gaps, curves and points, measurements,
// superseded judgement rounds; its lot and unit), in the order of the
// station's chain, with the chain's entries themselves.
//
// - Identity: a station archive is known at the plant by the hash of its
//   chain's first entry (archive_id). The plant keeps, per archive, how many
//   of its entries are shipped and the last one's hash (the cursor).
// - Idempotent and resumable: a sync ships the entries after the cursor and
//   nothing else; shipping again inserts nothing; a station offline for a
//   week ships its week at the next sync.
// - Transactional per batch: a batch of entries and the cursor move
//   together (a sync killed, or a plant gone, mid-batch leaves the plant
//   as it was before the batch).
// - Verified at the plant: each entry's link and hash (and its signature,
//   with trusted keys), and each run's record recomputed from the rows as
//   the plant now holds them (every chunk's digest from its bytes) equal to
//   the record the station signed. A mismatch is refused (the entry, and
//   everything after it, stays unshipped) and named.
// - A run judged again after it was shipped arrives with its new round:
//   its rows are replaced, its superseded rounds (kept by the station) come
//   with them, and the plant's chain holds every round's record.
// - Refused, named: a station chain that no longer holds what the plant has
//   (edited, or another archive with the same first entry); a run id the
//   plant holds from another station archive; a run whose station id
//   another station archive holds (two stations claiming one id: the first
//   archive to ship a run of a station id holds it, until a sync names
//   another archive that station's new one, SyncOptions::new_archive_of).
// - A station archive behind the plant (restored from an old backup, whose
//   chain is a prefix of what the plant holds) ships nothing and says so.
#ifndef IMUQUAL_STORE_PLANT_SYNC_H_
#define IMUQUAL_STORE_PLANT_SYNC_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "common/keys.h"
#include "common/status.h"
#include "store/archive.h"

namespace imuqual::store {

struct SyncOptions {
  int batch_entries = 32;  // chain entries per plant transaction
  // Check each entry's signature against these keys (role "store"); empty:
  // signatures are copied, not checked.
  std::vector<PublicKey> trusted;
  // With trusted keys: an unsigned entry is refused.
  bool require_signatures = false;
  // This archive is the new archive of that station id (a rebuilt station):
  // the plant moves the id to it from the archive that held it, and refuses
  // that one from then on. "" (default): a station id held by another
  // archive is refused.
  std::string new_archive_of;
  // Who ships, as recorded with a station id's claim (e.g. "imuqual sync
  // from HOST:PATH").
  std::string claimed_by;
  // Progress lines ("shipped entries 1..32 of 120").
  std::function<void(const std::string&)> progress;
};

struct SyncReport {
  std::string archive_id;  // hex; "" when the station chain is empty
  int64_t station_entries = 0;
  int64_t shipped_before = 0, shipped_after = 0;  // the plant's cursor
  int64_t runs_shipped = 0;   // runs whose rows were copied
  int64_t runs_replaced = 0;  // of them, runs the plant held (judged again)
  int64_t rows_inserted = 0;  // rows of every table, chunks and chain entries included
  int64_t chunks_inserted = 0;
  int64_t chunk_bytes = 0;
  // The station archive is behind the plant (restored from a backup): its
  // chain is a prefix of what the plant holds; nothing shipped.
  bool behind = false;
  // Raw chunks that went to the default partition (the month's could not
  // be made: the sync's role does not own raw_chunks), once; "" otherwise.
  std::string partition_note;
  // "station id X moved to this archive from ..." when new_archive_of took
  // a station id over; "" otherwise.
  std::string station_moved;
  // Why shipping stopped before the station's last entry ("" if it did
  // not): the entry or run refused and what was wrong. Everything before it
  // is shipped.
  std::string refusal;
};

// Ships `station` (a station archive, read) to `plant` (a plant archive,
// write). Errors: the plant or the station could not be read or written
// (what was committed before stays; the next sync resumes from it).
Result<SyncReport> SyncToPlant(Archive& station, Archive& plant, const SyncOptions& options);

// What `imuqual verify --db postgresql://...` checks of a plant archive:
// each station archive's chain as shipped (numbering, links, each entry's
// hash, signatures with trusted keys, the cursor at its last entry), every
// run's record recomputed from the plant's rows (every chunk's digest from
// its bytes) against the record of its last finalising entry, and runs
// that no chain entry accounts for. Problems go one line each to
// `problem`; returns their number and how many runs were verified.
struct PlantVerifyReport {
  int64_t problems = 0;
  int64_t archives = 0, entries = 0, runs_verified = 0;
};
Result<PlantVerifyReport> VerifyPlant(Archive& plant, const SyncOptions& options,
                                      const std::function<void(const std::string&)>& problem);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_PLANT_SYNC_H_
