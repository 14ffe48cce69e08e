#include "analyze/judge/plan_file.h"

#include "analyze/judge/plan.h"
#include "common/text_util.h"

namespace imuqual::judge {

Result<pb::TestPlan> LoadPlan(const std::string& spec) {
  constexpr std::string_view kBuiltin = "builtin:";
  if (spec.rfind(kBuiltin, 0) == 0) return BuiltinPlan(spec.substr(kBuiltin.size()));
  auto text = ReadFileToString(spec);
  // A plan that cannot be read is bad input, not an I/O failure of ours.
  if (!text.ok()) return Status::InvalidArgument("test plan: " + text.status().message());
  return ParsePlanText(*text, spec);
}

}  // namespace imuqual::judge
