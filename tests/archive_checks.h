// Checks of an archive after a station soak under faults: what the store
// holds of each run, and whether every run is whole (nothing lost, nothing
// damaged, judged). gtest assertions; read-only on the archive.
#ifndef IMUQUAL_TESTS_ARCHIVE_CHECKS_H_
#define IMUQUAL_TESTS_ARCHIVE_CHECKS_H_

#include <cstdint>
#include <map>
#include <string>

namespace imuqual::testing {

// One run as archived (runs joined with the run_archive view).
struct RunCheck {
  int64_t chunks = 0;
  int64_t last_seq = -1;
  int64_t gap_ranges = 0;
  std::string state, verdict, reasons;
};

// Every run of the archive at `db`, by run id. Also expects the SQLite file
// to pass its integrity check.
std::map<std::string, RunCheck> CheckArchive(const std::string& db);

// Every run whole: complete, every batch archived, no gap, judged.
void ExpectEveryRunWhole(const std::map<std::string, RunCheck>& runs);

// A soak of `runs` runs of `axes` axes each, all whole (ExpectEveryRunWhole),
// and for each run: a curve per axis, the samples archived equal to those
// announced, `imuqual reanalyze RUN --check` (bounded in time) agreeing that
// the archived curves are those of the archived samples, and the archived
// judgement (verdict, reasons, measurements) equal to the re-analysis's.
void ExpectSoakArchivedWhole(const std::string& db, size_t runs, size_t axes);

}  // namespace imuqual::testing

#endif  // IMUQUAL_TESTS_ARCHIVE_CHECKS_H_
