#include "store/sqlite.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <unordered_map>
#include <vector>

#include "store/postgres.h"

namespace imuqual::store {

// Idle compiled statements of one connection, by SQL text.
class StatementCache {
 public:
  // An idle statement of this text, or nullptr.
  sqlite3_stmt* Take(const std::string& sql) {
    auto it = idle_.find(sql);
    if (it == idle_.end() || it->second.empty()) return nullptr;
    sqlite3_stmt* stmt = it->second.back();
    it->second.pop_back();
    --count_;
    return stmt;
  }
  // Keeps `stmt` reset and unbound for the next Take, or finalizes it (the
  // connection is closed, or enough statements are idle).
  void Give(const std::string& sql, sqlite3_stmt* stmt) {
    std::vector<sqlite3_stmt*>& idle = idle_[sql];
    if (closed_ || idle.size() >= kPerText || count_ >= kTotal) {
      sqlite3_finalize(stmt);
      return;
    }
    sqlite3_reset(stmt);
    sqlite3_clear_bindings(stmt);
    idle.push_back(stmt);
    ++count_;
  }
  // Finalizes every idle statement; later ones are finalized when given.
  void Close() {
    for (auto& [sql, idle] : idle_) {
      for (sqlite3_stmt* stmt : idle) sqlite3_finalize(stmt);
    }
    idle_.clear();
    count_ = 0;
    closed_ = true;
  }

 private:
  static constexpr size_t kPerText = 4;  // nested uses of one text are rare
  static constexpr size_t kTotal = 256;
  std::unordered_map<std::string, std::vector<sqlite3_stmt*>> idle_;
  size_t count_ = 0;
  bool closed_ = false;
};

namespace {

// The statement's first line, shortened, for error messages.
std::string Brief(const std::string& sql) {
  const size_t start = sql.find_first_not_of(" \n\t");
  if (start == std::string::npos) return "";
  std::string s = sql.substr(start, sql.find('\n', start) - start);
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

Status FromCode(int rc, const std::string& what) {
  switch (rc & 0xff) {
    case SQLITE_NOTADB:
    case SQLITE_CORRUPT:
      return Status::Corruption(what);
    case SQLITE_CANTOPEN:
    case SQLITE_READONLY:
    case SQLITE_FULL:
    case SQLITE_IOERR:
    case SQLITE_PERM:
      return Status::IoError(what);
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Status::Unavailable(what);
    default:
      return Status::InvalidArgument(what);
  }
}

}  // namespace

bool IsPostgresUrl(std::string_view path) {
  return path.starts_with("postgresql://") || path.starts_with("postgres://");
}

Result<std::unique_ptr<Db>> Db::Open(const std::string& path, Mode mode) {
  if (IsPostgresUrl(path)) {
    std::string label;
    auto pg = PgConnect(path, mode == Mode::kReadOnly, &label);
    if (!pg.ok()) return pg.status();
    std::unique_ptr<Db> db(new Db(nullptr, label));
    db->pg_ = std::move(*pg);
    return db;
  }
  sqlite3* raw = nullptr;
  const int flags = (mode == Mode::kReadOnly ? SQLITE_OPEN_READONLY
                                             : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) |
                    SQLITE_OPEN_NOMUTEX;
  const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = raw ? sqlite3_errmsg(raw) : sqlite3_errstr(rc);
    sqlite3_close(raw);
    return FromCode(rc, "cannot open database " + path + ": " + msg);
  }
  sqlite3_extended_result_codes(raw, 1);
  sqlite3_busy_timeout(raw, 5000);
  return std::unique_ptr<Db>(new Db(raw, path));
}

Db::Db(sqlite3* db, std::string path)
    : db_(db), path_(std::move(path)), cache_(std::make_shared<StatementCache>()) {}

Db::~Db() {
  cache_->Close();
  if (db_) sqlite3_close_v2(db_);
}

std::string Db::ErrorMessage() const {
  if (pg_) return PgError(pg_->conn);
  return std::string(sqlite3_errmsg(db_)) + " (" + sqlite3_errstr(sqlite3_extended_errcode(db_)) +
         ")";
}

Status Db::Exec(const std::string& sql) {
  if (pg_) return PgExec(*pg_, sql, path_);
  char* err = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    return FromCode(rc, path_ + ": " + msg + " [" + Brief(sql) + "]");
  }
  return Status::Ok();
}

Result<Stmt> Db::Prepare(const std::string& sql) {
  if (pg_) {
    auto q = std::make_unique<PgQuery>();
    q->sql = PgTranslate(sql);
    return Stmt(std::move(q), this, sql);
  }
  if (sqlite3_stmt* idle = cache_->Take(sql)) return Stmt(idle, this, sql, cache_);
  sqlite3_stmt* stmt = nullptr;
  const int rc = sqlite3_prepare_v2(db_, sql.c_str(), static_cast<int>(sql.size()), &stmt, nullptr);
  if (rc != SQLITE_OK) {
    return FromCode(rc, path_ + ": " + ErrorMessage() + " [" + Brief(sql) + "]");
  }
  return Stmt(stmt, this, sql, cache_);
}

Result<int64_t> Db::QueryInt(const std::string& sql) {
  auto stmt = Prepare(sql);
  if (!stmt.ok()) return stmt.status();
  auto row = stmt->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::NotFound("no result for [" + Brief(sql) + "]");
  return stmt->Int(0);
}

int64_t Db::Changes() const { return pg_ ? pg_->changes : sqlite3_changes64(db_); }

bool Db::InAutocommit() const {
  if (pg_) return PQtransactionStatus(pg_->conn) == PQTRANS_IDLE;
  return sqlite3_get_autocommit(db_) != 0;
}

Status Db::BeginWrite() { return Exec(pg_ ? "BEGIN" : "BEGIN IMMEDIATE"); }

Stmt::Stmt(sqlite3_stmt* stmt, Db* db, std::string sql, std::shared_ptr<StatementCache> cache)
    : stmt_(stmt), db_(db), sql_(std::move(sql)), cache_(std::move(cache)) {}

Stmt::Stmt(std::unique_ptr<PgQuery> pg, Db* db, std::string sql)
    : db_(db), sql_(std::move(sql)), pg_(std::move(pg)) {}

Stmt::Stmt(Stmt&& other) noexcept
    : stmt_(other.stmt_),
      db_(other.db_),
      sql_(std::move(other.sql_)),
      cache_(std::move(other.cache_)),
      bind_error_(std::move(other.bind_error_)),
      pg_(std::move(other.pg_)) {
  other.stmt_ = nullptr;
}

Stmt& Stmt::operator=(Stmt&& other) noexcept {
  if (this != &other) {
    Release();
    stmt_ = other.stmt_;
    db_ = other.db_;
    sql_ = std::move(other.sql_);
    cache_ = std::move(other.cache_);
    bind_error_ = std::move(other.bind_error_);
    pg_ = std::move(other.pg_);
    other.stmt_ = nullptr;
  }
  return *this;
}

Stmt::~Stmt() { Release(); }

void Stmt::Release() {
  if (stmt_ == nullptr) return;
  if (cache_) {
    cache_->Give(sql_, stmt_);
  } else {
    sqlite3_finalize(stmt_);
  }
  stmt_ = nullptr;
}

#define IMUQUAL_BIND(call)                                                                         \
  do {                                                                                             \
    const int rc_ = (call);                                                                        \
    if (rc_ != SQLITE_OK && bind_error_.ok()) {                                                    \
      bind_error_ = FromCode(                                                                      \
          rc_, "bind " + std::to_string(i) + " of [" + Brief(sql_) + "]: " + sqlite3_errstr(rc_)); \
    }                                                                                              \
  } while (0)

namespace {
std::string RealText(double v) {
  if (std::isinf(v)) return v > 0 ? "Infinity" : "-Infinity";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
}  // namespace

Stmt& Stmt::Bind(int i, int64_t v) {
  if (pg_) {
    pg_->Set(i, std::to_string(v), false);
    return *this;
  }
  IMUQUAL_BIND(sqlite3_bind_int64(stmt_, i, v));
  return *this;
}
Stmt& Stmt::Bind(int i, double v) {
  if (std::isnan(v)) return BindNull(i);
  if (pg_) {
    pg_->Set(i, RealText(v), false);
    return *this;
  }
  IMUQUAL_BIND(sqlite3_bind_double(stmt_, i, v));
  return *this;
}
Stmt& Stmt::Bind(int i, std::string_view v) {
  if (pg_) {
    pg_->Set(i, std::string(v), false);
    return *this;
  }
  IMUQUAL_BIND(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::BindBlob(int i, std::span<const uint8_t> v) {
  // A zero-length blob must still be a blob, not NULL.
  static const uint8_t kEmpty = 0;
  if (pg_) {
    pg_->Set(i, std::string(v.begin(), v.end()), true);
    return *this;
  }
  IMUQUAL_BIND(sqlite3_bind_blob(stmt_, i, v.empty() ? &kEmpty : v.data(),
                                 static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::BindNull(int i) {
  if (pg_) {
    pg_->Set(i, std::nullopt, false);
    return *this;
  }
  IMUQUAL_BIND(sqlite3_bind_null(stmt_, i));
  return *this;
}
#undef IMUQUAL_BIND

Result<bool> Stmt::Step() {
  if (pg_) return PgStep(*db_->pg_, *pg_, db_->path());
  if (!bind_error_.ok()) {
    Status st = bind_error_;
    bind_error_ = Status::Ok();
    sqlite3_reset(stmt_);
    return st;
  }
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  Status st = FromCode(rc, db_->path() + ": " + db_->ErrorMessage() + " [" + Brief(sql_) + "]");
  sqlite3_reset(stmt_);
  return st;
}

Status Stmt::Run() {
  Result<bool> r = Step();
  while (r.ok() && *r) r = Step();
  Reset();
  return r.ok() ? Status::Ok() : r.status();
}

void Stmt::Reset() {
  if (pg_) {
    pg_->Clear();
    return;
  }
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

namespace {
const char* PgValue(const PgQuery& q, int col) {
  if (q.result == nullptr || q.row < 0 || q.row >= PQntuples(q.result)) return nullptr;
  if (col < 0 || col >= PQnfields(q.result) || PQgetisnull(q.result, q.row, col)) return nullptr;
  return PQgetvalue(q.result, q.row, col);
}
}  // namespace

int64_t Stmt::Int(int col) const {
  if (pg_) {
    const char* v = PgValue(*pg_, col);
    if (v == nullptr) return 0;
    if (v[0] == 't' && v[1] == 0) return 1;  // boolean
    if (v[0] == 'f' && v[1] == 0) return 0;
    return std::strtoll(v, nullptr, 10);
  }
  return sqlite3_column_int64(stmt_, col);
}
double Stmt::Real(int col) const {
  if (pg_) {
    const char* v = PgValue(*pg_, col);
    return v ? std::strtod(v, nullptr) : std::nan("");
  }
  return IsNull(col) ? std::nan("") : sqlite3_column_double(stmt_, col);
}
std::string Stmt::Text(int col) const {
  if (pg_) {
    const char* v = PgValue(*pg_, col);
    return v ? std::string(v, PQgetlength(pg_->result, pg_->row, col)) : "";
  }
  const unsigned char* p = sqlite3_column_text(stmt_, col);
  return p ? std::string(reinterpret_cast<const char*>(p), sqlite3_column_bytes(stmt_, col)) : "";
}
std::vector<uint8_t> Stmt::Blob(int col) const {
  if (pg_) {
    const char* v = PgValue(*pg_, col);
    if (v == nullptr) return {};
    size_t n = 0;
    unsigned char* raw = PQunescapeBytea(reinterpret_cast<const unsigned char*>(v), &n);
    if (raw == nullptr) return {};
    std::vector<uint8_t> out(raw, raw + n);
    PQfreemem(raw);
    return out;
  }
  const auto* p = static_cast<const uint8_t*>(sqlite3_column_blob(stmt_, col));
  const int n = sqlite3_column_bytes(stmt_, col);
  return p ? std::vector<uint8_t>(p, p + n) : std::vector<uint8_t>();
}
bool Stmt::IsNull(int col) const {
  if (pg_) return PgValue(*pg_, col) == nullptr;
  return sqlite3_column_type(stmt_, col) == SQLITE_NULL;
}

int Stmt::ColumnCount() const {
  if (pg_) return pg_->result ? PQnfields(pg_->result) : 0;
  return sqlite3_column_count(stmt_);
}

std::string Stmt::ColumnName(int col) const {
  if (pg_) {
    const char* name = pg_->result ? PQfname(pg_->result, col) : nullptr;
    return name ? name : "";
  }
  const char* name = sqlite3_column_name(stmt_, col);
  return name ? name : "";
}

Stmt::Type Stmt::ColumnType(int col) const {
  if (IsNull(col)) return Type::kNull;
  if (pg_) {
    switch (PQftype(pg_->result, col)) {
      case 16: case 20: case 21: case 23: return Type::kInt;  // bool, int8, int2, int4
      case 700: case 701: case 1700: return Type::kReal;       // float4, float8, numeric
      case 17: return Type::kBlob;                             // bytea
      default: return Type::kText;
    }
  }
  switch (sqlite3_column_type(stmt_, col)) {
    case SQLITE_INTEGER: return Type::kInt;
    case SQLITE_FLOAT: return Type::kReal;
    case SQLITE_BLOB: return Type::kBlob;
    default: return Type::kText;
  }
}

}  // namespace imuqual::store
