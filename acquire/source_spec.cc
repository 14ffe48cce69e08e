#include "acquire/source_spec.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include "acquire/archive_source.h"
#include "acquire/crossbow_protocol.h"
#include "acquire/csv_source.h"
#include "acquire/lot_profile.h"
#include "acquire/rosbag_source.h"
#include "acquire/serial_source.h"
#include "acquire/sim_source.h"
#include "acquire/text_protocol.h"
#include "acquire/xsens_protocol.h"
#include "analyze/allan/units.h"
#include "common/strings.h"

namespace imuqual::acquire {
namespace {

Result<double> Number(const SourceSpec& spec, const std::string& key, double fallback) {
  auto it = spec.options.find(key);
  if (it == spec.options.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
    return Status::InvalidArgument("source " + spec.kind + ":" + spec.location + ": " + key + "='" +
                                   it->second + "' is not a number");
  }
  return v;
}

Status CheckKeys(const SourceSpec& spec, const std::set<std::string>& known) {
  for (const auto& [key, value] : spec.options) {
    if (!known.count(key)) {
      return Status::InvalidArgument(
          "source " + spec.kind + ":" + spec.location + ": unknown option '" + key +
          "' (known: " + Join(std::vector<std::string>(known.begin(), known.end()), ", ") + ")");
    }
  }
  return Status::Ok();
}

std::string Where(const SourceSpec& spec) { return "source " + spec.kind + ":" + spec.location; }

// axes=NAME[:gyro|:accel]/... (kinds default to gyro).
Result<std::vector<pb::Axis>> ParseAxes(const SourceSpec& spec, const std::string& text) {
  std::vector<pb::Axis> axes;
  for (const std::string& item : Split(text, '/')) {
    const std::vector<std::string> parts = Split(item, ':');
    if (parts[0].empty() || parts.size() > 2 ||
        (parts.size() == 2 && parts[1] != "gyro" && parts[1] != "accel")) {
      return Status::InvalidArgument(Where(spec) + ": axes item '" + item +
                                     "' must be NAME, NAME:gyro or NAME:accel");
    }
    pb::Axis a;
    a.set_name(parts[0]);
    a.set_kind(parts.size() > 1 && parts[1] == "accel" ? pb::ACCEL : pb::GYRO);
    axes.push_back(a);
  }
  return axes;
}

std::string Option(const SourceSpec& spec, const std::string& key,
                   const std::string& fallback = "") {
  auto it = spec.options.find(key);
  return it == spec.options.end() ? fallback : it->second;
}

Result<int> Integer(const SourceSpec& spec, const std::string& key, int fallback) {
  auto v = Number(spec, key, fallback);
  if (!v.ok()) return v.status();
  if (*v != std::floor(*v) || std::abs(*v) > 1e9) {
    return Status::InvalidArgument(Where(spec) + ": " + key + " must be an integer");
  }
  return static_cast<int>(*v);
}

Result<std::unique_ptr<SampleSource>> MakeSim(const SourceSpec& spec, const SourceDefaults& d) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(
      spec, {"index", "duration", "rate", "seed", "actual_rate", "quantize", "lsb", "bits"}));
  auto profile = sim::LotProfileByName(spec.location.empty() ? "vg700" : spec.location);
  if (!profile.ok()) return profile.status();
  auto index = Number(spec, "index", d.index);
  auto duration = Number(spec, "duration", d.duration_s);
  auto rate = Number(spec, "rate", d.rate_hz);
  auto seed = Number(spec, "seed", static_cast<double>(d.seed));
  auto actual = Number(spec, "actual_rate", 0);
  auto quantize = Number(spec, "quantize", 1);
  auto lsb = Number(spec, "lsb", 0);
  auto bits = Number(spec, "bits", 16);
  for (const auto* r : {&index, &duration, &rate, &seed, &actual, &quantize, &lsb, &bits}) {
    if (!r->ok()) return r->status();
  }
  // d.rate_hz = 0 means "the profile's"; a rate= given must be a rate.
  if (spec.options.count("rate") > 0 && !(*rate > 0)) {
    return Status::InvalidArgument(Where(spec) +
                                   ": rate must be > 0 Hz (leave it out for the profile's)");
  }
  if (*quantize != 0 && *quantize != 1) {
    return Status::InvalidArgument(Where(spec) + ": quantize must be 0 or 1");
  }
  SimOutput output;
  output.actual_rate_hz = *actual;
  output.quantize = *quantize == 1;
  output.lsb = *lsb;
  output.adc_bits = static_cast<int>(*bits);
  const uint64_t lot_seed = *seed != 0 ? static_cast<uint64_t>(*seed) : sim::SeedFromName(d.lot);
  auto source =
      SimSource::Create(*profile, lot_seed, static_cast<int>(*index), *rate, *duration, output);
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

// An axis's column mapping, AXIS=COLUMN[:UNIT[:SCALE]]: the column, and the
// factor UNIT-to-base x SCALE (UNIT a sensor output unit of the axis's kind,
// allan::OutputUnitToBase; SCALE a number, e.g. an LSB).
Status MapCsvAxis(const SourceSpec& spec, const pb::Axis& axis, const std::string& text,
                  std::string* column, double* factor) {
  const std::vector<std::string> parts = Split(text, ':');
  const std::string what = Where(spec) + ": " + axis.name() + "='" + text + "'";
  if (parts.empty() || parts[0].empty() || parts.size() > 3) {
    return Status::InvalidArgument(what + " must be COLUMN[:UNIT[:SCALE]]");
  }
  *column = parts[0];
  *factor = 0.0;  // a column alone: scale= applies (csv_source.h)
  if (parts.size() == 1 || (parts[1].empty() && parts.size() == 2)) return Status::Ok();
  *factor = 1.0;
  const allan::SensorKind kind =
      axis.kind() == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
  if (parts.size() > 1 && !parts[1].empty()) {
    *factor = allan::OutputUnitToBase(parts[1], kind);
    if (!std::isfinite(*factor)) {
      return Status::InvalidArgument(
          what + ": unit '" + parts[1] + "' is not a unit for " +
          (kind == allan::SensorKind::kGyro ? "a gyro" : "an accelerometer") + " axis (" +
          std::string(allan::OutputUnitNames(kind)) + ")");
    }
  }
  if (parts.size() > 2) {
    char* end = nullptr;
    const double scale = std::strtod(parts[2].c_str(), &end);
    if (parts[2].empty() || *end != '\0' || !std::isfinite(scale) || scale == 0) {
      return Status::InvalidArgument(what + ": scale '" + parts[2] +
                                     "' must be a finite, non-zero number");
    }
    *factor *= scale;
  }
  return Status::Ok();
}

Result<std::unique_ptr<SampleSource>> MakeCsv(const SourceSpec& spec, const SourceDefaults& d) {
  CsvSourceOptions o;
  o.path = spec.location;
  auto rate = Number(spec, "rate", d.plan.nominal_rate_hz());
  auto scale = Number(spec, "scale", 1.0);
  if (!rate.ok()) return rate.status();
  if (!scale.ok()) return scale.status();
  o.rate_hz = *rate;
  o.scale = *scale;
  if (auto it = spec.options.find("counter"); it != spec.options.end())
    o.counter_column = it->second;
  if (auto it = spec.options.find("time"); it != spec.options.end()) o.time_column = it->second;
  if (auto it = spec.options.find("temperature"); it != spec.options.end()) {
    o.temperature_column = it->second;
  }
  if (auto it = spec.options.find("axes"); it != spec.options.end()) {
    auto axes = ParseAxes(spec, it->second);
    if (!axes.ok()) return axes.status();
    o.axes = std::move(*axes);
  } else {
    for (const pb::Axis& a : d.plan.axes()) o.axes.push_back(a);
  }
  if (o.axes.empty()) {
    return Status::InvalidArgument("source csv:" + o.path +
                                   ": name its axes (axes=gx:gyro/...) or use a plan with axes");
  }
  // The options, and one AXIS=COLUMN[:UNIT[:SCALE]] per axis that is not
  // read from the column of its name or not in the axis's unit.
  std::set<std::string> known = {"rate", "axes", "counter", "scale", "time", "temperature"};
  for (const pb::Axis& a : o.axes) known.insert(a.name());
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(spec, known));
  o.axis_columns.assign(o.axes.size(), "");
  o.axis_factors.assign(o.axes.size(), 0.0);
  for (size_t a = 0; a < o.axes.size(); ++a) {
    const auto it = spec.options.find(o.axes[a].name());
    if (it == spec.options.end()) continue;
    IMUQUAL_RETURN_IF_ERROR(
        MapCsvAxis(spec, o.axes[a], it->second, &o.axis_columns[a], &o.axis_factors[a]));
  }
  auto source = CsvSource::Open(o);
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

// bag:PATH[,topic=/imu][,rate=HZ][,axes=gx/gy/gz/ax/ay/az]: the channels
// default to the plan's axes when every one is a channel name, else all six.
Result<std::unique_ptr<SampleSource>> MakeBag(const SourceSpec& spec, const SourceDefaults& d) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(spec, {"topic", "rate", "axes"}));
  RosbagSourceOptions o;
  o.path = spec.location;
  o.topic = Option(spec, "topic", "/imu");
  auto rate = Number(spec, "rate", d.plan.nominal_rate_hz());
  if (!rate.ok()) return rate.status();
  o.rate_hz = *rate;
  if (!(o.rate_hz > 0)) {
    return Status::InvalidArgument(Where(spec) + ": give rate=HZ (or a plan with nominal_rate_hz)");
  }
  if (auto it = spec.options.find("axes"); it != spec.options.end()) {
    o.channels = Split(it->second, '/');
  } else {
    const std::vector<std::string>& names = RosbagSource::ChannelNames();
    bool plan_named = d.plan.axes_size() > 0;
    for (const pb::Axis& a : d.plan.axes()) {
      plan_named = plan_named && std::find(names.begin(), names.end(), a.name()) != names.end();
    }
    if (plan_named) {
      for (const pb::Axis& a : d.plan.axes()) o.channels.push_back(a.name());
    }
  }
  auto source = RosbagSource::Open(o);
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

// The text protocol's decoder and the axes it yields.
Result<std::unique_ptr<FrameDecoder>> MakeTextDecoder(const SourceSpec& spec,
                                                      const SourceDefaults& d,
                                                      std::vector<pb::Axis>* axes) {
  TextProtocolOptions t;
  const std::string columns = Option(spec, "columns");
  if (columns.empty()) {
    return Status::InvalidArgument(Where(spec) +
                                   ": protocol=text needs columns=NAME/NAME/... "
                                   "(the fields of a line, _ for one to ignore)");
  }
  t.columns = Split(columns, '/');
  t.counter_column = Option(spec, "counter");
  t.temperature_column = Option(spec, "temperature");
  const std::string delimiter = Option(spec, "delimiter", "comma");
  static const std::map<std::string, char> kDelimiters = {
      {"comma", ','}, {"semicolon", ';'}, {"tab", '\t'}, {"space", ' '}};
  auto dl = kDelimiters.find(delimiter);
  if (dl == kDelimiters.end()) {
    return Status::InvalidArgument(Where(spec) + ": delimiter '" + delimiter +
                                   "' must be comma, semicolon, tab or space");
  }
  t.delimiter = dl->second;
  const std::string checksum = Option(spec, "checksum", "none");
  if (checksum != "none" && checksum != "nmea") {
    return Status::InvalidArgument(Where(spec) + ": checksum '" + checksum +
                                   "' must be none or nmea");
  }
  t.nmea_checksum = checksum == "nmea";
  auto bits = Integer(spec, "counter_bits", 0);
  if (!bits.ok()) return bits.status();
  t.counter_bits = *bits;
  if (axes->empty()) {
    // Every named field but the counter and the temperature, as gyros.
    for (const std::string& c : t.columns) {
      if (c == "_" || c == t.counter_column || c == t.temperature_column) continue;
      pb::Axis a;
      a.set_name(c);
      a.set_kind(pb::GYRO);
      axes->push_back(a);
    }
  }
  for (const pb::Axis& a : *axes) t.axes.push_back(a.name());
  // scale=F (every axis) or scale=NAME:F/NAME:F (the others stay 1).
  t.scales.assign(t.axes.size(), 1.0);
  const std::string scale = Option(spec, "scale");
  if (!scale.empty()) {
    for (const std::string& item : Split(scale, '/')) {
      const size_t colon = item.find(':');
      const std::string value = colon == std::string::npos ? item : item.substr(colon + 1);
      char* end = nullptr;
      const double f = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || !std::isfinite(f) || f == 0) {
        return Status::InvalidArgument(Where(spec) + ": scale item '" + item +
                                       "' must be F or AXIS:F with F finite and non-zero");
      }
      bool found = colon == std::string::npos;
      for (size_t a = 0; a < t.axes.size(); ++a) {
        if (colon == std::string::npos || t.axes[a] == item.substr(0, colon)) {
          t.scales[a] = f;
          found = true;
        }
      }
      if (!found) {
        return Status::InvalidArgument(Where(spec) + ": scale names '" + item.substr(0, colon) +
                                       "', which is not an axis");
      }
    }
  }
  (void)d;
  auto decoder = TextLineDecoder::Create(std::move(t));
  if (!decoder.ok()) return decoder.status().WithContext(Where(spec));
  return std::unique_ptr<FrameDecoder>(std::move(*decoder));
}

Result<std::unique_ptr<SampleSource>> MakeSerial(const SourceSpec& spec, const SourceDefaults& d) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(
      spec, {"protocol", "rate", "baud", "parity", "data_bits", "stop_bits", "flow", "duration",
             "axes", "columns", "counter", "counter_bits", "temperature", "scale", "delimiter",
             "checksum", "reconnect_timeout", "rate_range", "g_range"}));
  SerialSourceOptions o;
  o.port.device = spec.location;
  o.protocol = Option(spec, "protocol");
  if (o.protocol != "text" && o.protocol != "xsens" && o.protocol != "crossbow") {
    return Status::InvalidArgument(Where(spec) +
                                   ": protocol=" + (o.protocol.empty() ? "?" : o.protocol) +
                                   " must be text, xsens or crossbow");
  }
  if (o.protocol != "crossbow") {
    for (const char* key : {"rate_range", "g_range"}) {
      if (spec.options.count(key)) {
        return Status::InvalidArgument(Where(spec) + ": '" + key + "' is for protocol=crossbow");
      }
    }
  }
  auto baud = Integer(spec, "baud", 115200);
  auto data_bits = Integer(spec, "data_bits", 8);
  auto stop_bits = Integer(spec, "stop_bits", 1);
  auto parity = ParseParity(Option(spec, "parity", "none"));
  auto flow = ParseFlowControl(Option(spec, "flow", "none"));
  auto rate = Number(spec, "rate", d.plan.nominal_rate_hz());
  // Record the plan's warm-up and minimum duration unless told otherwise.
  auto duration =
      Number(spec, "duration",
             d.duration_s > 0 ? d.duration_s : d.plan.min_duration_s() + d.plan.warmup_s());
  auto reconnect = Number(spec, "reconnect_timeout", 30);
  for (const auto* r : {&baud, &data_bits, &stop_bits}) {
    if (!r->ok()) return r->status();
  }
  for (const auto* r : {&rate, &duration, &reconnect}) {
    if (!r->ok()) return r->status();
  }
  if (!parity.ok()) return parity.status().WithContext(Where(spec));
  if (!flow.ok()) return flow.status().WithContext(Where(spec));
  o.port.baud = *baud;
  o.port.data_bits = *data_bits;
  o.port.stop_bits = *stop_bits;
  o.port.parity = *parity;
  o.port.flow = *flow;
  o.rate_hz = *rate;
  o.duration_s = *duration;
  o.reconnect_timeout_s = *reconnect;
  if (!(o.rate_hz > 0)) {
    return Status::InvalidArgument(Where(spec) + ": give rate=HZ (or a plan with nominal_rate_hz)");
  }
  if (!(o.duration_s > 0)) {
    return Status::InvalidArgument(Where(spec) +
                                   ": give duration=S (or --duration, or a plan "
                                   "with min_duration_s)");
  }
  std::vector<pb::Axis> axes;
  if (auto it = spec.options.find("axes"); it != spec.options.end()) {
    auto parsed = ParseAxes(spec, it->second);
    if (!parsed.ok()) return parsed.status();
    axes = std::move(*parsed);
  } else {
    for (const pb::Axis& a : d.plan.axes()) axes.push_back(a);
  }
  std::unique_ptr<FrameDecoder> decoder;
  if (o.protocol == "text") {
    auto text = MakeTextDecoder(spec, d, &axes);
    if (!text.ok()) return text.status();
    decoder = std::move(*text);
  } else {
    for (const char* key :
         {"columns", "counter", "counter_bits", "temperature", "scale", "delimiter", "checksum"}) {
      const bool crossbow_checksum = o.protocol == "crossbow" && std::string(key) == "checksum";
      if (spec.options.count(key) && !crossbow_checksum) {
        return Status::InvalidArgument(Where(spec) + ": '" + key + "' is for protocol=text");
      }
    }
    if (o.port.flow == FlowControl::kXonXoff) {
      return Status::InvalidArgument(Where(spec) +
                                     ": flow=xonxoff cannot carry a binary protocol "
                                     "(the line would swallow its 0x11 and 0x13 bytes)");
    }
    if (axes.empty()) {
      auto parsed = ParseAxes(spec, "gx:gyro/gy:gyro/gz:gyro");
      axes = std::move(*parsed);
    }
    if (o.protocol == "crossbow") {
      CrossbowOptions c;
      c.axes = axes;
      auto rr = Number(spec, "rate_range", 0);
      auto gr = Number(spec, "g_range", 0);
      if (!rr.ok()) return rr.status();
      if (!gr.ok()) return gr.status();
      c.rate_range_dps = *rr;
      c.g_range = *gr;
      const std::string rule = Option(spec, "checksum", "either");
      if (rule == "mod256") {
        c.checksum = CrossbowChecksum::kMod256;
      } else if (rule == "mod255") {
        c.checksum = CrossbowChecksum::kMod255;
      } else if (rule != "either") {
        return Status::InvalidArgument(Where(spec) + ": checksum=" + rule +
                                       " must be mod256, mod255 or either (the manual gives both)");
      }
      auto crossbow = CrossbowDecoder::Create(c);
      if (!crossbow.ok()) return crossbow.status().WithContext(Where(spec));
      decoder = std::move(*crossbow);
    } else {
      auto xsens = XsensDecoder::Create(axes);
      if (!xsens.ok()) return xsens.status().WithContext(Where(spec));
      decoder = std::move(*xsens);
    }
  }
  o.axes = axes;
  auto source = SerialSource::Open(std::move(o), std::move(decoder));
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

Result<std::unique_ptr<SampleSource>> MakeArchive(const SourceSpec& spec) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(spec, {"run"}));
  auto source = ArchiveSource::Open(spec.location, Option(spec, "run"));
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

}  // namespace

Result<SourceSpec> ParseSourceSpec(const std::string& text) {
  const size_t colon = text.find(':');
  if (colon == std::string::npos || colon == 0) {
    return Status::InvalidArgument("source '" + text +
                                   "' must be KIND:LOCATION[,KEY=VALUE...] "
                                   "(sim:vg700, csv:FILE,rate=100, ...)");
  }
  SourceSpec spec;
  spec.kind = text.substr(0, colon);
  const std::vector<std::string> parts = Split(text.substr(colon + 1), ',');
  spec.location = parts[0];
  for (size_t i = 1; i < parts.size(); ++i) {
    const size_t eq = parts[i].find('=');
    if (eq == std::string::npos || eq == 0) {
      return Status::InvalidArgument("source '" + text + "': '" + parts[i] + "' is not KEY=VALUE");
    }
    if (!spec.options.emplace(parts[i].substr(0, eq), parts[i].substr(eq + 1)).second) {
      return Status::InvalidArgument("source '" + text + "': '" + parts[i].substr(0, eq) +
                                     "' given twice");
    }
  }
  return spec;
}

Result<std::unique_ptr<SampleSource>> MakeSource(const SourceSpec& spec, const SourceDefaults& d) {
  if (spec.kind == "sim") return MakeSim(spec, d);
  if (spec.kind == "csv") return MakeCsv(spec, d);
  if (spec.kind == "serial") return MakeSerial(spec, d);
  if (spec.kind == "archive") return MakeArchive(spec);
  if (spec.kind == "bag") return MakeBag(spec, d);
  return Status::InvalidArgument("source kind '" + spec.kind +
                                 "' is not one of sim, csv, serial, archive, bag");
}

Status CheckSourceAxes(const std::string& serial, const SourceInfo& info,
                       const pb::TestPlan& plan) {
  if (plan.axes_size() == 0) return Status::Ok();
  bool match = plan.axes_size() == static_cast<int>(info.axes.size());
  for (size_t i = 0; match && i < info.axes.size(); ++i) {
    match =
        plan.axes(i).name() == info.axes[i].name() && plan.axes(i).kind() == info.axes[i].kind();
  }
  if (match) return Status::Ok();
  auto names = [](const auto& axes) {
    std::vector<std::string> parts;
    for (const pb::Axis& a : axes)
      parts.push_back(a.name() + (a.kind() == pb::ACCEL ? "(accel)" : "(gyro)"));
    return Join(parts, ",");
  };
  return Status::InvalidArgument("unit " + serial + ": source axes " + names(info.axes) +
                                 " do not match the plan's axes " + names(plan.axes()));
}

}  // namespace imuqual::acquire
