#include "report/table_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/strings.h"
#include "common/text_util.h"

namespace imuqual::report {
namespace {

// digits 17: for programs, the shortest text that reads back exactly.
std::string FormatReal(double v, int digits) {
  if (std::isnan(v)) return "";
  if (digits >= 17) return ShortestReal(v);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string CellText(const Cell& c, int digits) {
  switch (c.kind) {
    case Cell::Kind::kText:
    case Cell::Kind::kNumText:
      return c.text;
    case Cell::Kind::kReal:
      return digits < 17 && !c.text.empty() ? c.text : FormatReal(c.real, digits);
    case Cell::Kind::kInt:
      return std::to_string(c.integer);
    case Cell::Kind::kBool:
      return c.integer ? "true" : "false";
  }
  return "";
}

std::string CsvQuote(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

size_t DisplayWidth(const std::string& s) {
  size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

Result<Format> ParseFormat(const std::string& name) {
  if (name == "table") return Format::kTable;
  if (name == "csv") return Format::kCsv;
  if (name == "json") return Format::kJson;
  return Status::InvalidArgument("--format must be table, csv or json, not '" + name + "'");
}

std::string TableWriter::Render(Format format) const {
  switch (format) {
    case Format::kTable:
      return RenderTable();
    case Format::kCsv:
      return RenderCsv();
    case Format::kJson:
      return RenderJson();
    case Format::kHtml:
      return RenderHtml();
  }
  return "";
}

std::string TableWriter::RenderTableWithin(size_t width, const std::vector<std::string>& drop_order,
                                           std::vector<std::string>* left_out) const {
  auto widest = [](const std::string& text) {
    size_t most = 0, from = 0;
    while (from < text.size()) {
      size_t end = text.find('\n', from);
      if (end == std::string::npos) end = text.size();
      most = std::max(most, DisplayWidth(text.substr(from, end - from)));
      from = end + 1;
    }
    return most;
  };
  auto without = [&](const std::vector<std::string>& gone) {
    TableWriter t({}, digits_);
    std::vector<size_t> kept;
    for (size_t c = 0; c < columns_.size(); ++c) {
      if (std::find(gone.begin(), gone.end(), columns_[c]) != gone.end()) continue;
      kept.push_back(c);
      t.columns_.push_back(columns_[c]);
    }
    for (const std::vector<Cell>& row : rows_) {
      std::vector<Cell> cells;
      for (size_t c : kept) cells.push_back(c < row.size() ? row[c] : Cell::Text(""));
      t.rows_.push_back(std::move(cells));
    }
    return t.RenderTable();
  };
  // Leave columns out in order until it fits, then take back the most
  // important of them that still fit (a wide one left out may make room).
  std::vector<std::string> gone;
  std::string out = RenderTable();
  for (const std::string& name : drop_order) {
    if (widest(out) <= width) break;
    if (std::find(columns_.begin(), columns_.end(), name) == columns_.end()) continue;
    gone.push_back(name);
    out = without(gone);
  }
  for (size_t k = gone.size(); k-- > 0;) {
    std::vector<std::string> fewer = gone;
    fewer.erase(fewer.begin() + static_cast<std::ptrdiff_t>(k));
    std::string again = without(fewer);
    if (widest(again) <= width) {
      gone = std::move(fewer);
      out = std::move(again);
    }
  }
  if (left_out != nullptr) *left_out = gone;
  return out;
}

std::string TableWriter::RenderTable() const {
  std::vector<size_t> width(columns_.size());
  for (size_t c = 0; c < columns_.size(); ++c) width[c] = DisplayWidth(columns_[c]);
  std::vector<std::vector<std::string>> cells;
  for (const auto& row : rows_) {
    std::vector<std::string> texts;
    for (size_t c = 0; c < columns_.size(); ++c) {
      std::string text = c < row.size() ? CellText(row[c], digits_) : std::string();
      if (c < row.size() && row[c].kind == Cell::Kind::kBool) text = row[c].integer ? "yes" : "no";
      // A missing number shows as "-" for people.
      if (text.empty() && c < row.size() && row[c].kind == Cell::Kind::kReal) text.push_back('-');
      texts.push_back(std::move(text));
      width[c] = std::max(width[c], DisplayWidth(texts.back()));
    }
    cells.push_back(std::move(texts));
  }
  std::string out;
  auto line = [&](const std::vector<std::string>& texts, const std::vector<Cell>* row) {
    for (size_t c = 0; c < texts.size(); ++c) {
      const bool numeric = row && c < row->size() && (*row)[c].kind != Cell::Kind::kText &&
                           (*row)[c].kind != Cell::Kind::kBool;
      const std::string pad(width[c] - DisplayWidth(texts[c]), ' ');
      if (numeric) {
        out += pad;
        out += texts[c];
      } else {
        out += texts[c];
        if (c + 1 < texts.size()) out += pad;
      }
      if (c + 1 < texts.size()) out += "  ";
    }
    while (!out.empty() && out.back() == ' ') out.pop_back();
    out += '\n';
  };
  line(columns_, nullptr);
  std::vector<std::string> rule;
  for (size_t w : width) rule.push_back(std::string(w, '-'));
  line(rule, nullptr);
  for (size_t r = 0; r < rows_.size(); ++r) line(cells[r], &rows_[r]);
  return out;
}

std::string TableWriter::RenderCsv() const {
  std::string out;
  for (size_t c = 0; c < columns_.size(); ++c) {
    if (c) out += ',';
    out += CsvQuote(columns_[c]);
  }
  out += '\n';
  for (const auto& row : rows_) {
    for (size_t c = 0; c < columns_.size(); ++c) {
      if (c) out += ',';
      if (c < row.size()) out += CsvQuote(CellText(row[c], 17));
    }
    out += '\n';
  }
  return out;
}

std::string TableWriter::RenderJson() const {
  std::string out = "[";
  for (size_t r = 0; r < rows_.size(); ++r) {
    out += r ? ",\n {" : "\n {";
    for (size_t c = 0; c < columns_.size(); ++c) {
      if (c) out += ", ";
      out += JsonString(columns_[c]);
      out += ": ";
      const Cell& cell = c < rows_[r].size() ? rows_[r][c] : Cell::Text("");
      if (cell.kind == Cell::Kind::kText || cell.kind == Cell::Kind::kNumText) {
        out += JsonString(cell.text);
      } else if (cell.kind == Cell::Kind::kInt) {
        out += std::to_string(cell.integer);
      } else if (cell.kind == Cell::Kind::kBool) {
        out += cell.integer ? "true" : "false";
      } else {
        out += std::isfinite(cell.real) ? FormatReal(cell.real, 17) : "null";
      }
    }
    out += "}";
  }
  out += rows_.empty() ? "]\n" : "\n]\n";
  return out;
}

std::string TableWriter::RenderHtml() const {
  std::string out = "<table class=\"data\">\n<thead><tr>";
  for (const std::string& c : columns_) out += "<th>" + HtmlEscape(c) + "</th>";
  out += "</tr></thead>\n<tbody>\n";
  for (const auto& row : rows_) {
    out += "<tr>";
    for (size_t c = 0; c < columns_.size(); ++c) {
      const Cell& cell = c < row.size() ? row[c] : Cell::Text("");
      const bool number = cell.kind == Cell::Kind::kReal || cell.kind == Cell::Kind::kInt ||
                          cell.kind == Cell::Kind::kNumText;
      out += number ? "<td class=\"num\"" : "<td";
      if (cell.kind == Cell::Kind::kReal || cell.kind == Cell::Kind::kInt)
        out += " data-v=\"" + HtmlEscape(CellText(cell, 17)) + "\"";
      out += ">";
      std::string text = HtmlEscape(CellText(cell, digits_));
      if (cell.kind == Cell::Kind::kReal && std::isnan(cell.real)) text = "&ndash;";
      if (!cell.href.empty()) text = "<a href=\"" + HtmlEscape(cell.href) + "\">" + text + "</a>";
      out += text + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</tbody>\n</table>\n";
}

}  // namespace imuqual::report
