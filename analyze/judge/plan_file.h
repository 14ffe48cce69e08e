// Loading a plan named on a command line: "builtin:NAME" or a .textproto
// file. Separate from plan.h, which stays free of I/O.
#ifndef IMUQUAL_ANALYZE_JUDGE_PLAN_FILE_H_
#define IMUQUAL_ANALYZE_JUDGE_PLAN_FILE_H_

#include <string>

#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::judge {

Result<pb::TestPlan> LoadPlan(const std::string& spec);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_PLAN_FILE_H_
