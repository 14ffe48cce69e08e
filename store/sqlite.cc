#include "store/sqlite.h"

#include <cmath>
#include <unordered_map>
#include <vector>

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

Result<std::unique_ptr<Db>> Db::Open(const std::string& path, Mode mode) {
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
  sqlite3_close_v2(db_);
}

std::string Db::ErrorMessage() const {
  return std::string(sqlite3_errmsg(db_)) + " (" + sqlite3_errstr(sqlite3_extended_errcode(db_)) +
         ")";
}

Status Db::Exec(const std::string& sql) {
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

Stmt::Stmt(Stmt&& other) noexcept
    : stmt_(other.stmt_),
      db_(other.db_),
      sql_(std::move(other.sql_)),
      cache_(std::move(other.cache_)),
      bind_error_(std::move(other.bind_error_)) {
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

Stmt& Stmt::Bind(int i, int64_t v) {
  IMUQUAL_BIND(sqlite3_bind_int64(stmt_, i, v));
  return *this;
}
Stmt& Stmt::Bind(int i, double v) {
  if (std::isnan(v)) return BindNull(i);
  IMUQUAL_BIND(sqlite3_bind_double(stmt_, i, v));
  return *this;
}
Stmt& Stmt::Bind(int i, std::string_view v) {
  IMUQUAL_BIND(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::BindBlob(int i, std::span<const uint8_t> v) {
  // A zero-length blob must still be a blob, not NULL.
  static const uint8_t kEmpty = 0;
  IMUQUAL_BIND(sqlite3_bind_blob(stmt_, i, v.empty() ? &kEmpty : v.data(),
                                 static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::BindNull(int i) {
  IMUQUAL_BIND(sqlite3_bind_null(stmt_, i));
  return *this;
}
#undef IMUQUAL_BIND

Result<bool> Stmt::Step() {
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
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int64_t Stmt::Int(int col) const { return sqlite3_column_int64(stmt_, col); }
double Stmt::Real(int col) const {
  return IsNull(col) ? std::nan("") : sqlite3_column_double(stmt_, col);
}
std::string Stmt::Text(int col) const {
  const unsigned char* p = sqlite3_column_text(stmt_, col);
  return p ? std::string(reinterpret_cast<const char*>(p), sqlite3_column_bytes(stmt_, col)) : "";
}
std::vector<uint8_t> Stmt::Blob(int col) const {
  const auto* p = static_cast<const uint8_t*>(sqlite3_column_blob(stmt_, col));
  const int n = sqlite3_column_bytes(stmt_, col);
  return p ? std::vector<uint8_t>(p, p + n) : std::vector<uint8_t>();
}
bool Stmt::IsNull(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }

}  // namespace imuqual::store
