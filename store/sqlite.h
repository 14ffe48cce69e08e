// A thin RAII layer over the SQLite C API (a station's archive file) and
// libpq (a plant archive on PostgreSQL, store/postgres.h) that reports
// failures as Status values naming the statement and the engine's message.
// Bound parameters only: no SQL is ever built from data. A Db is used by one
// thread at a time, with its statements.
//
// One SQL text serves both engines where the archive's queries are written
// in their common dialect: parameters are written ?N (or ?) and become $N
// for PostgreSQL; values come back through the same accessors (a
// PostgreSQL boolean reads as Int 0/1, bytea as Blob).
//
// Compiled statements are reused: a Stmt that ends goes back to its Db reset
// and unbound (a few per SQL text), and Prepare of the same text takes it
// again instead of compiling it anew; what a statement does is the same
// either way (SQLite recompiles a reused one itself if the schema changed).
#ifndef IMUQUAL_STORE_SQLITE_H_
#define IMUQUAL_STORE_SQLITE_H_

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace imuqual::store {

class Stmt;
class StatementCache;
struct PgConnection;
struct PgQuery;

// A plant archive's address: "postgresql://..." or "postgres://..." (libpq
// connection URIs); anything else is a station's SQLite file.
bool IsPostgresUrl(std::string_view path);

class Db {
 public:
  enum class Mode { kReadWrite, kReadOnly };
  // Opens (kReadWrite: creating) the file, or connects to the PostgreSQL
  // database at a postgresql:// URL (kReadOnly: every transaction read
  // only). The file is not read until the first statement; Archive::Open
  // checks that it really is a database.
  static Result<std::unique_ptr<Db>> Open(const std::string& path, Mode mode);
  ~Db();
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  // Runs one or more statements without parameters (DDL, pragmas).
  Status Exec(const std::string& sql);
  // Compiles one statement (or reuses an idle one of the same text).
  Result<Stmt> Prepare(const std::string& sql);
  // Single integer result of a query such as "PRAGMA user_version".
  Result<int64_t> QueryInt(const std::string& sql);

  // Rows changed by the last INSERT, UPDATE or DELETE.
  int64_t Changes() const;
  // Whether no transaction is open.
  bool InAutocommit() const;
  // Starts a write transaction (SQLite: BEGIN IMMEDIATE, the write lock at
  // once).
  Status BeginWrite();

  bool postgres() const { return pg_ != nullptr; }
  sqlite3* handle() { return db_; }  // nullptr on PostgreSQL
  // The file, or the URL without its password.
  const std::string& path() const { return path_; }
  // The last error as "<sqlite message> (<extended code name>)".
  std::string ErrorMessage() const;

 private:
  friend class Stmt;
  Db(sqlite3* db, std::string path);
  sqlite3* db_ = nullptr;
  std::unique_ptr<PgConnection> pg_;
  std::string path_;
  // Idle statements; shared with the Stmts, which may outlive the Db (then
  // they are finalized when they end).
  std::shared_ptr<StatementCache> cache_;
};

// A prepared statement. Bind*() indices are 1-based, as in SQLite.
class Stmt {
 public:
  Stmt(Stmt&& other) noexcept;
  Stmt& operator=(Stmt&& other) noexcept;
  ~Stmt();

  Stmt& Bind(int i, int64_t v);
  Stmt& Bind(int i, int v) { return Bind(i, static_cast<int64_t>(v)); }
  Stmt& Bind(int i, double v);            // NaN binds NULL
  Stmt& Bind(int i, std::string_view v);  // text
  Stmt& Bind(int i, const char* v) { return Bind(i, std::string_view(v)); }
  Stmt& Bind(int i, const std::string& v) { return Bind(i, std::string_view(v)); }
  Stmt& BindBlob(int i, std::span<const uint8_t> v);
  Stmt& BindNull(int i);
  Stmt& Bind(int i, std::optional<double> v) { return v ? Bind(i, *v) : BindNull(i); }
  Stmt& Bind(int i, std::optional<int64_t> v) { return v ? Bind(i, *v) : BindNull(i); }
  Stmt& Bind(int i, const std::optional<std::string>& v) { return v ? Bind(i, *v) : BindNull(i); }

  // Steps once: true while a row is available, false when done.
  Result<bool> Step();
  // Steps to completion (for writes), then resets for reuse.
  Status Run();
  void Reset();

  // The compiled statement, for the C API's column functions (valid while
  // this Stmt lives; do not finalize it). nullptr on PostgreSQL.
  sqlite3_stmt* handle() { return stmt_; }

  // What a column of the current row holds, for copying rows between
  // engines.
  enum class Type { kNull, kInt, kReal, kText, kBlob };
  Type ColumnType(int col) const;
  int ColumnCount() const;
  std::string ColumnName(int col) const;

  int64_t Int(int col) const;
  double Real(int col) const;  // NULL reads as NaN
  std::string Text(int col) const;
  std::vector<uint8_t> Blob(int col) const;
  bool IsNull(int col) const;

 private:
  friend class Db;
  Stmt(sqlite3_stmt* stmt, Db* db, std::string sql, std::shared_ptr<StatementCache> cache);
  Stmt(std::unique_ptr<PgQuery> pg, Db* db, std::string sql);
  // Gives the statement back to the cache (or finalizes it).
  void Release();
  sqlite3_stmt* stmt_ = nullptr;
  Db* db_ = nullptr;
  std::string sql_;
  std::shared_ptr<StatementCache> cache_;
  Status bind_error_;
  std::unique_ptr<PgQuery> pg_;
};

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_SQLITE_H_
