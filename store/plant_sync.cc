#include "store/plant_sync.h"

#include <algorithm>
#include <ctime>
#include <map>
#include <optional>
#include <set>

#include "common/clock.h"
#include "store/canonical.h"
#include "store/chain.h"

namespace imuqual::store {
namespace {

// A run's tables besides runs, in the order they are filled (parents
// first); replaced in the reverse order.
constexpr const char* kRunTables[] = {"run_axes",     "gaps",         "curves",
                                      "curve_points", "measurements", "superseded_judgements",
                                      "raw_chunks"};

// Bounds of one multi-row INSERT.
constexpr size_t kMaxParams = 2000;
constexpr size_t kMaxBytes = 8 << 20;

struct Value {
  Stmt::Type type = Stmt::Type::kNull;
  int64_t integer = 0;
  double real = 0;
  std::string bytes;
};

Value ValueOf(const Stmt& s, int col) {
  Value v;
  v.type = s.ColumnType(col);
  switch (v.type) {
    case Stmt::Type::kInt:
      v.integer = s.Int(col);
      break;
    case Stmt::Type::kReal:
      v.real = s.Real(col);
      break;
    case Stmt::Type::kText:
      v.bytes = s.Text(col);
      break;
    case Stmt::Type::kBlob: {
      const std::vector<uint8_t> b = s.Blob(col);
      v.bytes.assign(b.begin(), b.end());
      break;
    }
    case Stmt::Type::kNull:
      break;
  }
  return v;
}

void BindValue(Stmt& s, int i, const Value& v) {
  switch (v.type) {
    case Stmt::Type::kInt:
      s.Bind(i, v.integer);
      break;
    case Stmt::Type::kReal:
      s.Bind(i, v.real);
      break;
    case Stmt::Type::kText:
      s.Bind(i, std::string_view(v.bytes));
      break;
    case Stmt::Type::kBlob:
      s.BindBlob(i, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(v.bytes.data()),
                                             v.bytes.size()));
      break;
    case Stmt::Type::kNull:
      s.BindNull(i);
      break;
  }
}

// A name as an SQL identifier (the plant's column names come from its
// catalog: quoted, any quote in them doubled).
std::string Quoted(const std::string& name) {
  std::string out = "\"";
  for (char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string ColumnList(const std::vector<std::string>& columns) {
  std::string out;
  for (const std::string& c : columns) out += (out.empty() ? "" : ", ") + Quoted(c);
  return out;
}

std::string Hex(const Digest& d) { return HexOf(d.data(), d.size()); }

// The items where two records differ, for the refusal ("runs.verdict,
// measurements").
std::string DifferingItems(const std::string& signed_bytes, const SignedRecord& held) {
  auto expected = SignedRecord::Decode(signed_bytes);
  if (!expected.ok()) return "the signed record does not decode";
  std::vector<std::string> names;
  std::set<std::string> all;
  for (const auto& [n, v] : expected->items) all.insert(n);
  for (const auto& [n, v] : held.items) all.insert(n);
  for (const std::string& n : all) {
    auto a = expected->items.find(n);
    auto b = held.items.find(n);
    if (a == expected->items.end() || b == held.items.end() || a->second != b->second) {
      names.push_back(n);
    }
  }
  std::string out;
  for (size_t i = 0; i < names.size() && i < 6; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > 6) out += ", ... (" + std::to_string(names.size() - 6) + " more)";
  return out;
}

// YYYYMM of a time (UTC): the month of raw_chunks' partition.
int MonthOf(int64_t utime) {
  const std::time_t secs = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return (tm.tm_year + 1900) * 100 + tm.tm_mon + 1;
}

class Shipper {
 public:
  Shipper(Db& station, Db& plant, const SyncOptions& options, SyncReport* report)
      : station_(station), plant_(plant), options_(options), report_(report) {}

  // The plant's columns of `table` but its run key and the plant's own.
  Result<std::vector<std::string>> Columns(const std::string& table) {
    auto it = columns_.find(table);
    if (it != columns_.end()) return it->second;
    auto s = plant_.Prepare(
        "SELECT column_name FROM information_schema.columns WHERE table_schema = "
        "current_schema() AND table_name = ?1 ORDER BY ordinal_position");
    if (!s.ok()) return s.status();
    s->Bind(1, table);
    std::vector<std::string> cols;
    for (;;) {
      auto row = s->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      const std::string c = s->Text(0);
      if (c == "month" && table == "raw_chunks") {
        chunk_months_ = true;  // partitioned by month (plant schema 2)
        continue;
      }
      if (c != "run_key" && c != "station_archive") cols.push_back(c);
    }
    if (cols.empty()) return Status::Corruption("the plant archive has no table " + table);
    return columns_[table] = cols;
  }

  // Copies the run's rows of `table` from the station to the plant's run
  // `plant_key`, many rows per statement.
  // `month`: the run's start month (YYYYMM, UTC), raw_chunks' partition.
  Status CopyRows(const std::string& table, int64_t station_key, int64_t plant_key, int month) {
    auto columns = Columns(table);
    if (!columns.ok()) return columns.status();
    const std::vector<std::string>& cols = *columns;
    const bool by_month = table == "raw_chunks" && chunk_months_;
    auto read = station_.Prepare("SELECT " + ColumnList(cols) + " FROM " + Quoted(table) +
                                 " WHERE run_key = ?1");
    if (!read.ok()) {
      return Status::Corruption("station archive: " + table + ": " + read.status().message());
    }
    read->Bind(1, station_key);
    const bool chunks = table == "raw_chunks";
    std::vector<std::vector<Value>> rows;
    size_t bytes = 0;
    auto flush = [&]() -> Status {
      if (rows.empty()) return Status::Ok();
      if (by_month) IMUQUAL_RETURN_IF_ERROR(EnsureMonth(month));
      // The run key (and month) are parameters too, so that the text
      // repeats from run to run for the same number of rows and the plant
      // parses and plans it once (the connection keeps it prepared).
      std::string sql = "INSERT INTO " + Quoted(table) + " (run_key, " +
                        (by_month ? "month, " : "") + ColumnList(cols) + ") VALUES ";
      const int fixed = by_month ? 2 : 1;
      int n = fixed;
      for (size_t r = 0; r < rows.size(); ++r) {
        sql += r ? ", (?1" : "(?1";
        if (by_month) sql += ", ?2";
        for (size_t c = 0; c < cols.size(); ++c) sql += ", ?" + std::to_string(++n);
        sql += ")";
      }
      // A chunk is immutable once archived: one already at the plant is
      // kept (the run's record check below sees whether it is the same).
      if (chunks) sql += " ON CONFLICT DO NOTHING";
      auto w = plant_.Prepare(sql);
      if (!w.ok()) return w.status();
      w->Bind(1, plant_key);
      if (by_month) w->Bind(2, static_cast<int64_t>(month));
      n = fixed;
      for (const auto& row : rows) {
        for (const Value& v : row) BindValue(*w, ++n, v);
      }
      IMUQUAL_RETURN_IF_ERROR(w->Run());
      const int64_t inserted = plant_.Changes();
      report_->rows_inserted += inserted;
      if (chunks) report_->chunks_inserted += inserted;
      rows.clear();
      bytes = 0;
      return Status::Ok();
    };
    for (;;) {
      auto row = read->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      std::vector<Value> values;
      values.reserve(cols.size());
      for (size_t c = 0; c < cols.size(); ++c) {
        values.push_back(ValueOf(*read, static_cast<int>(c)));
        bytes += values.back().bytes.size();
        if (chunks && cols[c] == "data") report_->chunk_bytes += values.back().bytes.size();
      }
      rows.push_back(std::move(values));
      if ((rows.size() + 1) * cols.size() + 2 > kMaxParams || bytes > kMaxBytes) {
        IMUQUAL_RETURN_IF_ERROR(flush());
      }
    }
    return flush();
  }

  // Raw chunks' partition of `month` (YYYYMM): created if missing, when
  // this role may (the owner of raw_chunks); else the month's chunks go to
  // the default partition, said once in the report.
  Status EnsureMonth(int month) {
    if (months_known_.count(month)) return Status::Ok();
    const std::string name = "raw_chunks_" + std::to_string(month);
    auto exists = plant_.Prepare(
        "SELECT count(*) FROM pg_catalog.pg_inherits i JOIN pg_catalog.pg_class c ON c.oid = "
        "i.inhrelid WHERE i.inhparent = 'raw_chunks'::regclass AND c.relname = ?1");
    if (!exists.ok()) return exists.status();
    exists->Bind(1, name);
    auto row = exists->Step();
    if (!row.ok()) return row.status();
    const bool there = *row && exists->Int(0) > 0;
    exists->Reset();
    if (!there) {
      const int next = month % 100 == 12 ? (month / 100 + 1) * 100 + 1 : month + 1;
      IMUQUAL_RETURN_IF_ERROR(plant_.Exec("SAVEPOINT month_partition"));
      const Status made =
          plant_.Exec("CREATE TABLE IF NOT EXISTS " + Quoted(name) +
                      " PARTITION OF raw_chunks FOR VALUES "
                      "FROM (" +
                      std::to_string(month) + ") TO (" + std::to_string(next) + "); ALTER TABLE " +
                      Quoted(name) + " ALTER COLUMN data SET STORAGE EXTERNAL");
      if (!made.ok()) {
        IMUQUAL_RETURN_IF_ERROR(plant_.Exec("ROLLBACK TO SAVEPOINT month_partition"));
        if (report_->partition_note.empty()) {
          report_->partition_note = "raw chunks of " + std::to_string(month) +
                                    " went to the default partition: " + made.message();
        }
      }
      IMUQUAL_RETURN_IF_ERROR(plant_.Exec("RELEASE SAVEPOINT month_partition"));
    }
    months_known_.insert(month);
    return Status::Ok();
  }

  // A plant transaction's partitions are known only once it commits.
  // A lot's or unit's row, if the plant lacks it; first seen at the plant
  // when the first station saw it.
  Status CopyKeyRow(const std::string& table, const std::string& key_column,
                    const std::string& key) {
    auto read = station_.Prepare("SELECT first_seen_utime FROM " + Quoted(table) + " WHERE " +
                                 Quoted(key_column) + " = ?1");
    if (!read.ok()) return read.status();
    read->Bind(1, key);
    auto row = read->Step();
    if (!row.ok()) return row.status();
    if (!*row) return Status::Corruption("station archive: no " + table + " row for '" + key + "'");
    auto w =
        plant_.Prepare("INSERT INTO " + Quoted(table) + " (" + Quoted(key_column) +
                       ", first_seen_utime) VALUES (?1, ?2) ON CONFLICT (" + Quoted(key_column) +
                       ") DO UPDATE SET first_seen_utime = EXCLUDED.first_seen_utime WHERE " +
                       Quoted(table) + ".first_seen_utime > EXCLUDED.first_seen_utime");
    if (!w.ok()) return w.status();
    w->Bind(1, key).Bind(2, read->Int(0));
    IMUQUAL_RETURN_IF_ERROR(w->Run());
    report_->rows_inserted += plant_.Changes();
    return Status::Ok();
  }

  // The station id `station_id` held by `archive_id` at the plant: claimed
  // now if no archive holds it; moved to it from the archive that holds it
  // when this sync names it that station's new archive; else a refusal in
  // *refusal.
  Status ClaimStation(const std::string& station_id, const std::string& archive_id,
                      std::string* refusal) {
    if (claimed_in_transaction_.count(station_id)) return Status::Ok();
    auto held = plant_.Prepare(
        "SELECT archive_id, claimed_utime, previous_archive FROM station_ids WHERE station = ?1 "
        "FOR UPDATE");
    if (!held.ok()) return held.status();
    held->Bind(1, station_id);
    auto h = held->Step();
    if (!h.ok()) return h.status();
    const bool found = *h;
    const std::string holder = found ? held->Text(0) : "";
    const int64_t since = found ? held->Int(1) : 0;
    const std::string before = found && !held->IsNull(2) ? held->Text(2) : "";
    held->Reset();
    const int64_t now = NowUtime();
    if (!found) {
      auto claim = plant_.Prepare(
          "INSERT INTO station_ids (station, archive_id, claimed_utime, claimed_by) "
          "VALUES (?1, ?2, ?3, ?4)");
      if (!claim.ok()) return claim.status();
      claim->Bind(1, station_id).Bind(2, archive_id).Bind(3, now).Bind(4, options_.claimed_by);
      IMUQUAL_RETURN_IF_ERROR(claim->Run());
    } else if (holder != archive_id) {
      if (before == archive_id) {
        *refusal = "station id " + station_id + " moved from this station archive to archive " +
                   holder.substr(0, 16) + "... at " + FormatUtimeIso(since) +
                   " (its new archive): this one may not ship runs of it any more";
        return Status::Ok();
      }
      if (options_.new_archive_of != station_id) {
        *refusal = "station id " + station_id +
                   " is held at the plant by another station archive (" + holder.substr(0, 16) +
                   "..., since " + FormatUtimeIso(since) +
                   "): two stations claim one station id (give each station its own id; a "
                   "rebuilt station's new archive is named with --new-archive-of " +
                   station_id + ")";
        return Status::Ok();
      }
      auto move = plant_.Prepare(
          "UPDATE station_ids SET archive_id = ?2, claimed_utime = ?3, previous_archive = ?4, "
          "claimed_by = ?5 WHERE station = ?1");
      if (!move.ok()) return move.status();
      move->Bind(1, station_id)
          .Bind(2, archive_id)
          .Bind(3, now)
          .Bind(4, holder)
          .Bind(5, options_.claimed_by);
      IMUQUAL_RETURN_IF_ERROR(move->Run());
      if (report_->station_moved.empty()) {
        report_->station_moved = "station id " + station_id + " moved to this archive from " +
                                 holder.substr(0, 16) + "...";
      }
    }
    claimed_in_transaction_.insert(station_id);
    return Status::Ok();
  }

  // A plant transaction begins (what was claimed in one rolled back is not
  // claimed any more).
  void NewTransaction() {
    claimed_in_transaction_.clear();
    months_known_.clear();
  }

  // Copies run `run_id` with everything it holds; the plant's run key, or
  // a refusal in *refusal (nothing written then).
  Result<int64_t> CopyRun(const std::string& run_id, const std::string& archive_id,
                          std::string* refusal) {
    auto skey_q =
        station_.Prepare("SELECT run_key, lot, serial, station FROM runs WHERE run_id = ?1");
    if (!skey_q.ok()) return skey_q.status();
    skey_q->Bind(1, run_id);
    auto found = skey_q->Step();
    if (!found.ok()) return found.status();
    if (!*found) {
      *refusal = "run " + run_id + " is in the station's chain but not in its runs (deleted?)";
      return 0;
    }
    const int64_t skey = skey_q->Int(0);
    const std::string lot = skey_q->Text(1), serial = skey_q->Text(2), station_id = skey_q->Text(3);
    skey_q->Reset();
    IMUQUAL_RETURN_IF_ERROR(ClaimStation(station_id, archive_id, refusal));
    if (!refusal->empty()) return 0;

    auto held = plant_.Prepare("SELECT run_key, station_archive FROM runs WHERE run_id = ?1");
    if (!held.ok()) return held.status();
    held->Bind(1, run_id);
    auto h = held->Step();
    if (!h.ok()) return h.status();
    std::optional<int64_t> pkey;
    if (*h) {
      if (held->Text(1) != archive_id) {
        *refusal = "run " + run_id + " is already at the plant from another station archive (" +
                   held->Text(1).substr(0, 16) +
                   "...): two stations claim one run id (the same station id on two hosts?)";
        return 0;
      }
      pkey = held->Int(0);
    }
    held->Reset();

    IMUQUAL_RETURN_IF_ERROR(CopyKeyRow("lots", "lot", lot));
    IMUQUAL_RETURN_IF_ERROR(CopyKeyRow("units", "serial", serial));

    auto columns = Columns("runs");
    if (!columns.ok()) return columns.status();
    const std::vector<std::string>& cols = *columns;
    auto read = station_.Prepare("SELECT " + ColumnList(cols) + " FROM runs WHERE run_key = ?1");
    if (!read.ok()) return Status::Corruption("station archive: runs: " + read.status().message());
    read->Bind(1, skey);
    auto row = read->Step();
    if (!row.ok()) return row.status();
    if (!*row) return Status::Corruption("station archive: run " + run_id + " vanished");
    std::string sql;
    if (pkey) {
      // Judged again since it was shipped: its rows are replaced (the
      // superseded rounds come with the new ones).
      for (auto t = std::rbegin(kRunTables); t != std::rend(kRunTables); ++t) {
        if (std::string(*t) == "raw_chunks") continue;
        IMUQUAL_RETURN_IF_ERROR(
            plant_.Exec("DELETE FROM " + Quoted(*t) + " WHERE run_key = " + std::to_string(*pkey)));
      }
      sql = "UPDATE runs SET ";
      for (size_t c = 0; c < cols.size(); ++c) {
        sql += (c ? ", " : "") + Quoted(cols[c]) + " = ?" + std::to_string(c + 1);
      }
      sql += ", station_archive = ?" + std::to_string(cols.size() + 1) +
             " WHERE run_key = " + std::to_string(*pkey) + " RETURNING run_key";
      ++report_->runs_replaced;
    } else {
      sql = "INSERT INTO runs (" + ColumnList(cols) + ", station_archive) VALUES (";
      for (size_t c = 0; c <= cols.size(); ++c) sql += (c ? ", ?" : "?") + std::to_string(c + 1);
      sql += ") RETURNING run_key";
    }
    auto w = plant_.Prepare(sql);
    if (!w.ok()) return w.status();
    int64_t start_utime = 0;
    for (size_t c = 0; c < cols.size(); ++c) {
      BindValue(*w, static_cast<int>(c + 1), ValueOf(*read, static_cast<int>(c)));
      if (cols[c] == "start_utime") start_utime = read->Int(static_cast<int>(c));
    }
    read->Reset();
    w->Bind(static_cast<int>(cols.size() + 1), archive_id);
    auto written = w->Step();
    if (!written.ok()) return written.status();
    if (!*written) return Status::Corruption("plant archive: run " + run_id + " not written");
    const int64_t key = w->Int(0);
    w->Reset();
    report_->rows_inserted += 1;
    const int month = MonthOf(start_utime);
    for (const char* t : kRunTables) IMUQUAL_RETURN_IF_ERROR(CopyRows(t, skey, key, month));
    ++report_->runs_shipped;
    return key;
  }

  // The run's record as the plant now holds it against `expected` (the
  // record the station signed, or computed from the station's rows): ""
  // when they are equal, else what differs.
  Result<std::string> Check(int64_t plant_key, const std::string& expected) {
    if (run_tables_.empty()) {
      auto tables = RunTables(plant_);
      if (!tables.ok()) return tables.status();
      run_tables_ = std::move(*tables);
    }
    ChunkFindings findings;
    auto held =
        ComputeRunRecord(plant_, plant_key, ChunkDigests::kRecomputed, &findings, &run_tables_);
    if (!held.ok()) return held.status();
    if (held->Encode() == expected) return std::string();
    return DifferingItems(expected, *held);
  }

 private:
  Db& station_;
  Db& plant_;
  const SyncOptions& options_;
  std::set<std::string> claimed_in_transaction_;  // station ids this archive holds
  bool chunk_months_ = false;                     // raw_chunks is partitioned by month
  std::set<int> months_known_;                    // partitions seen or made in this transaction
  SyncReport* report_;
  std::map<std::string, std::vector<std::string>> columns_;
  std::vector<std::string> run_tables_;
};

const PublicKey* FindKey(const std::vector<PublicKey>& keys, const std::string& id) {
  for (const PublicKey& k : keys) {
    if (k.Id() == id) return &k;
  }
  return nullptr;
}

// "" when the entry links to `prev` and its stored hash and signature hold.
std::string EntryProblem(const ChainEntry& e, int64_t number, const Digest& prev,
                         const SyncOptions& o) {
  const std::string label =
      "chain entry " + std::to_string(number) + (e.run_id.empty() ? "" : " (run " + e.run_id + ")");
  if (e.entry != number) return label + ": numbered " + std::to_string(e.entry);
  if (e.prev_hash != prev) return label + ": does not link to the entry before it";
  if (e.ComputeHash() != e.entry_hash) return label + ": its stored hash does not match it";
  if (o.trusted.empty()) return "";
  if (e.signature.empty()) {
    const bool migration = e.kind == kEntryMigrated;
    return o.require_signatures && !migration ? label + ": unsigned, and signatures are required"
                                              : "";
  }
  const PublicKey* key = FindKey(o.trusted, e.key_id);
  if (key == nullptr) return label + ": signed by an unknown key (key id " + e.key_id + ")";
  if (key->role != "store") return label + ": signed by a " + key->role + " key, not a store key";
  if (!EntrySignatureVerifies(e, *key)) return label + ": its signature does not verify";
  return "";
}

// The runs a migration entry lists (archived before the chain).
std::vector<std::string> LegacyRuns(const ChainEntry& e) {
  std::vector<std::string> ids;
  auto record = SignedRecord::Decode(e.record);
  if (!record.ok()) return ids;
  auto it = record->items.find("legacy_runs");
  if (it == record->items.end()) return ids;
  const std::string& text = it->second.bytes;
  size_t start = 0;
  while (start < text.size()) {
    const size_t end = text.find('\n', start);
    if (end == std::string::npos) break;
    ids.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return ids;
}

// Keeps the station's reads in one snapshot (a store may be writing).
class ReadSnapshot {
 public:
  explicit ReadSnapshot(Db& db) : db_(db) { open_ = db_.Exec("BEGIN").ok(); }
  ~ReadSnapshot() {
    if (open_) (void)db_.Exec("COMMIT");
  }

 private:
  Db& db_;
  bool open_ = false;
};

}  // namespace

namespace {

// The plant's cursor for one station archive, locked for the transaction
// (two syncs of one archive take turns), registering the archive first.
Result<int64_t> LockCursor(Db& plant, const std::string& archive_id, const std::string& station,
                           const std::string& source) {
  const int64_t now = NowUtime();
  auto reg = plant.Prepare(
      "INSERT INTO station_archives (archive_id, station, source, first_synced_utime, "
      "last_synced_utime) VALUES (?1, ?2, ?3, ?4, ?4) ON CONFLICT DO NOTHING");
  if (!reg.ok()) return reg.status();
  reg->Bind(1, archive_id).Bind(2, station).Bind(3, source).Bind(4, now);
  IMUQUAL_RETURN_IF_ERROR(reg->Run());
  auto cur = plant.Prepare(
      "SELECT shipped_entries FROM station_archives WHERE archive_id = ?1 FOR UPDATE");
  if (!cur.ok()) return cur.status();
  cur->Bind(1, archive_id);
  auto got = cur->Step();
  if (!got.ok()) return got.status();
  if (!*got)
    return Status::Corruption("plant archive: station archive " + archive_id + " vanished");
  return cur->Int(0);
}

// The hash the plant holds for the archive's entry `n`.
Result<std::vector<uint8_t>> PlantEntryHash(Db& plant, const std::string& archive_id, int64_t n) {
  auto at =
      plant.Prepare("SELECT entry_hash FROM archive_chain WHERE archive_id = ?1 AND entry = ?2");
  if (!at.ok()) return at.status();
  at->Bind(1, archive_id).Bind(2, n);
  auto row = at->Step();
  if (!row.ok()) return row.status();
  return *row ? at->Blob(0) : std::vector<uint8_t>();
}

}  // namespace

Result<SyncReport> SyncToPlant(Archive& station_archive, Archive& plant_archive,
                               const SyncOptions& o) {
  if (!plant_archive.postgres()) {
    return Status::InvalidArgument("the plant archive must be PostgreSQL (postgresql://...), not " +
                                   plant_archive.path());
  }
  if (station_archive.postgres()) {
    return Status::InvalidArgument("a station archive is an SQLite file, not " +
                                   station_archive.path());
  }
  Db& station = station_archive.db();
  Db& plant = plant_archive.db();
  SyncReport report;
  ReadSnapshot snapshot(station);
  auto head = ReadChainHead(station);
  if (!head.ok()) return head.status();
  const int64_t total = head->entries;
  report.station_entries = total;
  if (total == 0) return report;  // no finalised run yet
  auto first = ReadChainEntry(station, 1);
  if (!first.ok()) return first.status();
  if (!first->has_value()) return Status::Corruption("station archive: its chain has no entry 1");
  report.archive_id = Hex((*first)->entry_hash);

  // The unshipped tail of the station's chain, read at the first batch.
  std::vector<ChainEntry> tail;
  int64_t tail_from = 0;                      // entry number of tail[0]
  Digest tail_prev{};                         // the hash tail[0] links to
  std::map<std::string, int64_t> last_entry;  // run id -> its last entry in the tail
  std::string station_name;
  Shipper shipper(station, plant, o, &report);
  bool first_batch = true;
  // A refusal found in a batch: the batch is rolled back and shipped again
  // up to the refused entry, then shipping stops there.
  int64_t refused_at = -1;
  std::string refusal_found;
  for (;;) {
    IMUQUAL_RETURN_IF_ERROR(plant.BeginWrite());
    shipper.NewTransaction();
    auto fail = [&](const Status& st) {
      (void)plant.Exec("ROLLBACK");
      return st;
    };
    auto done_here = [&]() {
      (void)plant.Exec("ROLLBACK");
      return report;
    };
    auto locked = LockCursor(plant, report.archive_id, station_name, station_archive.path());
    if (!locked.ok()) return fail(locked.status());
    const int64_t shipped = *locked;
    if (first_batch) {
      report.shipped_before = shipped;
      // The plant's last entry of this archive against the station's.
      if (shipped > 0) {
        const int64_t n = std::min(shipped, total);
        auto theirs = PlantEntryHash(plant, report.archive_id, n);
        if (!theirs.ok()) return fail(theirs.status());
        auto mine = ReadChainEntry(station, n);
        if (!mine.ok()) return fail(mine.status());
        const bool same = mine->has_value() && theirs->size() == kDigestBytes &&
                          std::equal(theirs->begin(), theirs->end(), (*mine)->entry_hash.begin());
        if (!same) {
          report.refusal = "the station's chain entry " + std::to_string(n) +
                           " is not the one the plant holds: the station archive was edited, or "
                           "is another archive with the same first entry; nothing shipped";
          report.shipped_after = shipped;
          return done_here();
        }
        if (shipped > total) {
          report.behind = true;
          report.shipped_after = shipped;
          return done_here();
        }
        tail_prev = (*mine)->entry_hash;
      }
      if (shipped < total) {
        auto entries = ReadChainFrom(station, shipped + 1);
        if (!entries.ok()) return fail(entries.status());
        tail = std::move(*entries);
        tail_from = shipped + 1;
        for (const ChainEntry& e : tail) {
          if (e.kind == kEntryMigrated) {
            for (const std::string& id : LegacyRuns(e)) last_entry[id] = e.entry;
          } else {
            last_entry[e.run_id] = e.entry;
            if (station_name.empty()) {
              auto info = station_archive.LoadRun(e.run_id);
              if (info.ok()) station_name = info->station;
            }
          }
        }
      }
    }
    const int64_t tail_end = tail_from + static_cast<int64_t>(tail.size()) - 1;  // last entry
    if (!first_batch && (shipped < tail_from - 1 || shipped > tail_end)) {
      // Another sync of this archive moved the cursor meanwhile: it ships.
      report.shipped_after = shipped;
      return done_here();
    }
    first_batch = false;
    report.shipped_after = shipped;
    if (shipped >= std::min(total, tail_end)) return done_here();

    int64_t end = std::min(tail_end, shipped + std::max(1, o.batch_entries));  // last entry
    if (refused_at >= 0) end = std::min(end, refused_at - 1);
    int64_t done = shipped;
    std::string refusal_of_batch;
    for (int64_t number = shipped + 1; number <= end; ++number) {
      const ChainEntry& e = tail[static_cast<size_t>(number - tail_from)];
      const Digest prev = number == tail_from
                              ? tail_prev
                              : tail[static_cast<size_t>(number - 1 - tail_from)].entry_hash;
      std::string refusal = EntryProblem(e, number, prev, o);
      if (refusal.empty()) {
        auto ins = plant.Prepare(
            "INSERT INTO archive_chain (archive_id, entry, kind, run_id, revision, record, "
            "created_utime, key_id, signature, prev_hash, entry_hash) VALUES "
            "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)");
        if (!ins.ok()) return fail(ins.status());
        auto blob = [](const std::string& b) {
          return std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(b.data()), b.size());
        };
        ins->Bind(1, report.archive_id).Bind(2, e.entry).Bind(3, e.kind).Bind(4, e.run_id);
        ins->Bind(5, e.revision).BindBlob(6, blob(e.record)).Bind(7, e.created_utime);
        ins->Bind(8, e.key_id);
        if (e.signature.empty()) {
          ins->BindNull(9);
        } else {
          ins->BindBlob(9, blob(e.signature));
        }
        ins->BindBlob(10, e.prev_hash).BindBlob(11, e.entry_hash);
        if (Status st = ins->Run(); !st.ok()) return fail(st);
        report.rows_inserted += 1;
      }
      // The runs whose rows go with this entry: a run's rows go with its
      // last entry when that one finalised it (a run open again now ships
      // its new round when it is finalised again).
      std::vector<std::string> runs;
      if (refusal.empty() && e.kind == kEntryFinalized && last_entry[e.run_id] == e.entry) {
        runs.push_back(e.run_id);
      }
      if (refusal.empty() && e.kind == kEntryMigrated) {
        for (const std::string& id : LegacyRuns(e)) {
          if (last_entry[id] != e.entry) continue;
          auto fin = station_archive.IsFinalized(id);
          if (!fin.ok()) return fail(fin.status());
          if (*fin) runs.push_back(id);
        }
      }
      for (const std::string& id : runs) {
        auto key = shipper.CopyRun(id, report.archive_id, &refusal);
        if (!key.ok()) return fail(key.status());
        if (!refusal.empty()) break;
        // What the run's record must be: the signed one, or for a run
        // archived before the chain the station's own rows.
        std::string expected = e.record;
        if (e.kind == kEntryMigrated) {
          auto skey = station_archive.FindRunKey(id);
          if (!skey.ok()) return fail(skey.status());
          auto rec = ComputeRunRecord(station, **skey, ChunkDigests::kRecomputed);
          if (!rec.ok()) return fail(rec.status());
          expected = rec->Encode();
        }
        auto diff = shipper.Check(*key, expected);
        if (!diff.ok()) return fail(diff.status());
        if (!diff->empty()) {
          refusal = "run " + id + " (chain entry " + std::to_string(e.entry) +
                    "): the station's rows do not match the record it signed (" + *diff +
                    "): edited after it was signed";
          break;
        }
      }
      if (!refusal.empty()) {
        refusal_of_batch = refusal;
        break;
      }
      done = number;
    }
    if (refused_at < 0 && done < end) {
      // Entry done + 1 was refused: ship the batch again up to it.
      (void)plant.Exec("ROLLBACK");
      refused_at = done + 1;
      refusal_found = refusal_of_batch;
      if (done > shipped) continue;
      report.refusal = refusal_found;
      return report;
    }
    if (done > shipped) {
      auto up = plant.Prepare(
          "UPDATE station_archives SET shipped_entries = ?2, head_hash = ?3, last_synced_utime = "
          "?4, station = CASE WHEN station = '' THEN ?5 ELSE station END WHERE archive_id = ?1");
      if (!up.ok()) return fail(up.status());
      up->Bind(1, report.archive_id).Bind(2, done);
      up->BindBlob(3, tail[static_cast<size_t>(done - tail_from)].entry_hash);
      up->Bind(4, NowUtime()).Bind(5, station_name);
      if (Status st = up->Run(); !st.ok()) return fail(st);
    }
    if (Status st = plant.Exec("COMMIT"); !st.ok()) return fail(st);
    report.shipped_after = done;
    if (o.progress && done > shipped) {
      o.progress("shipped chain entries " + std::to_string(shipped + 1) + ".." +
                 std::to_string(done) + " of " + std::to_string(total));
    }
    if (refused_at >= 0 && done >= refused_at - 1) {
      report.refusal = refusal_found;
      return report;
    }
  }
}

Result<PlantVerifyReport> VerifyPlant(Archive& plant_archive, const SyncOptions& o,
                                      const std::function<void(const std::string&)>& problem) {
  if (!plant_archive.postgres()) {
    return Status::InvalidArgument(plant_archive.path() + " is not a plant archive");
  }
  Db& plant = plant_archive.db();
  PlantVerifyReport report;
  auto say = [&](const std::string& line) {
    ++report.problems;
    problem(line);
  };
  struct Cursor {
    std::string id;
    int64_t shipped = 0;
    std::vector<uint8_t> head;
  };
  std::vector<Cursor> cursors;
  {
    auto s = plant.Prepare(
        "SELECT archive_id, shipped_entries, head_hash FROM station_archives ORDER BY archive_id");
    if (!s.ok()) return s.status();
    for (;;) {
      auto row = s->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      cursors.push_back({s->Text(0), s->Int(1), s->Blob(2)});
    }
  }
  std::map<std::string, std::pair<std::string, std::string>> last;  // run -> (archive, record)
  std::set<std::string> accounted;
  for (const Cursor& c : cursors) {
    ++report.archives;
    const std::string who = "station archive " + c.id.substr(0, 16) + "...";
    Digest prev{};
    int64_t n = 0;
    IMUQUAL_RETURN_IF_ERROR(ForEachPlantChainEntry(plant, c.id, [&](const ChainEntry& e) {
      ++n;
      ++report.entries;
      if (n == 1 && HexOf(e.entry_hash.data(), e.entry_hash.size()) != c.id) {
        say(who + ": its first entry is not the one that names it");
      }
      if (std::string p = EntryProblem(e, n, prev, o); !p.empty()) say(who + ": " + p);
      prev = e.entry_hash;
      if (e.kind == kEntryMigrated) {
        for (const std::string& id : LegacyRuns(e)) last[id] = {c.id, ""};
      } else {
        last[e.run_id] = {c.id, e.kind == kEntryFinalized ? e.record : std::string()};
      }
      return Status::Ok();
    }));
    if (n != c.shipped || !std::equal(c.head.begin(), c.head.end(), prev.begin(), prev.end())) {
      say(who + ": the cursor says " + std::to_string(c.shipped) +
          " entries shipped, the plant "
          "holds " +
          std::to_string(n) + (n == c.shipped ? " ending elsewhere" : ""));
    }
  }
  auto runs = plant.Prepare("SELECT run_key, run_id, station_archive FROM runs ORDER BY run_id");
  if (!runs.ok()) return runs.status();
  std::vector<std::tuple<int64_t, std::string, std::string>> all;
  for (;;) {
    auto row = runs->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    all.emplace_back(runs->Int(0), runs->Text(1), runs->Text(2));
  }
  SyncReport unused;
  const SyncOptions no_options;
  Shipper checker(plant, plant, no_options, &unused);
  for (const auto& [key, id, archive] : all) {
    auto it = last.find(id);
    if (it == last.end() || it->second.first != archive) {
      say("run " + id +
          ": no chain entry of its station archive accounts for it (inserted at "
          "the plant behind the sync's back?)");
      continue;
    }
    if (it->second.second.empty()) continue;  // archived before the chain, or open again
    auto diff = checker.Check(key, it->second.second);
    if (!diff.ok()) return diff.status();
    if (!diff->empty()) {
      say("run " + id + ": the plant's rows do not match its signed record (" + *diff + ")");
    } else {
      ++report.runs_verified;
    }
  }
  return report;
}

}  // namespace imuqual::store
