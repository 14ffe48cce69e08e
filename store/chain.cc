#include "store/chain.h"

#include <algorithm>
#include <functional>

#include "store/archive.h"
#include "store/checksums.h"

namespace imuqual::store {
namespace {

// A statement whose rows are read by column name and storage class, on
// either engine.
class RawStmt {
 public:
  RawStmt(Db& db, const std::string& sql) {
    auto s = db.Prepare(sql);
    if (s.ok()) {
      stmt_.emplace(std::move(*s));
    } else {
      error_ = s.status();
    }
  }
  const Status& error() const { return error_; }
  RawStmt& Bind(int i, int64_t v) {
    if (stmt_) stmt_->Bind(i, v);
    return *this;
  }
  RawStmt& Bind(int i, const std::string& v) {
    if (stmt_) stmt_->Bind(i, v);
    return *this;
  }
  // Calls fn for each row; fn's error stops the loop.
  Status ForEach(const std::function<Status(const Stmt&)>& fn) {
    IMUQUAL_RETURN_IF_ERROR(error_);
    for (;;) {
      auto row = stmt_->Step();
      if (!row.ok()) return row.status();
      if (!*row) return Status::Ok();
      IMUQUAL_RETURN_IF_ERROR(fn(*stmt_));
    }
  }

 private:
  std::optional<Stmt> stmt_;
  Status error_;
};

std::string BlobOf(const Stmt& s, int col) {
  const std::vector<uint8_t> b = s.Blob(col);
  return std::string(b.begin(), b.end());
}

// A 32-byte digest column (zeros when it is not 32 bytes: then it matches
// nothing it should).
Digest DigestOfColumn(const Stmt& s, int col) {
  Digest d{};
  const std::string b = BlobOf(s, col);
  if (b.size() == d.size()) std::copy(b.begin(), b.end(), reinterpret_cast<char*>(d.data()));
  return d;
}

const CanonicalValue* Column(const CanonicalRow& row, const char* name) {
  for (const auto& [n, v] : row) {
    if (n == name) return &v;
  }
  return nullptr;
}

int64_t IntColumn(const CanonicalRow& row, const char* name) {
  const CanonicalValue* v = Column(row, name);
  return v != nullptr && v->type == CanonicalValue::Type::kInteger ? v->integer : 0;
}

// The chunk as ChunkChecksum sees it, from its row.
ChunkRecord ChunkFromCanonicalRow(const CanonicalRow& row) {
  ChunkRecord c;
  c.seq = IntColumn(row, "seq");
  c.first_sample = IntColumn(row, "first_sample");
  c.num_samples = IntColumn(row, "num_samples");
  c.host_utime = IntColumn(row, "host_utime");
  const CanonicalValue* t = Column(row, "temperature_c");
  if (t != nullptr && t->type == CanonicalValue::Type::kReal) c.temperature_c = t->real;
  c.codec = static_cast<int>(IntColumn(row, "codec"));
  if (const CanonicalValue* d = Column(row, "data"))
    c.data.assign(d->bytes.begin(), d->bytes.end());
  c.sample_utime = IntColumn(row, "sample_utime");
  return c;
}

// Rows of one table of one run: BLAKE2b-256 of "imuqual-table v1\0", the
// table's name (u64 length + bytes), u64 row count and each canonical row
// (u64 length + bytes) in ascending bytewise order.
Status AddTableItems(Db& db, const std::string& table, int64_t run_key, SignedRecord* record) {
  RawStmt s(db, "SELECT * FROM \"" + table + "\" WHERE run_key = ?");
  IMUQUAL_RETURN_IF_ERROR(s.error());
  s.Bind(1, run_key);
  static const std::vector<std::string> kExcluded = {"run_key"};
  std::vector<std::string> rows;
  IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
    rows.push_back(EncodeRow(RowFromStatement(row, kExcluded)));
    return Status::Ok();
  }));
  if (rows.empty()) return Status::Ok();  // no rows: no item (as a NULL column)
  std::sort(rows.begin(), rows.end());
  Blake2b256 h;
  h.Update(std::string_view("imuqual-table v1\0", 17));
  h.Sized(table);
  h.U64(rows.size());
  for (const std::string& row : rows) h.Sized(row);
  record->items[table] = CanonicalValue::DigestOf(h.Final());
  record->items[table + ".rows"] = CanonicalValue::Integer(static_cast<int64_t>(rows.size()));
  return Status::Ok();
}

Status AddChunkItems(Db& db, int64_t run_key, ChunkDigests how, ChunkFindings* findings,
                     SignedRecord* record) {
  // The plant's own column (raw_chunks' month partition) is no part of a
  // chunk, as run_key is not.
  std::vector<std::string> excluded = ChunkDigestExclusions();
  if (db.postgres()) excluded.push_back("month");
  ChunkListDigest list;
  std::vector<int64_t> seqs;
  if (how == ChunkDigests::kStored) {
    // Chunks archived before schema 7 (a run that spans the upgrade) get
    // their digests now.
    std::vector<std::pair<int64_t, Digest>> missing;
    {
      RawStmt s(db, "SELECT * FROM raw_chunks WHERE run_key = ? AND digest IS NULL");
      s.Bind(1, run_key);
      IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
        const CanonicalRow c = RowFromStatement(row, excluded);
        missing.emplace_back(IntColumn(c, "seq"), ChunkRowDigest(c));
        return Status::Ok();
      }));
    }
    for (const auto& [seq, digest] : missing) {
      auto up = db.Prepare("UPDATE raw_chunks SET digest = ? WHERE run_key = ? AND seq = ?");
      if (!up.ok()) return up.status();
      IMUQUAL_RETURN_IF_ERROR(up->BindBlob(1, digest).Bind(2, run_key).Bind(3, seq).Run());
    }
    RawStmt s(db, db.postgres() ? "SELECT seq, digest FROM raw_chunks WHERE run_key = ? ORDER BY seq"
                                : "SELECT seq, digest FROM raw_chunks INDEXED BY raw_chunks_digests "
                                  "WHERE run_key = ? ORDER BY seq");
    s.Bind(1, run_key);
    IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
      seqs.push_back(row.Int(0));
      list.Add(seqs.back(), DigestOfColumn(row, 1));
      return Status::Ok();
    }));
  } else {
    RawStmt s(db, "SELECT * FROM raw_chunks WHERE run_key = ? ORDER BY seq");
    s.Bind(1, run_key);
    IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
      const CanonicalRow all = RowFromStatement(row, {"run_key"});
      CanonicalRow content;
      for (const auto& column : all) {
        if (std::find(excluded.begin(), excluded.end(), column.first) == excluded.end()) {
          content.push_back(column);
        }
      }
      const int64_t seq = IntColumn(all, "seq");
      const Digest digest = ChunkRowDigest(content);
      seqs.push_back(seq);
      list.Add(seq, digest);
      if (findings != nullptr) {
        findings->seqs.push_back(seq);
        findings->digests.push_back(digest);
        const CanonicalValue* crc = Column(all, "crc32c");
        const bool crc_ok =
            crc == nullptr || crc->is_null() ||
            static_cast<uint32_t>(crc->integer) == ChunkChecksum(ChunkFromCanonicalRow(content));
        const CanonicalValue* stored = Column(all, "digest");
        if (!crc_ok) {
          findings->damaged.push_back(seq);
        } else if (stored != nullptr && !stored->is_null() &&
                   stored->bytes !=
                       std::string(reinterpret_cast<const char*>(digest.data()), digest.size())) {
          findings->altered.push_back(seq);
        }
      }
      return Status::Ok();
    }));
  }
  record->items["raw_chunks.count"] = CanonicalValue::Integer(list.count());
  record->items["raw_chunks.seqs"] = CanonicalValue::Text(SeqRangesText(seqs));
  record->items["raw_chunks.digest"] = CanonicalValue::DigestOf(list.Final());
  return Status::Ok();
}

// The next entry's number and the hash it links to, read in the caller's
// transaction.
Status ChainTail(Db& db, int64_t* entry, Digest* hash) {
  *entry = 0;
  *hash = Digest{};
  RawStmt s(db, "SELECT entry, entry_hash FROM archive_chain ORDER BY entry DESC LIMIT 1");
  return s.ForEach([&](const Stmt& row) {
    *entry = row.Int(0);
    *hash = DigestOfColumn(row, 1);
    return Status::Ok();
  });
}

Status InsertEntry(Db& db, ChainEntry& e, const SigningKey* key) {
  IMUQUAL_RETURN_IF_ERROR(ChainTail(db, &e.entry, &e.prev_hash));
  ++e.entry;
  if (key != nullptr) {
    if (key->role != "store") {
      return Status::InvalidArgument("the archive is signed with a key of role 'store', not '" +
                                     key->role + "'");
    }
    e.key_id = key->Public().Id();
    const std::string body = e.Body();
    const Signature sig = Sign(*key, body.data(), body.size());
    e.signature.assign(reinterpret_cast<const char*>(sig.data()), sig.size());
  }
  e.entry_hash = e.ComputeHash();
  auto in = db.Prepare(
      "INSERT INTO archive_chain(entry, kind, run_id, revision, record, created_utime, key_id, "
      "signature, prev_hash, entry_hash) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!in.ok()) return in.status();
  in->Bind(1, e.entry).Bind(2, e.kind).Bind(3, e.run_id).Bind(4, e.revision);
  in->BindBlob(5, {reinterpret_cast<const uint8_t*>(e.record.data()), e.record.size()});
  in->Bind(6, e.created_utime).Bind(7, e.key_id);
  if (e.signature.empty()) {
    in->BindNull(8);
  } else {
    in->BindBlob(8, {reinterpret_cast<const uint8_t*>(e.signature.data()), e.signature.size()});
  }
  in->BindBlob(9, e.prev_hash).BindBlob(10, e.entry_hash);
  return in->Run();
}

}  // namespace

const std::vector<std::string>& RunColumnExclusions() {
  static const std::vector<std::string> kExcluded = {"run_key", "results_crc32c"};
  return kExcluded;
}

const std::vector<std::string>& OpenRunColumns() {
  static const std::vector<std::string> kOpen = {"state",
                                                 "bus_auth",
                                                 "end_reason",
                                                 "end_utime",
                                                 "last_seq",
                                                 "samples_announced",
                                                 "first_sample",
                                                 "end_sample",
                                                 "verdict",
                                                 "reasons",
                                                 "samples",
                                                 "gap_samples",
                                                 "invalid_samples",
                                                 "record",
                                                 "result_utime",
                                                 "result_last_seq",
                                                 "result_gap_batches",
                                                 "finalized_utime"};
  return kOpen;
}

std::string SignedRecord::Encode() const {
  std::string out("imuqual-run-record v1\0", 22);
  AppendU64(&out, items.size());
  for (const auto& [name, value] : items) {
    AppendSized(&out, name);
    value.AppendTo(&out);
  }
  return out;
}

Result<SignedRecord> SignedRecord::Decode(std::string_view in) {
  const std::string_view magic("imuqual-run-record v1\0", 22);
  auto bad = [] { return Status::Corruption("malformed signed record"); };
  if (in.substr(0, magic.size()) != magic || in.size() < magic.size() + 8) return bad();
  size_t pos = magic.size();
  auto u64 = [&](uint64_t* v) {
    if (in.size() - pos < 8) return false;
    *v = 0;
    for (int i = 0; i < 8; ++i) *v |= uint64_t{static_cast<uint8_t>(in[pos + i])} << (8 * i);
    pos += 8;
    return true;
  };
  uint64_t count = 0;
  if (!u64(&count)) return bad();
  SignedRecord r;
  for (uint64_t i = 0; i < count; ++i) {
    uint64_t size = 0;
    if (!u64(&size) || in.size() - pos < size) return bad();
    std::string name(in.substr(pos, size));
    pos += size;
    CanonicalValue v;
    if (!CanonicalValue::Parse(in, &pos, &v)) return bad();
    r.items[std::move(name)] = std::move(v);
  }
  if (pos != in.size() || r.items.size() != count) return bad();
  return r;
}

Result<std::vector<std::string>> RunTables(Db& db) {
  std::vector<std::string> tables;
  RawStmt s(db,
            db.postgres()
                ? "SELECT c.relname FROM pg_catalog.pg_attribute a "
                  "JOIN pg_catalog.pg_class c ON c.oid = a.attrelid "
                  "JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace "
                  "WHERE n.nspname = current_schema() AND c.relkind IN ('r', 'p') "
                  "AND NOT c.relispartition "  // raw_chunks' months are raw_chunks
                  "AND a.attname = 'run_key' AND NOT a.attisdropped "
                  "AND c.relname NOT IN ('runs', 'raw_chunks', 'archive_chain') "
                  "ORDER BY c.relname COLLATE \"C\""
                : "SELECT m.name FROM sqlite_schema m, pragma_table_info(m.name) p "
                  "WHERE m.type = 'table' AND p.name = 'run_key' AND m.name NOT LIKE 'sqlite_%' "
                  "AND m.name NOT IN ('runs', 'raw_chunks', 'archive_chain') ORDER BY m.name");
  IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
    tables.push_back(row.Text(0));
    return Status::Ok();
  }));
  return tables;
}

Result<SignedRecord> ComputeRunRecord(Db& db, int64_t run_key, ChunkDigests how,
                                      ChunkFindings* findings,
                                      const std::vector<std::string>* known_tables) {
  SignedRecord record;
  bool found = false;
  // A plant archive's runs also say which station archive shipped them.
  std::vector<std::string> excluded = RunColumnExclusions();
  if (db.postgres()) excluded.push_back("station_archive");
  {
    RawStmt s(db, "SELECT * FROM runs WHERE run_key = ?");
    s.Bind(1, run_key);
    IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
      found = true;
      for (auto& [name, value] : RowFromStatement(row, excluded)) {
        if (value.is_null()) continue;
        record.items["runs." + name] = value.type == CanonicalValue::Type::kBlob
                                           ? CanonicalValue::DigestOf(Blake2b256Of(value.bytes))
                                           : std::move(value);
      }
      return Status::Ok();
    }));
  }
  if (!found) return Status::NotFound("no run with key " + std::to_string(run_key));
  Result<std::vector<std::string>> tables =
      known_tables ? Result<std::vector<std::string>>(*known_tables) : RunTables(db);
  if (!tables.ok()) return tables.status();
  for (const std::string& table : *tables) {
    IMUQUAL_RETURN_IF_ERROR(AddTableItems(db, table, run_key, &record));
  }
  IMUQUAL_RETURN_IF_ERROR(AddChunkItems(db, run_key, how, findings, &record));
  return record;
}

std::string ChainEntry::Body() const {
  std::string out("imuqual-chain v1\0", 17);
  AppendU64(&out, static_cast<uint64_t>(entry));
  AppendSized(&out, kind);
  AppendSized(&out, run_id);
  AppendU64(&out, static_cast<uint64_t>(revision));
  const Digest record_digest = Blake2b256Of(record);
  out.append(reinterpret_cast<const char*>(record_digest.data()), record_digest.size());
  AppendU64(&out, static_cast<uint64_t>(created_utime));
  AppendSized(&out, key_id);
  out.append(reinterpret_cast<const char*>(prev_hash.data()), prev_hash.size());
  return out;
}

Digest ChainEntry::ComputeHash() const {
  Blake2b256 h;
  h.Update(std::string_view("imuqual-chain-link v1\0", 22));
  h.Update(Body());
  h.Sized(signature);
  return h.Final();
}

bool EntrySignatureVerifies(const ChainEntry& entry, const PublicKey& key) {
  Signature signature{};
  if (entry.signature.size() != signature.size()) return false;
  std::copy(entry.signature.begin(), entry.signature.end(),
            reinterpret_cast<char*>(signature.data()));
  const std::string body = entry.Body();
  return VerifySignature(key, signature, body.data(), body.size());
}

Status AppendRunEntry(Db& db, int64_t run_key, const std::string& kind, const SigningKey* key,
                      int64_t utime) {
  ChainEntry e;
  e.kind = kind;
  e.created_utime = utime;
  {
    RawStmt s(db, "SELECT run_id, revision FROM runs WHERE run_key = ?");
    s.Bind(1, run_key);
    bool found = false;
    IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
      found = true;
      e.run_id = row.Text(0);
      e.revision = row.Int(1);
      return Status::Ok();
    }));
    if (!found) return Status::NotFound("no run with key " + std::to_string(run_key));
  }
  auto record = ComputeRunRecord(db, run_key, ChunkDigests::kStored);
  if (!record.ok()) return record.status();
  e.record = record->Encode();
  return InsertEntry(db, e, key).WithContext("chain entry of run " + e.run_id);
}

Status AppendMigrationEntry(Db& db, int64_t utime) {
  std::vector<std::string> ids;
  RawStmt s(db, "SELECT run_id FROM runs");
  IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
    ids.push_back(row.Text(0));
    return Status::Ok();
  }));
  if (ids.empty()) return Status::Ok();
  std::sort(ids.begin(), ids.end());
  std::string listed;
  for (const std::string& id : ids) listed += id + "\n";
  SignedRecord record;
  record.items["legacy_runs"] = CanonicalValue::Text(listed);
  record.items["legacy_runs.count"] = CanonicalValue::Integer(static_cast<int64_t>(ids.size()));
  ChainEntry e;
  e.kind = kEntryMigrated;
  e.created_utime = utime;
  e.record = record.Encode();
  return InsertEntry(db, e, nullptr);
}

namespace {

ChainEntry EntryFromRow(const Stmt& row) {
  ChainEntry e;
  e.entry = row.Int(0);
  e.kind = row.Text(1);
  e.run_id = row.Text(2);
  e.revision = row.Int(3);
  e.record = BlobOf(row, 4);
  e.created_utime = row.Int(5);
  e.key_id = row.Text(6);
  e.signature = BlobOf(row, 7);
  e.prev_hash = DigestOfColumn(row, 8);
  e.entry_hash = DigestOfColumn(row, 9);
  return e;
}

constexpr char kEntryColumns[] =
    "SELECT entry, kind, run_id, revision, record, created_utime, key_id, signature, prev_hash, "
    "entry_hash FROM archive_chain";

}  // namespace

Result<std::vector<ChainEntry>> ReadChain(Db& db) {
  std::vector<ChainEntry> entries;
  IMUQUAL_RETURN_IF_ERROR(ForEachChainEntry(db, [&](const ChainEntry& e) {
    entries.push_back(e);
    return Status::Ok();
  }));
  return entries;
}

Status ForEachChainEntry(Db& db, const std::function<Status(const ChainEntry&)>& fn) {
  RawStmt s(db, std::string(kEntryColumns) + " ORDER BY entry");
  return s.ForEach([&](const Stmt& row) { return fn(EntryFromRow(row)); });
}

Status ForEachPlantChainEntry(Db& plant, const std::string& archive_id,
                              const std::function<Status(const ChainEntry&)>& fn) {
  RawStmt s(plant, std::string(kEntryColumns) + " WHERE archive_id = ? ORDER BY entry");
  s.Bind(1, archive_id);
  return s.ForEach([&](const Stmt& row) { return fn(EntryFromRow(row)); });
}

Result<std::vector<ChainEntry>> ReadChainFrom(Db& db, int64_t first) {
  RawStmt s(db, std::string(kEntryColumns) + " WHERE entry >= ? ORDER BY entry");
  s.Bind(1, first);
  std::vector<ChainEntry> entries;
  IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
    entries.push_back(EntryFromRow(row));
    return Status::Ok();
  }));
  return entries;
}

Result<std::optional<ChainEntry>> ReadChainEntry(Db& db, int64_t entry) {
  RawStmt s(db, std::string(kEntryColumns) + " WHERE entry = ?");
  s.Bind(1, entry);
  std::optional<ChainEntry> found;
  IMUQUAL_RETURN_IF_ERROR(s.ForEach([&](const Stmt& row) {
    found = EntryFromRow(row);
    return Status::Ok();
  }));
  return found;
}

std::string ChainHead::ToText() const {
  return std::to_string(entries) + ":" + HexOf(hash.data(), hash.size());
}

bool ChainHead::Parse(std::string_view text, ChainHead* head) {
  const size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0) return false;
  int64_t n = 0;
  for (char c : text.substr(0, colon)) {
    if (c < '0' || c > '9' || n > (INT64_MAX - 9) / 10) return false;
    n = n * 10 + (c - '0');
  }
  const std::string_view hex = text.substr(colon + 1);
  if (hex.size() != 2 * kDigestBytes || !ParseHex(hex, head->hash.data(), head->hash.size())) {
    return false;
  }
  head->entries = n;
  return true;
}

Result<ChainHead> ReadChainHead(Db& db) {
  ChainHead head;
  IMUQUAL_RETURN_IF_ERROR(ChainTail(db, &head.entries, &head.hash));
  return head;
}

}  // namespace imuqual::store
