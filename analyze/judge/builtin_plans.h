// The plan files of plans/, compiled into the binaries (generated at build
// time from the .textproto files, so the files stay the single source).
#ifndef IMUQUAL_ANALYZE_JUDGE_BUILTIN_PLANS_H_
#define IMUQUAL_ANALYZE_JUDGE_BUILTIN_PLANS_H_

#include <string_view>
#include <vector>

namespace imuqual::judge {

struct BuiltinPlanFile {
  std::string_view name;  // file name without .textproto
  std::string_view text;
};

const std::vector<BuiltinPlanFile>& BuiltinPlanFiles();

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_BUILTIN_PLANS_H_
