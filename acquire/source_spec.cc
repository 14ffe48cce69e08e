#include "acquire/source_spec.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>

#include "acquire/csv_source.h"
#include "acquire/lot_profile.h"
#include "acquire/sim_source.h"
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
      return Status::InvalidArgument("source " + spec.kind + ":" + spec.location +
                                     ": unknown option '" + key + "' (known: " +
                                     Join(std::vector<std::string>(known.begin(), known.end()), ", ") + ")");
    }
  }
  return Status::Ok();
}

Result<std::unique_ptr<SampleSource>> MakeSim(const SourceSpec& spec, const SourceDefaults& d) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(spec, {"index", "duration", "rate", "seed"}));
  auto profile = sim::LotProfileByName(spec.location.empty() ? "vg700" : spec.location);
  if (!profile.ok()) return profile.status();
  auto index = Number(spec, "index", d.index);
  auto duration = Number(spec, "duration", d.duration_s);
  auto rate = Number(spec, "rate", d.rate_hz);
  auto seed = Number(spec, "seed", static_cast<double>(d.seed));
  for (const auto* r : {&index, &duration, &rate, &seed}) {
    if (!r->ok()) return r->status();
  }
  const uint64_t lot_seed = *seed != 0 ? static_cast<uint64_t>(*seed) : sim::SeedFromName(d.lot);
  auto source = SimSource::Create(*profile, lot_seed, static_cast<int>(*index), *rate, *duration);
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

Result<std::unique_ptr<SampleSource>> MakeCsv(const SourceSpec& spec, const SourceDefaults& d) {
  IMUQUAL_RETURN_IF_ERROR(CheckKeys(spec, {"rate", "axes", "counter", "scale"}));
  CsvSourceOptions o;
  o.path = spec.location;
  auto rate = Number(spec, "rate", d.plan.nominal_rate_hz());
  auto scale = Number(spec, "scale", 1.0);
  if (!rate.ok()) return rate.status();
  if (!scale.ok()) return scale.status();
  o.rate_hz = *rate;
  o.scale = *scale;
  if (auto it = spec.options.find("counter"); it != spec.options.end()) o.counter_column = it->second;
  if (auto it = spec.options.find("axes"); it != spec.options.end()) {
    for (const std::string& item : Split(it->second, '/')) {
      const std::vector<std::string> parts = Split(item, ':');
      pb::Axis a;
      a.set_name(parts[0]);
      a.set_kind(parts.size() > 1 && parts[1] == "accel" ? pb::ACCEL : pb::GYRO);
      if (parts[0].empty() || parts.size() > 2 || (parts.size() == 2 && parts[1] != "gyro" && parts[1] != "accel")) {
        return Status::InvalidArgument("source csv:" + o.path + ": axes item '" + item +
                                       "' must be NAME, NAME:gyro or NAME:accel");
      }
      o.axes.push_back(a);
    }
  } else {
    for (const pb::Axis& a : d.plan.axes()) o.axes.push_back(a);
  }
  if (o.axes.empty()) {
    return Status::InvalidArgument("source csv:" + o.path +
                                   ": name its axes (axes=gx:gyro/...) or use a plan with axes");
  }
  auto source = CsvSource::Open(o);
  if (!source.ok()) return source.status();
  return std::unique_ptr<SampleSource>(std::move(*source));
}

}  // namespace

Result<SourceSpec> ParseSourceSpec(const std::string& text) {
  const size_t colon = text.find(':');
  if (colon == std::string::npos || colon == 0) {
    return Status::InvalidArgument("source '" + text + "' must be KIND:LOCATION[,KEY=VALUE...] "
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
  return Status::InvalidArgument("source kind '" + spec.kind + "' is not one of sim, csv");
}

}  // namespace imuqual::acquire
