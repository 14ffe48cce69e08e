#include "station/station_config.h"

#include <cmath>
#include <filesystem>
#include <set>

#include "acquire/source_spec.h"
#include "analyze/judge/plan_file.h"
#include "common/keys.h"
#include "common/text_util.h"
#include "proto/text_proto.h"

namespace imuqual::station {
namespace {

constexpr int kMaxShards = 64;
constexpr int kMaxSlots = 1000;

std::string DirOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
}

std::string Resolve(const std::string& dir, const std::string& path) {
  if (path.empty() || path[0] == '/' || dir == ".") return path;
  return std::filesystem::path(dir + "/" + path).lexically_normal().string();
}

}  // namespace

Result<pb::StationConfig> ParseStationConfig(const std::string& text, const std::string& path,
                                             std::vector<int>* slot_lines) {
  pb::StationConfig c;
  pb::TextProto parsed;
  IMUQUAL_RETURN_IF_ERROR(parsed.Parse(text, path, &c));
  const auto* type = pb::StationConfig::descriptor();
  // "FILE:LINE: field: problem", at the field's line when it was written,
  // else at the file.
  auto fail = [&](const char* field, int index, const std::string& problem,
                  const char* sub = nullptr) {
    const int line = parsed.LineOf(type, field, index, sub);
    return Status::InvalidArgument(path + ":" + (line > 0 ? std::to_string(line) + ":" : "") + " " +
                                   problem);
  };
  auto identifier = [&](const char* field, const std::string& value) {
    Status st = ValidateIdentifier(field, value);
    return st.ok() ? st : fail(field, 0, st.message());
  };
  IMUQUAL_RETURN_IF_ERROR(identifier("station_id", c.station_id()));
  IMUQUAL_RETURN_IF_ERROR(identifier("lot", c.lot()));
  if (c.plan().empty())
    return fail("plan", 0, "plan: required (a .textproto file or builtin:NAME)");
  if (c.plan().rfind("builtin:", 0) != 0) c.set_plan(Resolve(DirOf(path), c.plan()));
  auto plan = judge::LoadPlan(c.plan());
  if (!plan.ok()) return fail("plan", 0, "plan: " + plan.status().message());
  if (IsBlank(c.operator_name()) && (c.require_operator() || plan->require_operator())) {
    return fail(c.require_operator() ? "require_operator" : "plan", 0,
                std::string("operator_name: required (") +
                    (c.require_operator() ? "require_operator is set"
                                          : "plan " + plan->name() + " has require_operator") +
                    "): the operator who runs the station");
  }
  if (!(c.duration_s() > 0) || !std::isfinite(c.duration_s())) {
    return fail("duration_s", 0, "duration_s: must be > 0 seconds");
  }
  if (c.archive().empty()) return fail("archive", 0, "archive: required (the SQLite file)");
  c.set_archive(Resolve(DirOf(path), c.archive()));
  if (!c.report().empty()) c.set_report(Resolve(DirOf(path), c.report()));
  // Trust: each key file resolved and read now, so that a wrong one is
  // named with its line before any process starts.
  if (!c.key_file().empty()) {
    c.set_key_file(Resolve(DirOf(path), c.key_file()));
    if (auto key = ReadStationKeyFile(c.key_file()); !key.ok())
      return fail("key_file", 0, "key_file: " + key.status().message());
  }
  if (!c.trust_file().empty()) {
    c.set_trust_file(Resolve(DirOf(path), c.trust_file()));
    if (auto keys = ReadPublicKeyFile(c.trust_file()); !keys.ok())
      return fail("trust_file", 0, "trust_file: " + keys.status().message());
    if (c.key_file().empty())
      return fail("trust_file", 0, "trust_file: needs key_file too (role signatures ride on an "
                                   "authenticated bus)");
  }
  const std::pair<const char*, std::string*> sign_keys[] = {
      {"acquire_sign_key", c.mutable_acquire_sign_key()},
      {"analyze_sign_key", c.mutable_analyze_sign_key()},
      {"store_sign_key", c.mutable_store_sign_key()}};
  for (const auto& [field, value] : sign_keys) {
    if (value->empty()) continue;
    *value = Resolve(DirOf(path), *value);
    auto key = ReadSigningKeyFile(*value);
    if (!key.ok()) return fail(field, 0, std::string(field) + ": " + key.status().message());
    const std::string role = std::string(field).substr(0, std::string(field).find('_'));
    if (key->role != role) {
      return fail(field, 0, std::string(field) + ": " + *value + " is the " + key->role +
                                " role's key, not " + role + "'s");
    }
  }
  if (c.analyze_shards() < 0 || c.analyze_shards() > kMaxShards) {
    return fail("analyze_shards", 0, "analyze_shards: must be 1.." + std::to_string(kMaxShards));
  }
  if (!(c.pace() >= 0) || !std::isfinite(c.pace())) return fail("pace", 0, "pace: must be >= 0");
  if (c.has_rate_hz() && !(c.rate_hz() > 0 && std::isfinite(c.rate_hz()))) {
    return fail("rate_hz", 0, "rate_hz: must be > 0 Hz (leave it out for the profile's rate)");
  }
  if (!(c.stale_after_s() >= 0) || !std::isfinite(c.stale_after_s())) {
    return fail("stale_after_s", 0, "stale_after_s: must be >= 0");
  }
  if (c.slot_size() == 0)
    return Status::InvalidArgument(path + ": no slot: give at least one slot { ... }");
  if (c.slot_size() > kMaxSlots)
    return fail("slot", kMaxSlots, "slot: at most " + std::to_string(kMaxSlots));
  std::set<std::string> serials, names;
  for (int i = 0; i < c.slot_size(); ++i) {
    pb::Slot& s = *c.mutable_slot(i);
    const std::string label = "slot " + std::to_string(i + 1);
    if (s.name().empty()) s.set_name(std::to_string(i + 1));
    if (Status st = ValidateIdentifier(label + " name", s.name()); !st.ok()) {
      return fail("slot", i, st.message(), "name");
    }
    if (Status st = ValidateIdentifier(label + " unit_serial", s.unit_serial()); !st.ok()) {
      return fail("slot", i, st.message(), "unit_serial");
    }
    if (!names.insert(s.name()).second)
      return fail("slot", i, label + ": slot name '" + s.name() + "' twice", "name");
    if (!serials.insert(s.unit_serial()).second) {
      return fail("slot", i, label + ": unit " + s.unit_serial() + " is in two slots",
                  "unit_serial");
    }
    auto spec = acquire::ParseSourceSpec(s.source());
    if (!spec.ok()) return fail("slot", i, label + " source: " + spec.status().message(), "source");
    if ((spec->kind == "csv" || spec->kind == "archive" || spec->kind == "bag") &&
        !spec->location.empty() && spec->location[0] != '/') {
      const std::string head = spec->kind + ":" + spec->location;
      if (s.source().compare(0, head.size(), head) == 0) {
        s.set_source(spec->kind + ":" + Resolve(DirOf(path), spec->location) +
                     s.source().substr(head.size()));
      }
    }
  }
  if (slot_lines) {
    slot_lines->clear();
    for (int i = 0; i < c.slot_size(); ++i) slot_lines->push_back(parsed.LineOf(type, "slot", i));
  }
  return c;
}

Result<pb::StationConfig> LoadStationConfig(const std::string& path, std::vector<int>* slot_lines) {
  auto text = ReadFileToString(path);
  if (!text.ok())
    return Status::NotFound("station configuration " + path + ": " + text.status().message());
  return ParseStationConfig(*text, path, slot_lines);
}

StationRunOptions StationRunFromConfig(const pb::StationConfig& c, const std::string& path,
                                       const std::vector<int>& slot_lines) {
  StationRunOptions o;
  o.station = c.station_id();
  o.lcm_url = c.lcm_url();
  o.lot = c.lot();
  o.operator_name = c.operator_name();
  o.plan_spec = c.plan();
  o.duration_s = c.duration_s();
  o.db_path = c.archive();
  o.report_path = c.report();
  o.analyze_shards = std::max(1, c.analyze_shards());
  o.pace = c.pace();
  if (c.has_rate_hz()) o.rate_hz = c.rate_hz();
  if (c.stale_after_s() > 0) o.stale_after_s = c.stale_after_s();
  o.key_file = c.key_file();
  o.trust_file = c.trust_file();
  o.acquire_sign_key = c.acquire_sign_key();
  o.analyze_sign_key = c.analyze_sign_key();
  o.store_sign_key = c.store_sign_key();
  o.insecure_bus = c.insecure_bus();
  o.sync_to = c.sync_to();
  for (int i = 0; i < c.slot_size(); ++i) {
    const pb::Slot& s = c.slot(i);
    o.units.push_back(s.unit_serial() + "=" + s.source());
    o.slots.push_back(s.name());
    const int line = i < static_cast<int>(slot_lines.size()) ? slot_lines[i] : 0;
    o.unit_locations.push_back(path.empty() ? ""
                               : line > 0   ? path + ":" + std::to_string(line)
                                            : path);
  }
  return o;
}

}  // namespace imuqual::station
