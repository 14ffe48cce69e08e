// The archive's schema and its migrations. The version lives in
// PRAGMA user_version; PRAGMA application_id marks the file as an imuqual
// archive. store/SCHEMA.md documents every table and view.
#ifndef IMUQUAL_STORE_SCHEMA_H_
#define IMUQUAL_STORE_SCHEMA_H_

#include "common/status.h"
#include "store/sqlite.h"

namespace imuqual::store {

// 'IMUQ' in ASCII.
inline constexpr int64_t kApplicationId = 0x494D5551;
// The schema version this build writes.
int SchemaVersion();

// Brings a database to SchemaVersion(): an empty file gets the whole schema,
// an older one is migrated step by step (each step in one transaction). Fails
// (changing nothing) on a file that is not an imuqual archive, whose schema
// is newer than this build, or that fails SQLite's quick_check (damaged).
Status Migrate(Db& db);

// Checks without writing that `db` is an imuqual archive this build can
// read (for read-only opens).
Status CheckReadable(Db& db);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_SCHEMA_H_
