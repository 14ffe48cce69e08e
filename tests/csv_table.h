// CSV as the imuqual commands write it (RFC 4180: quoted fields, doubled
// quotes, quoted newlines, CRLF or LF), read back into header-indexed rows
// for tests. Blank lines are skipped.
#ifndef IMUQUAL_TESTS_CSV_TABLE_H_
#define IMUQUAL_TESTS_CSV_TABLE_H_

#include <string>
#include <vector>

namespace imuqual::testing {

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  // The index of column `name`; a test failure (and 0) when there is none.
  size_t Col(const std::string& name) const;
};

Csv ParseCsv(const std::string& text);

}  // namespace imuqual::testing

#endif  // IMUQUAL_TESTS_CSV_TABLE_H_
