// Signed records of runs and the archive's append-only hash chain
// (store/SCHEMA.md, "Signed records and the chain", defines every byte).
//
// - A run's signed record: what the archive holds of the run, as named
//   canonical items (store/canonical.h): every non-NULL column of its `runs`
//   row but the exclusions (blobs by their digest), a digest and row count
//   of its rows in every other table that has a run_key column (curves,
//   measurements, gaps, superseded judgements, ... and tables added later),
//   and its raw chunks by count, seq ranges and the digest of its ordered
//   list of chunk digests.
// - The chain (table archive_chain): entries numbered 1, 2, ... without
//   gaps, one per finalised run and one per judgement round the store opens
//   again ("finalized", "reopened"), plus one "migrated" entry listing the
//   runs an older archive held when it was migrated to schema 7. Each entry
//   holds its run's record, the previous entry's hash and, when the writer
//   holds a signing key of role "store", an Ed25519 signature, so an edited,
//   deleted or inserted run or entry breaks it.
//
// Writers append inside their own write transaction, reading the chain's
// last entry there, so several stores sharing one file chain correctly.
// Thread-safety: as the Db (one thread at a time).
#ifndef IMUQUAL_STORE_CHAIN_H_
#define IMUQUAL_STORE_CHAIN_H_

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/keys.h"
#include "common/status.h"
#include "store/canonical.h"
#include "store/sqlite.h"

namespace imuqual::store {

inline constexpr char kEntryFinalized[] = "finalized";
inline constexpr char kEntryReopened[] = "reopened";
inline constexpr char kEntryMigrated[] = "migrated";

// Columns of runs left out of a run's record: SQLite's key of the row (the
// record names the run by run_id) and the results' CRC (derived from rows
// the record covers itself).
const std::vector<std::string>& RunColumnExclusions();
// Columns of runs the store changes while a judgement round is open (the
// run's progress and its result); the rest of the row is settled once the
// run is announced. verify compares only the settled part of a run whose
// last entry reopened it and that is not finalised again yet.
const std::vector<std::string>& OpenRunColumns();

// A run's signed record: items by name (ascending bytewise, std::string's
// order), each a non-NULL canonical value.
struct SignedRecord {
  std::map<std::string, CanonicalValue> items;
  // "imuqual-run-record v1\0", u64 item count, then each item's u64 name
  // length, name and canonical value.
  std::string Encode() const;
  static Result<SignedRecord> Decode(std::string_view bytes);
};

// How ComputeRunRecord has the chunks' digests.
enum class ChunkDigests {
  // As stored in raw_chunks.digest (the writer, at signing; a run's few
  // chunks archived before schema 7 get theirs computed and stored first,
  // so this needs a write transaction). Reads the covering index on
  // (run_key, seq, digest), never the chunks' data.
  kStored,
  // Recomputed from every chunk's bytes (verify).
  kRecomputed,
};

// What kRecomputed found chunk by chunk.
struct ChunkFindings {
  std::vector<int64_t> seqs;     // archived, ascending
  std::vector<Digest> digests;   // recomputed, same order
  std::vector<int64_t> altered;  // bytes differ from the stored digest, CRC matches
  std::vector<int64_t> damaged;  // CRC does not match (CheckChecksums names them)
};

// Tables whose rows of a run enter its record: every table with a run_key
// column but runs, raw_chunks and archive_chain, sorted by name.
Result<std::vector<std::string>> RunTables(Db& db);

// The record of run `run_key` as the archive holds it now.
// `tables`: RunTables(db) when the caller has it (many runs in a row).
Result<SignedRecord> ComputeRunRecord(Db& db, int64_t run_key, ChunkDigests how,
                                      ChunkFindings* findings = nullptr,
                                      const std::vector<std::string>* tables = nullptr);

struct ChainEntry {
  int64_t entry = 0;   // 1, 2, ...
  std::string kind;    // kEntryFinalized, kEntryReopened, kEntryMigrated
  std::string run_id;  // "" for kEntryMigrated
  int64_t revision = 0;
  std::string record;  // SignedRecord::Encode()
  int64_t created_utime = 0;
  std::string key_id;     // PublicKey::Id() of the signer; "" unsigned
  std::string signature;  // Ed25519 over Body(); "" unsigned
  Digest prev_hash{};     // hash of entry - 1 (zeros for entry 1)
  Digest entry_hash{};    // as stored

  // The bytes signed: "imuqual-chain v1\0", u64 entry, kind, run_id (each
  // u64 length + bytes), i64 revision, BLAKE2b-256 of record, i64
  // created_utime, key_id (u64 length + bytes), prev_hash.
  std::string Body() const;
  // BLAKE2b-256 of "imuqual-chain-link v1\0", Body(), then the signature (u64
  // length + bytes): the link the next entry holds.
  Digest ComputeHash() const;
};

// Whether the entry's signature verifies with `key` (over Body()).
bool EntrySignatureVerifies(const ChainEntry& entry, const PublicKey& key);

// Appends the run's entry (kEntryFinalized or kEntryReopened) with its
// record as the archive holds it now, inside the caller's write
// transaction; signed when `key` is not null (role "store").
Status AppendRunEntry(Db& db, int64_t run_key, const std::string& kind, const SigningKey* key,
                      int64_t utime);
// The migration to schema 7: an unsigned kEntryMigrated entry whose record
// lists every run the archive holds ("legacy_runs": run ids, each followed
// by '\n', ascending; "legacy_runs.count"), if it holds any. Those runs are
// reported unsigned until they are finalised again.
Status AppendMigrationEntry(Db& db, int64_t utime);

// Every entry, in entry order (ReadChain holds them all; ForEachChainEntry
// one at a time; fn's error stops it).
Result<std::vector<ChainEntry>> ReadChain(Db& db);
Status ForEachChainEntry(Db& db, const std::function<Status(const ChainEntry&)>& fn);
// A plant archive's copy of station archive `archive_id`'s chain, in entry
// order (store/plant_schema.h).
Status ForEachPlantChainEntry(Db& plant, const std::string& archive_id,
                              const std::function<Status(const ChainEntry&)>& fn);
// Entries `first`, first + 1, ... to the last, in entry order.
Result<std::vector<ChainEntry>> ReadChainFrom(Db& db, int64_t first);
// Entry number `entry`, if the chain holds it.
Result<std::optional<ChainEntry>> ReadChainEntry(Db& db, int64_t entry);

// The chain's last entry: its number (0: empty chain) and stored hash (zeros
// for an empty chain). Text form "N:HEX", kept outside the archive.
struct ChainHead {
  int64_t entries = 0;
  Digest hash{};
  std::string ToText() const;
  // "N:HEX" (HEX: 64 hex digits); false if malformed.
  static bool Parse(std::string_view text, ChainHead* head);
};
Result<ChainHead> ReadChainHead(Db& db);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CHAIN_H_
