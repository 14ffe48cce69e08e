#include "cli/export_command.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>

#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "common/clock.h"
#include "common/exit_codes.h"
#include "common/log.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "report/marks.h"
#include "report/run_samples.h"
#include "report/table_writer.h"
#include "store/archive.h"
#include "store/chunk_codec.h"
#include "store/outcome.h"
#include "store/query.h"

namespace imuqual::cli {
using report::Cell;
using report::Format;
using report::QualifierWord;
using report::RunSampleVisitor;
using report::TableWriter;
using report::WalkRunSamples;

namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

struct RunRef {
  std::string run_id;
  int64_t key = 0;
  store::RunInfo info;
};

Result<std::vector<RunRef>> ResolveRuns(store::Archive& archive, const ExportOptions& o) {
  std::vector<std::string> ids;
  if (!o.run_id.empty()) {
    ids.push_back(o.run_id);
  } else {
    store::RunFilter f;
    f.lot = o.lot;
    f.limit = std::numeric_limits<int64_t>::max();
    auto runs = store::QueryRuns(archive, f);
    if (!runs.ok()) return runs.status();
    if (runs->empty()) return Status::NotFound("no lot '" + o.lot + "' in " + o.db_path);
    for (auto it = runs->rbegin(); it != runs->rend(); ++it)
      ids.push_back(it->run_id);  // oldest first
  }
  std::vector<RunRef> out;
  for (const std::string& id : ids) {
    auto info = archive.LoadRun(id);
    if (!info.ok()) return info.status();
    auto key = archive.FindRunKey(id);
    if (!key.ok()) return key.status();
    out.push_back({id, **key, std::move(*info)});
  }
  return out;
}

Result<std::string> ExportJson(store::Archive& archive, const std::vector<RunRef>& runs) {
  pb::RunRecords records;
  for (const RunRef& r : runs) {
    auto result = archive.LoadResult(r.key);
    if (!result.ok()) return result.status();
    if (!result->has_value() || (*result)->record.empty()) {
      LogWarning("run " + r.run_id + " has no final result yet; not exported");
      continue;
    }
    pb::RunRecord* record = records.add_records();
    if (!record->ParseFromString((*result)->record)) {
      return Status::Corruption("run " + r.run_id + ": the archived record does not decode");
    }
    // Times people can read beside the microseconds (JSON carries int64 as strings).
    if (record->start_utime() > 0) record->set_start_time(FormatUtimeIso(record->start_utime()));
    if (record->end_utime() > 0) record->set_end_time(FormatUtimeIso(record->end_utime()));
  }
  std::string json;
  // Default values printed too, so every measurement shows its qualifier and
  // outcome: value 0 of pb::Outcome and pb::Qualifier is first named
  // NOT_JUDGED and MEASURED (record.proto), the names the printer writes.
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  auto st = google::protobuf::util::MessageToJsonString(records, &json, options);
  if (!st.ok()) return Status::InvalidArgument("cannot write JSON: " + std::string(st.message()));
  return json;
}

Result<std::string> ExportMeasurements(store::Archive& archive, const std::vector<RunRef>& runs) {
  TableWriter t({"lot", "serial", "run_id", "axis", "name", "value", "uncertainty", "unit", "low",
                 "high", "marginal_low", "marginal_high", "outcome", "note", "uncertainty_method",
                 "qualifier", "decision_rule", "guard_band"});
  for (const RunRef& r : runs) {
    auto result = archive.LoadResult(r.key);
    if (!result.ok()) return result.status();
    if (!result->has_value()) continue;
    for (const pb::Measurement& m : (*result)->measurements) {
      auto opt = [](bool has, double v) { return Cell::Real(has ? v : allan::kNaN); };
      // Every row says what it is: "not_judged" for a value without a limit,
      // its qualifier (QualifierWord), "none" where no decision rule applied.
      const std::string outcome_text = store::OutcomeText(m.outcome());
      const std::string outcome = outcome_text.empty() ? "not_judged" : outcome_text;
      const std::string rule = store::DecisionRuleText(m.decision_rule());
      t.AddRow({Cell::Text(r.info.lot), Cell::Text(r.info.serial), Cell::Text(r.run_id),
                Cell::Text(m.axis()), Cell::Text(m.name()), Cell::Real(m.value()),
                opt(m.has_uncertainty(), m.uncertainty()), Cell::Text(m.unit()),
                opt(m.has_low(), m.low()), opt(m.has_high(), m.high()),
                opt(m.has_marginal_low(), m.marginal_low()),
                opt(m.has_marginal_high(), m.marginal_high()), Cell::Text(outcome),
                Cell::Text(m.note()), Cell::Text(m.uncertainty_method()),
                Cell::Text(QualifierWord(m.qualifier(), m.value())),
                Cell::Text(rule.empty() ? "none" : rule), opt(m.has_guard_band(), m.guard_band())});
    }
  }
  return t.Render(Format::kCsv);
}

Result<std::string> ExportCurves(store::Archive& archive, const std::vector<RunRef>& runs) {
  TableWriter t({"lot", "serial", "run_id", "axis", "estimator", "ci_method", "m", "tau_s", "dev",
                 "lo", "hi", "edf", "n_terms", "stride", "alpha", "alpha_from"});
  for (const RunRef& r : runs) {
    auto curves = archive.LoadCurves(r.key);
    if (!curves.ok()) return curves.status();
    for (const store::CurveRecord& c : *curves) {
      for (const allan::CurvePoint& p : c.curve.points) {
        t.AddRow({Cell::Text(r.info.lot), Cell::Text(r.info.serial), Cell::Text(r.run_id),
                  Cell::Text(c.axis),
                  Cell::Text(std::string(allan::DeviationName(c.curve.deviation))),
                  Cell::Text(std::string(allan::CiMethodName(c.curve.ci))), Cell::Int(p.m),
                  Cell::Real(p.tau_s), Cell::Real(p.dev), Cell::Real(p.lo), Cell::Real(p.hi),
                  Cell::Real(p.edf), Cell::Int(p.n), Cell::Int(p.stride),
                  p.alpha ? Cell::Int(*p.alpha) : Cell::Text(""),
                  Cell::Text(!p.alpha            ? ""
                             : p.alpha_inherited ? "nearest"
                                                 : "identified")});
      }
    }
  }
  return t.Render(Format::kCsv);
}

// A record archived before schema 6 has neither a qualifier nor an
// uncertainty method (an analysis of schema 6 states one or why there is
// none): only then is the note's text read for what the qualifier says.
bool ArchivedBeforeQualifiers(const pb::Measurement& m) {
  return m.qualifier() == pb::QUALIFIER_NONE && m.uncertainty_method().empty();
}

bool UpperBound(const pb::Measurement& m) {
  if (ArchivedBeforeQualifiers(m)) return m.note().starts_with("upper bound");
  return m.qualifier() == pb::UPPER_BOUND;
}

// The noise model's p-value measurement: the model fits (not
// MODEL_INADEQUATE, and a finite p-value).
bool ModelAdequate(const pb::Measurement& p_value) {
  if (ArchivedBeforeQualifiers(p_value)) return judge::NoiseModelAdequate(p_value);
  return p_value.qualifier() != pb::MODEL_INADEQUATE && std::isfinite(p_value.value());
}

std::string Num(double v) { return ShortestReal(v); }

// A YAML 1.1 float (PyYAML, which Kalibr uses, reads "1e-05" as a string: its
// float needs a dot in the mantissa): the shortest round-trip text with ".0"
// added to a mantissa that has no dot ("1.0e-05", "200.0").
std::string YamlFloat(double v) {
  std::string text = ShortestReal(v);
  if (!std::isfinite(v) || text.find('.') != std::string::npos) return text;
  const size_t e = text.find_first_of("eE");
  return e == std::string::npos ? text + ".0" : text.insert(e, ".0");
}

// Kalibr's noise density is the continuous-time white-noise density (IEEE
// 952's N) and its random walk the bias random walk (IEEE 952's K), in rad
// (gyro) and m (accel) units; like allan_variance_ros, the sensor's value is
// the mean over its axes (each axis is listed in a comment). Only measured
// values go into that mean: an axis whose model has no such term has only a
// 95 % upper bound, listed in its own comment and left out. A sensor with no
// axis measured is refused (not measurable) unless --upper-bounds is given;
// then its value is the largest bound, said so beside it and in the summary.
// One YAML document (Kalibr's imu.yaml) for one run, and a one-line summary
// of where each value came from; errors name the run and the axes.
struct KalibrDocument {
  std::string yaml;
  std::string summary;
};

Result<KalibrDocument> KalibrYaml(store::Archive& archive, const RunRef& r,
                                  const ExportOptions& o) {
  auto result = archive.LoadResult(r.key);
  if (!result.ok()) return result.status();
  if (!result->has_value()) {
    return Status::InvalidArgument("run " + r.run_id + " has no final result yet");
  }
  // One Kalibr value: the measured axes' values and the bounded axes' bounds.
  struct Value {
    std::vector<double> measured, bounds;
    std::vector<std::string> measured_axes, bounded_axes;
  };
  struct Sensor {
    Value n, k;
    std::string comments;
  } gyro, accel;
  // A navigation filter tuned from a model that does not fit the sensor is
  // tuned wrong: only adequate models are exported.
  for (const pb::Measurement& m : (*result)->measurements) {
    if (m.name() != judge::kNoiseModelPValue) continue;
    if (!ModelAdequate(m)) {
      return Status::InvalidArgument("run " + r.run_id + " axis " + m.axis() +
                                     ": no adequate noise model for Kalibr (" + m.note() + ")");
    }
  }
  for (const pb::Measurement& m : (*result)->measurements) {
    const bool gyro_n = m.name() == judge::kFitAngleRandomWalk;
    const bool accel_n = m.name() == judge::kFitVelocityRandomWalk;
    const bool rrw = m.name() == judge::kFitRateRandomWalk;
    if (!(gyro_n || accel_n || rrw)) continue;
    if (!std::isfinite(m.value())) {
      return Status::InvalidArgument("run " + r.run_id + " axis " + m.axis() + ": " + m.name() +
                                     " not measured (" + m.note() + "); no Kalibr YAML");
    }
    bool is_accel = accel_n;
    if (rrw) {
      for (const store::AxisInfo& a : r.info.axes) {
        if (a.name == m.axis()) is_accel = a.kind == pb::ACCEL;
      }
    }
    Sensor& sensor = is_accel ? accel : gyro;
    double si;  // SI/rad base value
    if (gyro_n) {
      si = allan::DegPerRootHourToDegPerRootSec(m.value()) * kRadPerDeg;  // rad/s/sqrt(Hz)
    } else if (accel_n) {
      si = allan::MetersPerSecPerRootHourToMetersPerSecSqPerRootHz(m.value());  // m/s^2/sqrt(Hz)
    } else if (!is_accel) {
      si = allan::DegPerHourPerRootHourToDegPerSecPerRootSec(m.value()) *
           kRadPerDeg;  // rad/s^2/sqrt(Hz)
    } else {
      si = allan::MicroGToMetersPerSecSq(m.value()) / 60.0;  // ug/sqrt(h) -> m/s^3/sqrt(Hz)
    }
    Value& v = rrw ? sensor.k : sensor.n;
    const bool bound = UpperBound(m);
    (bound ? v.bounds : v.measured).push_back(si);
    (bound ? v.bounded_axes : v.measured_axes).push_back(m.axis());
    sensor.comments += "#   " + m.axis() + (rrw ? " random_walk " : " noise_density ") + Num(si) +
                       (bound ? " (only an upper bound at 95 %: the noise model has no such "
                                "term; not in the mean below)"
                              : "") +
                       "\n";
  }
  std::string yaml = "# " + r.info.serial + ", run " + r.run_id + " (lot " + r.info.lot +
                     "): composite noise model, mean over the measured axes\n";
  std::vector<std::string> summary;
  for (auto [sensor, name] :
       {std::pair{&accel, std::string("accelerometer")}, std::pair{&gyro, std::string("gyroscope")}}) {
    // Kalibr's imu.yaml has both sensors: a unit without one cannot fill it.
    const size_t terms = sensor->n.measured.size() + sensor->n.bounds.size() +
                         sensor->k.measured.size() + sensor->k.bounds.size();
    if (sensor->n.measured.size() + sensor->n.bounds.size() == 0 ||
        sensor->k.measured.size() + sensor->k.bounds.size() == 0) {
      return Status::InvalidArgument("run " + r.run_id + " (unit " + r.info.serial + "): no " +
                                     name + " noise density and random walk (" +
                                     (terms == 0 ? "no " + name + " axis" : "a term not measured") +
                                     "); Kalibr's imu.yaml needs both sensors");
    }
    std::string lines = "#" + std::string(1, static_cast<char>(std::toupper(name[0]))) +
                        name.substr(1) + "\n" + sensor->comments;
    for (auto [value, key] : {std::pair{&sensor->n, name + "_noise_density"},
                              std::pair{&sensor->k, name + "_random_walk"}}) {
      double written;
      if (!value->measured.empty()) {
        double sum = 0;
        for (double x : value->measured) sum += x;
        written = sum / static_cast<double>(value->measured.size());
        if (!value->bounds.empty()) {
          lines += "# " + key + ": the mean of " + Join(value->measured_axes, ", ") +
                   " (measured); " + Join(value->bounded_axes, ", ") + " only bounded, not in it\n";
          summary.push_back(key + " from " + Join(value->measured_axes, ", ") + " (" +
                            Join(value->bounded_axes, ", ") + " only bounded)");
        }
      } else if (o.kalibr_upper_bounds) {
        written = *std::max_element(value->bounds.begin(), value->bounds.end());
        lines += "# " + key +
                 ": AN UPPER BOUND at 95 %, not a measured value (the largest of the bounds of " +
                 Join(value->bounded_axes, ", ") + "; no axis measured it; --upper-bounds)\n";
        summary.push_back(key + " an upper bound (no axis measured it)");
      } else {
        return Status::InvalidArgument(
            "run " + r.run_id + " (unit " + r.info.serial + "): " + key +
            " is not measurable: the noise model of " + Join(value->bounded_axes, ", ") +
            " has no such term, only a 95 % upper bound; --upper-bounds writes the largest bound "
            "as the value, said so in the file");
      }
      lines += key + ": " + YamlFloat(written) + "\n";
    }
    yaml += lines;
  }
  yaml += "rostopic: '" + o.rostopic + "'\nupdate_rate: " + YamlFloat(r.info.nominal_rate_hz) + "\n";
  return KalibrDocument{yaml, r.info.serial + " (run " + r.run_id + "): " +
                                   (summary.empty() ? "every value the mean of measured axes"
                                                    : Join(summary, "; "))};
}

// --format kalibr: one run's YAML to -o FILE (or standard output), or each
// unit's latest run of a lot into -o DIR/ as DIR/<serial>.yaml (one document
// per file, as Kalibr and PyYAML's safe_load read it). Every problem is
// reported; the files of the units without one are written.
int ExportKalibr(store::Archive& archive, const std::vector<RunRef>& runs, const ExportOptions& o) {
  if (o.run_id.empty() && (o.output.empty() || o.output.back() != '/')) {
    LogError(
        "a lot's Kalibr export is one file per unit: give -o DIR/ (the trailing / names a "
        "directory)");
    return kExitUsage;
  }
  // Each unit's latest judged run, else its latest (as `imuqual lot` counts
  // a unit; runs are oldest first): a superseded retest is not the unit.
  std::map<std::string, const RunRef*> latest;
  std::set<std::string> judged;
  for (const RunRef& r : runs) {
    auto result = archive.LoadResult(r.key);
    const bool has_result = result.ok() && result->has_value();
    if (has_result || !judged.count(r.info.serial)) latest[r.info.serial] = &r;
    if (has_result) judged.insert(r.info.serial);
  }
  int exit_code = kExitOk;
  for (const auto& [serial, run] : latest) {
    Result<KalibrDocument> doc = KalibrYaml(archive, *run, o);
    if (!doc.ok()) {
      LogError(doc.status().message());
      // Refused (a model or term that cannot tune a filter): 2, as before;
      // the archive failing: 1.
      exit_code =
          std::max(exit_code, doc.status().code() == Status::Code::kInvalidArgument ? kExitUsage
                                                                                    : kExitError);
      continue;
    }
    const std::string& yaml = doc->yaml;
    LogInfo("kalibr: " + doc->summary);
    if (!o.run_id.empty() && (o.output.empty() || o.output == "-")) {
      std::fwrite(yaml.data(), 1, yaml.size(), stdout);
      continue;
    }
    std::string path = o.output;
    if (path.back() == '/') {
      std::error_code ec;
      std::filesystem::create_directories(path, ec);
      path += serial + ".yaml";
    }
    if (Status st = WriteStringToFile(path, yaml); !st.ok()) {
      LogError(st.message());
      exit_code = std::max(exit_code, kExitError);
    }
  }
  return exit_code;
}

// The shortest text that reads back as the same float32 (the archived bits).
std::string FloatText(float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// A column name's unit suffix for an axis kind: deg/s -> deg_s, m/s^2 -> m_s2.
std::string UnitSuffix(pb::AxisKind kind) { return kind == pb::ACCEL ? "m_s2" : "deg_s"; }

// --format samples: one run's raw samples as archived, one row per device
// sample counter from the first archived chunk to the last; see the header.
Status ExportSamples(store::Archive& archive, const RunRef& run, std::FILE* out) {
  const store::RunInfo& info = run.info;
  const double rate = info.nominal_rate_hz;
  std::string header = "sample,device_time_s,arrival_utime";
  for (const store::AxisInfo& a : info.axes) header += "," + a.name + "_" + UnitSuffix(a.kind);
  header += ",temperature_c,flags\n";
  std::fputs(header.c_str(), out);
  const size_t axes = info.axes.size();
  std::string row;
  std::vector<int> bits;
  // The plan's sensor range, as the analysis reads it (none: a plan that
  // does not decode, or says none).
  pb::TestPlan plan;
  if (!plan.ParseFromString(info.plan)) plan.Clear();
  std::vector<double> out_of_range_at;
  for (const store::AxisInfo& a : info.axes) {
    out_of_range_at.push_back(judge::OutOfRangeAt(plan, a.kind));
  }
  const auto time_of = [&](int64_t first, int64_t counter) {
    return ShortestReal(static_cast<double>(counter - first) / rate);
  };
  RunSampleVisitor visitor;
  // Samples that never arrived: rows with empty values, flagged "missing".
  visitor.missing = [&](int64_t first, int64_t from, int64_t count) {
    for (int64_t k = from; k < from + count; ++k) {
      row = std::to_string(k) + "," + time_of(first, k) + ",";
      for (size_t a = 0; a < axes; ++a) row += ",";
      row += ",,missing\n";  // no temperature either
      std::fputs(row.c_str(), out);
    }
    return Status::Ok();
  };
  visitor.chunk = [&](int64_t first, const store::ChunkRecord& c, const store::ChunkData& chunk) {
    const std::string temperature = c.temperature_c ? ShortestReal(*c.temperature_c) : "";
    for (int i = 0; i < chunk.num_samples; ++i) {
      const int64_t k = c.first_sample + i;
      row = std::to_string(k) + "," + time_of(first, k) + ",";
      if (c.sample_utime > 0) row += std::to_string(c.sample_utime + std::llround(i * 1e6 / rate));
      // Per axis: the source's flags (1 saturated, 2 invalid), and a value
      // that is not a finite number (NaN, inf: a bad cell or reading) or is
      // out of the plan's sensor range is invalid as the analysis counts it,
      // flagged or not.
      bits.assign(axes, 0);
      for (size_t a = 0; a < axes; ++a) {
        const float v = chunk.at(static_cast<int>(a), i);
        row += "," + FloatText(v);
        if (!std::isfinite(v) || judge::OutOfRange(v, out_of_range_at[a])) bits[a] |= 2;
      }
      for (const store::SampleFlag& f : chunk.flags) {
        if (f.sample == i && f.axis < axes) bits[f.axis] |= f.bits;
      }
      std::string flags;
      for (size_t a = 0; a < axes; ++a) {
        const int f = bits[a];
        if (f == 0) continue;
        if (!flags.empty()) flags += " ";
        flags += info.axes[a].name + ":" +
                 ((f & 1) && (f & 2) ? "saturated+invalid"
                  : (f & 1)          ? "saturated"
                  : (f & 2)          ? "invalid"
                                     : std::to_string(f));
      }
      row += "," + temperature + "," + flags + "\n";
      std::fputs(row.c_str(), out);
    }
    return Status::Ok();
  };
  auto walk = WalkRunSamples(archive, run.key, info, visitor);
  if (!walk.ok()) return walk.status();
  if (walk->skipped > 0) {
    LogWarning(
        "run " + run.run_id + ": " + std::to_string(walk->skipped) +
        " archived chunks not exported (counter went backwards or jumped by more than a day, "
        "or axes differ), as the analysis rejected them");
  }
  if (std::fflush(out) != 0 || std::ferror(out))
    return Status::IoError("writing the samples failed");
  return Status::Ok();
}

}  // namespace

int ExportCommand(const ExportOptions& o) {
  if (o.lot.empty() == o.run_id.empty()) {
    LogError("export needs exactly one of --lot or --run");
    return 2;
  }
  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto runs = ResolveRuns(**archive, o);
  if (!runs.ok()) {
    LogError(runs.status().message());
    return runs.status().code() == Status::Code::kNotFound ? 2 : 1;
  }
  if (o.as == "samples") {
    // Streamed: a long run's samples do not fit in one string.
    if (!o.lot.empty()) {
      LogError("--format samples exports one run: give --run, not --lot");
      return 2;
    }
    const bool to_stdout = o.output.empty() || o.output == "-";
    std::FILE* out = to_stdout ? stdout : std::fopen(o.output.c_str(), "w");
    if (out == nullptr) {
      LogError("cannot write " + o.output + ": " + std::strerror(errno));
      return 1;
    }
    const Status st = ExportSamples(**archive, runs->front(), out);
    if (!to_stdout && std::fclose(out) != 0 && st.ok()) {
      LogError("cannot write " + o.output + ": " + std::strerror(errno));
      return 1;
    }
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
    return 0;
  }
  if (o.as == "kalibr") return ExportKalibr(**archive, *runs, o);
  Result<std::string> text =
      Status::InvalidArgument("--format must be json, measurements, curves, kalibr or samples");
  if (o.as == "json") text = ExportJson(**archive, *runs);
  if (o.as == "measurements") text = ExportMeasurements(**archive, *runs);
  if (o.as == "curves") text = ExportCurves(**archive, *runs);

  if (!text.ok()) {
    LogError(text.status().message());
    return text.status().code() == Status::Code::kInvalidArgument ? 2 : 1;
  }
  if (o.output.empty() || o.output == "-") {
    std::fwrite(text->data(), 1, text->size(), stdout);
    return 0;
  }
  Status st = WriteStringToFile(o.output, *text);
  if (!st.ok()) {
    LogError(st.message());
    return 1;
  }
  return 0;
}

}  // namespace imuqual::cli
