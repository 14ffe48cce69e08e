#include "analyze/judge/run_admission.h"

#include "analyze/judge/plan.h"
#include "common/text_util.h"

namespace imuqual::judge {
namespace {

// Free text that shows on screens and in reports: no control characters,
// bounded.
Status CheckText(const char* what, const std::string& value, size_t max_bytes) {
  if (value.size() > max_bytes) {
    return Status::InvalidArgument(std::string(what) + " is longer than " +
                                   std::to_string(max_bytes) + " bytes");
  }
  for (unsigned char c : value) {
    if (c < 0x20 || c == 0x7f) {
      return Status::InvalidArgument(std::string(what) + " holds a control character");
    }
  }
  return Status::Ok();
}

}  // namespace

RunAdmission::RunAdmission(std::vector<pb::TestPlan> accepted) : accepted_(std::move(accepted)) {}

std::string RunAdmission::AcceptedNames() const {
  std::string names;
  for (const pb::TestPlan& p : accepted_) {
    names += (names.empty() ? "" : ", ") + (p.name().empty() ? std::string("(unnamed)") : p.name());
  }
  return names;
}

Status RunAdmission::Admit(const imuqual::run_t& run) const {
  // A run id is <prefix>-<serial>: the identifier alphabet, longer.
  if (run.run_id.empty() || run.run_id.size() > 160 ||
      run.run_id.find_first_not_of(
          "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-") !=
          std::string::npos) {
    return Status::InvalidArgument("run id '" + run.run_id.substr(0, 160) +
                                   "' must be 1-160 characters of A-Z a-z 0-9 . _ -");
  }
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("unit serial", run.unit_serial));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("lot", run.lot));
  IMUQUAL_RETURN_IF_ERROR(ValidateIdentifier("station", run.station));
  IMUQUAL_RETURN_IF_ERROR(CheckText("slot", run.slot, 64));
  IMUQUAL_RETURN_IF_ERROR(CheckText("operator name", run.operator_name, 256));
  IMUQUAL_RETURN_IF_ERROR(CheckText("source", run.source, 1024));
  const std::string plan_bytes(run.plan.begin(), run.plan.end());
  if (Sha256Hex(plan_bytes) != run.plan_sha256) {
    return Status::InvalidArgument("the plan's digest does not match its bytes");
  }
  if (accepted_.empty()) return Status::Ok();
  pb::TestPlan plan;
  if (!plan.ParseFromString(plan_bytes)) return Status::InvalidArgument("the plan does not decode");
  for (const pb::TestPlan& a : accepted_) {
    if (IsCompletionOf(plan, a)) return Status::Ok();
  }
  return Status::InvalidArgument(
      "plan '" + plan.name() + "' (sha256 " + run.plan_sha256.substr(0, 16) +
      "...) is not a plan this station accepts (" + AcceptedNames() + ")");
}

std::string RunIdentityDifference(const imuqual::run_t& a, const imuqual::run_t& b) {
  if (a.run_id != b.run_id) return "run_id";
  if (a.unit_serial != b.unit_serial) return "unit_serial";
  if (a.lot != b.lot) return "lot";
  if (a.station != b.station) return "station";
  if (a.slot != b.slot) return "slot";
  if (a.operator_name != b.operator_name) return "operator_name";
  if (a.source != b.source) return "source";
  if (a.software_version != b.software_version) return "software_version";
  if (a.start_utime != b.start_utime) return "start_utime";
  if (a.nominal_rate_hz != b.nominal_rate_hz) return "nominal_rate_hz";
  if (a.axis_names != b.axis_names || a.axis_kinds != b.axis_kinds) return "axes";
  if (a.plan_sha256 != b.plan_sha256 || a.plan != b.plan) return "plan";
  if (a.truth != b.truth) return "truth";
  return "";
}

}  // namespace imuqual::judge
