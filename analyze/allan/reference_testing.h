// Test-only helpers that read the reference vectors in tests/reference/
// (datasets.json, data/*.txt, results/<dataset>/*.csv, stable32_ref/*.txt).
// Tests are built with IMUQUAL_SOURCE_DIR pointing at the repository root.
// Header-only; not part of the imuqual_allan library.
#ifndef IMUQUAL_ANALYZE_ALLAN_REFERENCE_TESTING_H_
#define IMUQUAL_ANALYZE_ALLAN_REFERENCE_TESTING_H_

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "analyze/allan/phase.h"

namespace imuqual::allan::testing {

inline std::string ReferencePath(std::string_view relative) {
  return std::string(IMUQUAL_SOURCE_DIR) + "/tests/reference/" + std::string(relative);
}

inline bool FileExists(const std::string& path) { return std::ifstream(path).good(); }

// One entry of datasets.json.
struct Dataset {
  std::string name;
  std::string file;       // relative to tests/reference/
  std::string data_type;  // "freq" (rate) or "phase"
  double rate_hz = 1.0;
  bool all_taus = false;
};

// Parses the flat array of flat objects in datasets.json (string, number and
// boolean values only). Returns an empty list if the file cannot be read.
inline std::vector<Dataset> ReadDatasets() {
  std::ifstream in(ReferencePath("datasets.json"));
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  std::vector<Dataset> datasets;
  size_t pos = 0;
  while ((pos = text.find('{', pos)) != std::string::npos) {
    const size_t close = text.find('}', pos);
    if (close == std::string::npos) break;
    std::map<std::string, std::string> fields;
    size_t at = pos + 1;
    while (true) {
      const size_t key_begin = text.find('"', at);
      if (key_begin == std::string::npos || key_begin > close) break;
      const size_t key_end = text.find('"', key_begin + 1);
      const size_t colon = text.find(':', key_end);
      size_t value_begin = text.find_first_not_of(" \t\r\n", colon + 1);
      size_t value_end;
      std::string value;
      if (text[value_begin] == '"') {
        value_end = text.find('"', value_begin + 1);
        value = text.substr(value_begin + 1, value_end - value_begin - 1);
        ++value_end;
      } else {
        value_end = text.find_first_of(",}", value_begin);
        value = text.substr(value_begin, value_end - value_begin);
        while (!value.empty() && (value.back() == ' ' || value.back() == '\n')) value.pop_back();
      }
      fields[text.substr(key_begin + 1, key_end - key_begin - 1)] = value;
      at = value_end;
    }
    Dataset dataset;
    dataset.name = fields["name"];
    dataset.file = fields["file"];
    dataset.data_type = fields["data_type"];
    dataset.rate_hz = std::strtod(fields["rate"].c_str(), nullptr);
    dataset.all_taus = fields["all_taus"] == "true";
    datasets.push_back(dataset);
    pos = close + 1;
  }
  return datasets;
}

// One number per line; blank lines and '#' comments skipped.
inline std::vector<double> ReadColumn(const std::string& path) {
  std::ifstream in(path);
  std::vector<double> values;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    values.push_back(std::strtod(line.c_str(), nullptr));
  }
  return values;
}

// The phase record of a dataset: rate data through PhaseFromRate, phase data
// as is (tau0 = 1/rate).
inline PhaseRecord LoadDataset(const Dataset& dataset) {
  const std::vector<double> values = ReadColumn(ReferencePath(dataset.file));
  const double tau0_s = 1.0 / dataset.rate_hz;
  return dataset.data_type == "phase" ? PhaseFromPhase(values, tau0_s)
                                      : PhaseFromRate(values, tau0_s);
}

// A CSV file with a header row; every cell parsed as a double ("nan" -> NaN).
struct CsvTable {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  bool ok = false;

  int Column(std::string_view name) const {
    for (size_t c = 0; c < columns.size(); ++c) {
      if (columns[c] == name) return static_cast<int>(c);
    }
    return -1;
  }
};

inline std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  std::string cell;
  while (std::getline(stream, cell, ',')) cells.push_back(cell);
  return cells;
}

inline CsvTable ReadCsv(const std::string& path) {
  CsvTable table;
  std::ifstream in(path);
  if (!in) return table;
  std::string line;
  if (!std::getline(in, line)) return table;
  table.columns = SplitCsvLine(line);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<double> row;
    for (const std::string& cell : SplitCsvLine(line)) {
      row.push_back(cell == "nan" ? std::nan("") : std::strtod(cell.c_str(), nullptr));
    }
    table.rows.push_back(row);
  }
  table.ok = true;
  return table;
}

// A row of a Stable32 table: AF, Tau, #, Alpha, Min Sigma, Sigma, Max Sigma.
// `*_text` keep the printed numbers so tests can derive their precision.
struct Stable32Row {
  int64_t af = 0;
  double tau_s = 0;
  int64_t n = 0;
  int alpha = 0;
  double min_sigma = 0;
  double sigma = 0;
  double max_sigma = 0;
  std::string min_sigma_text;
  std::string sigma_text;
  std::string max_sigma_text;
};

inline std::vector<Stable32Row> ReadStable32Table(const std::string& path) {
  std::ifstream in(path);
  std::vector<Stable32Row> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream stream(line);
    Stable32Row row;
    stream >> row.af >> row.tau_s >> row.n >> row.alpha >> row.min_sigma_text >> row.sigma_text >>
        row.max_sigma_text;
    if (!stream) continue;
    row.min_sigma = std::strtod(row.min_sigma_text.c_str(), nullptr);
    row.sigma = std::strtod(row.sigma_text.c_str(), nullptr);
    row.max_sigma = std::strtod(row.max_sigma_text.c_str(), nullptr);
    rows.push_back(row);
  }
  return rows;
}

// Half a unit in the last printed digit of a number in "d.dddde+xx" form:
// the largest rounding error the printed value can carry.
inline double HalfUnitInLastPlace(const std::string& printed) {
  const size_t point = printed.find('.');
  const size_t exponent_at = printed.find_first_of("eE");
  if (point == std::string::npos || exponent_at == std::string::npos) return 0.0;
  const int decimals = static_cast<int>(exponent_at - point - 1);
  const int exponent = std::atoi(printed.c_str() + exponent_at + 1);
  return 0.5 * std::pow(10.0, exponent - decimals);
}

}  // namespace imuqual::allan::testing

#endif  // IMUQUAL_ANALYZE_ALLAN_REFERENCE_TESTING_H_
