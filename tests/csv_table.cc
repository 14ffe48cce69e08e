#include "tests/csv_table.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace imuqual::testing {

size_t Csv::Col(const std::string& name) const {
  const auto it = std::find(header.begin(), header.end(), name);
  if (it == header.end()) {
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  return static_cast<size_t>(it - header.begin());
}

Csv ParseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> record;
  std::string field;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"') {
        field += c;
      } else if (i + 1 < text.size() && text[i + 1] == '"') {
        field += '"';
        ++i;
      } else {
        quoted = false;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      record.push_back(std::move(field));
      field.clear();
    } else if (c == '\n') {
      record.push_back(std::move(field));
      field.clear();
      records.push_back(std::move(record));
      record.clear();
    } else if (c != '\r') {
      field += c;
    }
  }
  if (!field.empty() || !record.empty()) {
    record.push_back(std::move(field));
    records.push_back(std::move(record));
  }
  Csv out;
  if (records.empty()) return out;
  out.header = std::move(records[0]);
  for (size_t i = 1; i < records.size(); ++i) {
    if (records[i].size() > 1 || !records[i][0].empty()) out.rows.push_back(std::move(records[i]));
  }
  return out;
}

}  // namespace imuqual::testing
