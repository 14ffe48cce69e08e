// Tabular output: an aligned text table for people, CSV (RFC 4180) and JSON
// (an array of objects) for programs, and an HTML table for web pages.
// Numbers keep full precision in CSV and JSON (and in HTML's data-v); NaN is
// an empty CSV cell and JSON null.
#ifndef IMUQUAL_REPORT_TABLE_WRITER_H_
#define IMUQUAL_REPORT_TABLE_WRITER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::report {

enum class Format { kTable, kCsv, kJson, kHtml };
// "table", "csv", "json" (HTML is for the web pages, not a --format).
Result<Format> ParseFormat(const std::string& name);

struct Cell {
  // kNumText: a number already written as text with its marks ("≤ 0.68",
  // "22.1† ± 1.3", "n/m"), right-aligned like numbers, a string in JSON.
  // kBool: true/false in CSV and JSON (a JSON boolean), yes/no in the table.
  enum class Kind { kText, kReal, kInt, kNumText, kBool } kind = Kind::kText;
  std::string text;
  double real = 0;
  int64_t integer = 0;
  static Cell Text(std::string t) { return {Kind::kText, std::move(t), 0, 0, {}}; }
  static Cell Real(double v) { return {Kind::kReal, "", v, 0, {}}; }
  static Cell Int(int64_t v) { return {Kind::kInt, "", 0, v, {}}; }
  static Cell NumText(std::string t) { return {Kind::kNumText, std::move(t), 0, 0, {}}; }
  static Cell Bool(bool b) { return {Kind::kBool, "", 0, b ? 1 : 0, {}}; }
  // A number shown as `shown` in the text table and HTML (rounded as a
  // person reads it, e.g. to its uncertainty), exact in CSV, JSON and data-v.
  static Cell RealShown(double v, std::string shown) {
    return {Kind::kReal, std::move(shown), v, 0, {}};
  }
  // A link target for the HTML table (escaped there; ignored elsewhere).
  std::string href;
  Cell Linked(std::string target) && {
    href = std::move(target);
    return std::move(*this);
  }
};

// Columns a UTF-8 string takes on a terminal: its code points ("±", "≤",
// "†" one column each).
size_t DisplayWidth(const std::string& s);

class TableWriter {
 public:
  // `digits`: significant digits in the text table (CSV/JSON use 17).
  explicit TableWriter(std::vector<std::string> columns, int digits = 4)
      : columns_(std::move(columns)), digits_(digits) {}
  void AddRow(std::vector<Cell> row) { rows_.push_back(std::move(row)); }
  size_t rows() const { return rows_.size(); }
  std::string Render(Format format) const;
  // The text table no wider than `width` columns: the columns of
  // `drop_order` left out, in that order, until it fits (or none is left to
  // drop); the names of those left out go to *left_out.
  std::string RenderTableWithin(size_t width, const std::vector<std::string>& drop_order,
                                std::vector<std::string>* left_out) const;

 private:
  std::string RenderTable() const;
  std::string RenderCsv() const;
  std::string RenderJson() const;
  // <table class="data">: headers, then a row per row; numbers rounded to
  // `digits` with the full value in data-v, links as <a href>; every text
  // escaped.
  std::string RenderHtml() const;
  std::vector<std::string> columns_;
  std::vector<std::vector<Cell>> rows_;
  int digits_;
};

// A JSON string literal: quotes, backslashes and control characters escaped.
std::string JsonString(const std::string& s);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_TABLE_WRITER_H_
