// Which run announcements a station takes, the same rule in analyze and in
// the store: a run's names are identifiers (nothing an operator's screen or
// a file name could choke on), its plan is the one its digest names and one
// the station accepts (its station file or command line names it), and once
// a run is announced, what it is never changes: a later announcement that
// differs in identity or plan is refused, never applied.
#ifndef IMUQUAL_ANALYZE_JUDGE_RUN_ADMISSION_H_
#define IMUQUAL_ANALYZE_JUDGE_RUN_ADMISSION_H_

#include <string>
#include <vector>

#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/run_t.hpp"

namespace imuqual::judge {

class RunAdmission {
 public:
  // `accepted`: the plans this station runs, as their files give them (a
  // run carries one completed from its source where the file is silent:
  // IsCompletionOf). Empty: any plan whose digest holds.
  explicit RunAdmission(std::vector<pb::TestPlan> accepted = {});

  // Ok, or why `run` is refused, in one line naming the field.
  Status Admit(const imuqual::run_t& run) const;
  bool restricts_plans() const { return !accepted_.empty(); }
  // "vg700ca, tactical": the accepted plans' names, for the log.
  std::string AcceptedNames() const;

 private:
  std::vector<pb::TestPlan> accepted_;
};

// "" when `later` announces the run `first` announced (same identity and
// plan; state, progress and judgement round may move on), else the name of
// the first field that differs ("operator_name", "plan", ...).
std::string RunIdentityDifference(const imuqual::run_t& first, const imuqual::run_t& later);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_RUN_ADMISSION_H_
