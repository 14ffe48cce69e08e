#include "common/numeric_text.h"

#include <strings.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "common/strings.h"

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

// Why a line is not text, or "" if it is: a control byte (other than tab)
// or DEL, as compressed and binary files have within their first bytes.
std::string NotText(std::string_view line) {
  if (line.starts_with("\xFD" "7zXZ")) return "an xz-compressed file (decompress it first)";
  if (line.starts_with("\x1F\x8B")) return "a gzip-compressed file (decompress it first)";
  for (size_t i = 0; i < line.size(); ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    if ((c < 0x20 && c != '\t') || c == 0x7F) {
      char text[96];
      std::snprintf(text, sizeof text, "not text: byte 0x%02X at column %zu (a binary file?)", c,
                    i + 1);
      return text;
    }
  }
  return "";
}

// A cell as shown in an error: at most 40 bytes, control bytes as \xNN.
std::string Shown(std::string_view cell) {
  std::string out;
  for (char ch : cell.substr(0, 40)) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7F) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\x%02X", c);
      out += esc;
    } else {
      out += ch;
    }
  }
  return out;
}

}  // namespace

NumericRowReader::NumericRowReader(LineSource next_line, std::string source_name,
                                   std::vector<std::string> wanted)
    : next_line_(std::move(next_line)), source_(std::move(source_name)), wanted_(std::move(wanted)) {}

Status NumericRowReader::Start() {
  for (;;) {
    std::optional<std::string> raw = next_line_();
    if (!raw) return Status::InvalidArgument(source_ + ": no samples");
    ++line_no_;
    const std::string_view line = Trim(*raw);
    if (line.empty() || line[0] == '#' || line[0] == '%') continue;
    const std::string where = source_ + ":" + std::to_string(line_no_) + ": ";
    if (const std::string why = NotText(line); !why.empty()) {
      return Status::InvalidArgument(where + why);
    }
    if (!SplitCsv(line, &fields_)) return Status::InvalidArgument(where + "unterminated quote");
    double probe;
    const bool header = fields_.size() > 1 || !ParseNumber(fields_[0], &probe);
    const std::vector<std::string> all = header ? fields_ : std::vector<std::string>{"value"};
    if (wanted_.empty()) {
      for (size_t c = 0; c < all.size(); ++c) pick_.push_back(static_cast<int>(c));
    } else {
      for (const std::string& w : wanted_) {
        const auto it = std::find(all.begin(), all.end(), w);
        if (it == all.end()) {
          return Status::InvalidArgument(where + "no column '" + w + "' (columns: " +
                                         Join(all, ", ") + ")");
        }
        pick_.push_back(static_cast<int>(it - all.begin()));
      }
    }
    for (int c : pick_) names_.push_back(all[c]);
    if (!header) {  // a bare number: this line is the first row
      pending_ = std::string(line);
      pending_line_ = line_no_;
    }
    return Status::Ok();
  }
}

Result<bool> NumericRowReader::ParseRow(std::string_view line, std::vector<double>* values) {
  const std::string where = source_ + ":" + std::to_string(line_no_) + ": ";
  if (!SplitCsv(line, &fields_)) return Status::InvalidArgument(where + "unterminated quote");
  values->resize(pick_.size());
  for (size_t k = 0; k < pick_.size(); ++k) {
    if (static_cast<size_t>(pick_[k]) >= fields_.size()) {
      return Status::InvalidArgument(where + std::to_string(fields_.size()) + " fields, column '" +
                                     names_[k] + "' is field " + std::to_string(pick_[k] + 1));
    }
    if (!ParseNumber(fields_[pick_[k]], &(*values)[k])) {
      if (k < lenient_columns_) {
        (*values)[k] = std::numeric_limits<double>::quiet_NaN();
        ++invalid_cells_;
        if (warned_.size() <= k) warned_.resize(k + 1, false);
        if (!warned_[k]) {
          warned_[k] = true;
          warnings_.push_back(where + "'" + Shown(fields_[pick_[k]]) +
                              "' is not a number (column '" + names_[k] +
                              "'): read as an invalid sample of that axis, as nan or an empty "
                              "cell is (the first here; each is counted)");
        }
        continue;
      }
      return Status::InvalidArgument(where + "'" + Shown(fields_[pick_[k]]) +
                                     "' is not a number (column '" + names_[k] + "')");
    }
  }
  return true;
}

Result<bool> NumericRowReader::Next(std::vector<double>* values) {
  if (pending_) {
    const std::string line = std::move(*pending_);
    pending_.reset();
    const size_t now = line_no_;
    line_no_ = pending_line_;
    Result<bool> r = ParseRow(line, values);
    line_no_ = now;
    return r;
  }
  for (;;) {
    std::optional<std::string> raw = next_line_();
    if (!raw) return false;
    ++line_no_;
    const std::string_view line = Trim(*raw);
    if (line.empty() || line[0] == '#' || line[0] == '%') continue;
    return ParseRow(line, values);
  }
}

Result<NumericTable> ParseNumericText(std::string_view text, std::string_view source_name,
                                      const std::vector<std::string>& wanted,
                                      std::vector<std::string>* invalid_warnings) {
  size_t pos = 0;
  NumericRowReader reader(
      [&]() -> std::optional<std::string> {
        if (pos > text.size()) return std::nullopt;
        size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string line(text.substr(pos, end - pos));
        pos = end + 1;
        return line;
      },
      std::string(source_name), wanted);
  if (invalid_warnings != nullptr) {
    reader.ReadNonNumbersAsInvalid(wanted.empty() ? std::numeric_limits<size_t>::max()
                                                  : wanted.size());
  }
  IMUQUAL_RETURN_IF_ERROR(reader.Start());
  NumericTable table;
  table.names = reader.names();
  table.columns.resize(table.names.size());
  std::vector<double> row;
  for (;;) {
    Result<bool> more = reader.Next(&row);
    if (!more.ok()) return more.status();
    if (!*more) break;
    for (size_t c = 0; c < row.size(); ++c) table.columns[c].push_back(row[c]);
  }
  if (table.rows() == 0) return Status::InvalidArgument(std::string(source_name) + ": no samples");
  if (invalid_warnings != nullptr) {
    for (std::string& w : reader.TakeWarnings()) invalid_warnings->push_back(std::move(w));
  }
  return table;
}

Result<std::vector<double>> ParseSeries(std::string_view text, std::string_view source_name,
                                        const std::string& column,
                                        std::vector<std::string>* invalid_warnings) {
  std::vector<std::string> wanted;
  if (!column.empty()) wanted.push_back(column);
  auto table = ParseNumericText(text, source_name, wanted, invalid_warnings);
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
