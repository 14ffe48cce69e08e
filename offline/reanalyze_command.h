// `imuqual reanalyze RUN`: the analysis of an archived run again.
//  - by default, the live analysis (streaming engine, the run's plan) over the
//    archived samples: the archived result bit for bit (--check says so,
//    after checking the run's stored checksums: a damaged chunk or result
//    is named and fails the check);
//  - with --exact, the exact batch estimators on any grid, stop rule and
//    confidence interval, over every archived sample (no warm-up skipped;
//    missing and flagged samples are gaps): what `imuqual analyze` gives for
//    the same samples;
//  - with --looks (live mode), every look of the run's early decisions: the
//    evidence of each look, what was decided and what was still pending.
#ifndef IMUQUAL_OFFLINE_REANALYZE_COMMAND_H_
#define IMUQUAL_OFFLINE_REANALYZE_COMMAND_H_

#include <string>

namespace imuqual::offline {

struct ReanalyzeOptions {
  std::string db_path;
  std::string run_id;
  bool exact = false;
  bool check = false;          // live mode: checksums, then compare with the archived curves
  std::string devs = "oadev";  // --exact: estimators, grid, stop rule, CI
  std::string grid = "octave";
  std::string stop = "bins9";
  std::string ci = "none";
  double confidence = 0.682689492137086;
  std::string format = "table";
  // live mode: every look of the run's early decisions instead of the curves
  bool looks = false;
};

int ReanalyzeCommand(const ReanalyzeOptions& options);

}  // namespace imuqual::offline

#endif  // IMUQUAL_OFFLINE_REANALYZE_COMMAND_H_
