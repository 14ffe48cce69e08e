// The selected model's parameters as named quantities and back
// (model_quantities.h): the archive keeps them to draw the model again.
#include "analyze/allan/model_quantities.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace imuqual::allan {
namespace {

CompositeFit HandMadeFit() {
  CompositeFit fit;
  fit.tau0_s = 0.01;
  auto add = [&](ModelTerm t) {
    fit.model.terms.push_back(t);
    FittedTerm f;
    f.term = t;
    f.scale_sigma = 0.1 * t.scale;
    fit.terms.push_back(f);
  };
  add({TermKind::kQuantization, 2e-4});
  add({TermKind::kWhite, 0.005});
  add({TermKind::kRandomWalk, 3e-4});
  ModelTerm slow{TermKind::kGaussMarkov, 0.01};
  slow.correlation_time_s = 30;
  add(slow);
  ModelTerm fast{TermKind::kGaussMarkov, 0.02};
  fast.correlation_time_s = 0.5;
  add(fast);
  ModelTerm line{TermKind::kSinusoid, 0.03};
  line.frequency_hz = 24.5;
  add(line);
  return fit;
}

TEST(ModelQuantitiesTest, ModelTermsRoundTrip) {
  const CompositeFit fit = HandMadeFit();
  for (SensorKind kind : {SensorKind::kGyro, SensorKind::kAccelerometer}) {
    const std::vector<ModelQuantity> q = DescribeModelTerms(fit, kind);
    ASSERT_EQ(q.size(), 3u + 2 * 3u);
    EXPECT_EQ(q[0].name, "quantization");
    EXPECT_EQ(q[3].name, "gauss_markov_1_sigma");  // the faster one first
    const Result<CompositeModel> back = ModelFromTerms(q, kind);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(back->terms.size(), fit.model.terms.size());
    for (double m : {1.0, 3.0, 64.0, 1e4}) {
      // Datasheet units and back: a multiplication and a division.
      EXPECT_NEAR(back->Avar(m, fit.tau0_s), fit.model.Avar(m, fit.tau0_s),
                  1e-12 * fit.model.Avar(m, fit.tau0_s))
          << m;
    }
  }
}

TEST(ModelQuantitiesTest, ModelFromTermsRefusesWhatWouldDrawAWrongModel) {
  std::vector<ModelQuantity> q = DescribeModelTerms(HandMadeFit(), SensorKind::kGyro);
  std::vector<ModelQuantity> wrong_unit = q;
  wrong_unit[1].unit = "deg/h";
  EXPECT_FALSE(ModelFromTerms(wrong_unit, SensorKind::kGyro).ok());
  std::vector<ModelQuantity> negative = q;
  negative[1].value = -1;
  EXPECT_FALSE(ModelFromTerms(negative, SensorKind::kGyro).ok());
  std::vector<ModelQuantity> half_a_term;
  for (const ModelQuantity& x : q) {
    if (x.name != "gauss_markov_2_correlation_time") half_a_term.push_back(x);
  }
  const Result<CompositeModel> r = ModelFromTerms(half_a_term, SensorKind::kGyro);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("gauss_markov_2"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::allan
