#include "common/numeric_text.h"

#include "common/strings.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <strings.h>

namespace imuqual {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Whole-field number: strtod must consume everything. Empty and "nan" are NaN.
bool ParseNumber(std::string_view field, double* out) {
  field = Trim(field);
  if (field.empty()) {
    *out = std::nan("");
    return true;
  }
  if (field.size() == 3 && strncasecmp(field.data(), "nan", 3) == 0) {
    *out = std::nan("");
    return true;
  }
  if (field.size() > 64) return false;
  char buf[72];
  field.copy(buf, field.size());
  buf[field.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(buf, &end);
  if (end != buf + field.size() || errno == ERANGE) return false;
  *out = v;
  return true;
}

// Splits a CSV line; fields may be double-quoted ("" is a quote inside).
bool SplitCsv(std::string_view line, std::vector<std::string>* fields) {
  fields->clear();
  std::string cur;
  bool quoted = false, was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"' && Trim(cur).empty() && !was_quoted) {
      quoted = was_quoted = true;
      cur.clear();
    } else if (c == ',') {
      fields->push_back(std::string(Trim(cur)));
      cur.clear();
      was_quoted = false;
    } else {
      cur += c;
    }
  }
  if (quoted) return false;
  fields->push_back(std::string(Trim(cur)));
  return true;
}

}  // namespace

Result<NumericTable> ParseNumericText(std::string_view text, std::string_view source_name,
                                      const std::vector<std::string>& wanted) {
  const std::string src(source_name);
  NumericTable table;
  std::vector<int> pick;  // source column of each output column
  bool header_done = false;
  std::vector<std::string> fields;
  size_t line_no = 0, start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = Trim(text.substr(start, end - start));
    start = end + 1;
    ++line_no;
    if (line.empty() || line[0] == '#' || line[0] == '%') {
      if (end == text.size()) break;
      continue;
    }
    auto where = [&]() { return src + ":" + std::to_string(line_no) + ": "; };
    if (!SplitCsv(line, &fields)) return Status::InvalidArgument(where() + "unterminated quote");
    if (!header_done) {
      header_done = true;
      double probe;
      const bool header = fields.size() > 1 || !ParseNumber(fields[0], &probe);
      std::vector<std::string> names;
      if (header) {
        names = fields;
      } else {
        names = {"value"};
      }
      if (wanted.empty()) {
        for (size_t c = 0; c < names.size(); ++c) pick.push_back(static_cast<int>(c));
      } else {
        for (const std::string& w : wanted) {
          int found = -1;
          for (size_t c = 0; c < names.size(); ++c) {
            if (names[c] == w) found = static_cast<int>(c);
          }
          if (found < 0) {
            return Status::InvalidArgument(where() + "no column '" + w + "' (columns: " +
                                           Join(names, ", ") + ")");
          }
          pick.push_back(found);
        }
      }
      for (int c : pick) table.names.push_back(names[c]);
      table.columns.resize(pick.size());
      if (header) {
        if (end == text.size()) break;
        continue;
      }
      // A bare number: this line is data.
    }
    for (size_t k = 0; k < pick.size(); ++k) {
      if (static_cast<size_t>(pick[k]) >= fields.size()) {
        return Status::InvalidArgument(where() + std::to_string(fields.size()) +
                                       " fields, column '" + table.names[k] + "' is field " +
                                       std::to_string(pick[k] + 1));
      }
      double v;
      if (!ParseNumber(fields[pick[k]], &v)) {
        return Status::InvalidArgument(where() + "'" + fields[pick[k]].substr(0, 40) +
                                       "' is not a number (column '" + table.names[k] + "')");
      }
      table.columns[k].push_back(v);
    }
    if (end == text.size()) break;
  }
  if (table.rows() == 0) return Status::InvalidArgument(src + ": no samples");
  return table;
}

Result<std::vector<double>> ParseSeries(std::string_view text, std::string_view source_name,
                                        const std::string& column) {
  std::vector<std::string> wanted;
  if (!column.empty()) wanted.push_back(column);
  auto table = ParseNumericText(text, source_name, wanted);
  if (!table.ok()) return table.status();
  if (table->columns.size() != 1) {
    return Status::InvalidArgument(std::string(source_name) + ": " +
                                   std::to_string(table->columns.size()) +
                                   " columns; choose one with --column (" +
                                   Join(table->names, ", ") + ")");
  }
  return std::move(table->columns[0]);
}

}  // namespace imuqual
