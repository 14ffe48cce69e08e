#include "store/outcome.h"

namespace imuqual::store {
namespace {

constexpr std::pair<pb::Outcome, const char*> kOutcomes[] = {
    {pb::PASS, "PASS"},         {pb::MARGINAL, "MARGINAL"}, {pb::FAIL, "FAIL"},
    {pb::INCONCLUSIVE, "INCONCLUSIVE"}, {pb::ABORTED, "ABORTED"}, {pb::ERROR, "ERROR"},
};
constexpr std::pair<pb::Qualifier, const char*> kQualifiers[] = {
    {pb::UPPER_BOUND, "upper_bound"},
    {pb::MINIMUM_NOT_RESOLVED, "minimum_not_resolved"},
    {pb::NOT_MEASURABLE, "not_measurable"},
    {pb::MODEL_INADEQUATE, "model_inadequate"},
};
constexpr std::pair<pb::Limit::DecisionRule, const char*> kRules[] = {
    {pb::Limit::SIMPLE, "simple"},
    {pb::Limit::GUARDED, "guarded"},
    {pb::Limit::GUARDED_ACCEPTANCE, "guarded_acceptance"},
    {pb::Limit::GUARDED_REJECTION, "guarded_rejection"},
};

template <typename Enum, size_t N>
const char* TextOf(const std::pair<Enum, const char*> (&table)[N], Enum value) {
  for (const auto& [v, text] : table) {
    if (v == value) return text;
  }
  return "";
}

template <typename Enum, size_t N>
Enum ValueOf(const std::pair<Enum, const char*> (&table)[N], std::string_view text, Enum none) {
  for (const auto& [v, t] : table) {
    if (t == text) return v;
  }
  return none;
}

}  // namespace

const char* OutcomeText(pb::Outcome outcome) { return TextOf(kOutcomes, outcome); }

pb::Outcome OutcomeFromText(std::string_view text) {
  return ValueOf(kOutcomes, text, pb::OUTCOME_UNSET);
}

pb::Outcome OutcomeFromNumber(int number) {
  return pb::Outcome_IsValid(number) ? static_cast<pb::Outcome>(number) : pb::OUTCOME_UNSET;
}

int OutcomeSeverity(pb::Outcome outcome) {
  switch (outcome) {
    case pb::PASS: return 1;
    case pb::MARGINAL: return 2;
    case pb::INCONCLUSIVE: return 3;
    case pb::FAIL: return 4;
    case pb::ABORTED: return 5;
    case pb::ERROR: return 6;
    default: return 0;
  }
}

int OutcomeSeverity(std::string_view text) { return OutcomeSeverity(OutcomeFromText(text)); }

int AttentionRank(pb::Outcome verdict) {
  switch (verdict) {
    case pb::FAIL: return 5;
    case pb::ERROR: return 4;
    case pb::ABORTED: return 3;
    case pb::INCONCLUSIVE: return 2;
    case pb::MARGINAL: return 1;
    default: return 0;
  }
}

bool IsJudged(pb::Outcome outcome) {
  return outcome == pb::PASS || outcome == pb::MARGINAL || outcome == pb::FAIL ||
         outcome == pb::INCONCLUSIVE;
}

bool CountsInYield(pb::Outcome outcome) {
  return outcome == pb::PASS || outcome == pb::MARGINAL || outcome == pb::FAIL;
}

const char* QualifierText(pb::Qualifier qualifier) { return TextOf(kQualifiers, qualifier); }

pb::Qualifier QualifierFromText(std::string_view text) {
  return ValueOf(kQualifiers, text, pb::QUALIFIER_NONE);
}

const char* DecisionRuleText(pb::Limit::DecisionRule rule) { return TextOf(kRules, rule); }

pb::Limit::DecisionRule DecisionRuleFromText(std::string_view text) {
  return ValueOf(kRules, text, pb::Limit::RULE_DEFAULT);
}

}  // namespace imuqual::store
