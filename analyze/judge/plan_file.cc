#include "analyze/judge/plan_file.h"

#include "analyze/judge/plan.h"
#include "common/text_util.h"

namespace imuqual::judge {

Result<pb::TestPlan> LoadPlan(const std::string& spec) {
  constexpr std::string_view kBuiltin = "builtin:";
  if (spec.rfind(kBuiltin, 0) == 0) return BuiltinPlan(spec.substr(kBuiltin.size()));
  auto text = ReadFileToString(spec);
  if (!text.ok()) return text.status();
  return ParsePlanText(*text, spec);
}

}  // namespace imuqual::judge
