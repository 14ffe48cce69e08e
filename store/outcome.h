// The text of outcomes, qualifiers and decision rules as the archive, the
// CLI and the reports write them: one place for every conversion between
// pb::Outcome ("PASS", ..., "ERROR"), pb::Qualifier ("upper_bound", ...) and
// pb::Limit::DecisionRule ("simple", ...) and their text.
#ifndef IMUQUAL_STORE_OUTCOME_H_
#define IMUQUAL_STORE_OUTCOME_H_

#include <string_view>

#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::store {

// "PASS", "MARGINAL", "FAIL", "INCONCLUSIVE", "ABORTED", "ERROR"; "" for
// OUTCOME_UNSET (not judged) and any unknown number.
const char* OutcomeText(pb::Outcome outcome);
// The inverse; OUTCOME_UNSET for "" and any other text.
pb::Outcome OutcomeFromText(std::string_view text);
// The number as read from the bus or a record (an unknown number: unset).
pb::Outcome OutcomeFromNumber(int number);

// How bad an outcome is, for "the worst of": unset 0 < PASS 1 < MARGINAL 2
// < INCONCLUSIVE 3 < FAIL 4 (ABORTED and ERROR, run verdicts only, rank
// above FAIL: 5 and 6).
int OutcomeSeverity(pb::Outcome outcome);
int OutcomeSeverity(std::string_view text);

// How urgently a unit with this verdict needs a look, for the report's and
// the console's "worst first": FAIL 5, ERROR 4, ABORTED 3, INCONCLUSIVE 2,
// MARGINAL 1; 0 for none (PASS, not judged).
int AttentionRank(pb::Outcome verdict);

// Judged verdicts say something about the unit (it was measured to the
// end): PASS, MARGINAL, FAIL, INCONCLUSIVE. ABORTED, ERROR and unset do not.
bool IsJudged(pb::Outcome outcome);
// Verdicts that count in a yield: PASS, MARGINAL (passed) and FAIL.
bool CountsInYield(pb::Outcome outcome);

// "upper_bound", "minimum_not_resolved", "not_measurable",
// "model_inadequate"; "" for QUALIFIER_NONE (stored as NULL).
const char* QualifierText(pb::Qualifier qualifier);
pb::Qualifier QualifierFromText(std::string_view text);

// "simple", "guarded", "guarded_acceptance", "guarded_rejection"; "" for
// RULE_DEFAULT (no limit applied; stored as NULL).
const char* DecisionRuleText(pb::Limit::DecisionRule rule);
pb::Limit::DecisionRule DecisionRuleFromText(std::string_view text);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_OUTCOME_H_
