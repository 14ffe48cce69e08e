// The plant archive's schema on PostgreSQL 15: every station's finalised
// runs with everything they hold (the station schema's tables, column for
// column, store/SCHEMA.md), each station archive's chain of signed entries,
// and the per-station shipping cursor. The views answer the same questions
// as the station's (axis_results, final_runs, lot_overview, ...), so the
// archive's queries (store/query.h) read either engine.
#ifndef IMUQUAL_STORE_PLANT_SCHEMA_H_
#define IMUQUAL_STORE_PLANT_SCHEMA_H_

#include "common/status.h"
#include "store/sqlite.h"

namespace imuqual::store {

// The plant schema version this build writes.
int PlantSchemaVersion();

// Creates the schema in an empty database (one transaction), or checks that
// the database holds this build's plant schema. Fails, changing nothing, on
// a database that holds other tables or a newer version.
Status MigratePlant(Db& db);

// Checks without writing that `db` holds a plant archive this build reads.
Status CheckPlantReadable(Db& db);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_PLANT_SCHEMA_H_
