// The local model of the residuals (optimizer/local_model.h) on hand-made observations: an
// exact linear function is recovered, groups keep intercepts of their own, distant
// observations weigh less, and the prior holds the slopes where nothing measures them. The
// fit's ridge on the intercepts (1e-9) leaves errors near 1e-9: checks allow 1e-7.
#include "local_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace solid::optimizer {
namespace {

// r = 1.5 + 2 x0 - 3 x1 at points around (0.5, 0.5), one target, variance 1.
std::vector<Observation> Plane(int group = 0, double intercept = 1.5) {
  std::vector<Observation> out;
  for (double a : {0.4, 0.5, 0.6}) {
    for (double b : {0.4, 0.5, 0.6}) out.push_back({{a, b}, {intercept + 2 * (a - 0.5) - 3 * (b - 0.5)}, {1}, group});
  }
  return out;
}

TEST(LocalModel, RecoversALinearFunctionExactly) {
  const LocalModel m = FitLocalModel(Plane(), {0.5, 0.5}, 0.3, {0, 0}, 1e6);
  ASSERT_EQ(m.residuals.size(), 1u);
  EXPECT_NEAR(m.residuals[0], 1.5, 1e-7);
  EXPECT_NEAR(m.jacobian[0], 2, 1e-7);
  EXPECT_NEAR(m.jacobian[1], -3, 1e-7);
  // Nine observations of variance 1 near the centre: the level's variance is about a ninth.
  EXPECT_GT(m.variances[0], 1.0 / 9);
  EXPECT_LT(m.variances[0], 1.0 / 5);
}

TEST(LocalModel, LevelAtAnotherCentreFollowsTheSlopes) {
  const LocalModel m = FitLocalModel(Plane(), {0.6, 0.4}, 0.3, {0, 0}, 1e6);
  EXPECT_NEAR(m.residuals[0], 1.5 + 2 * 0.1 + 3 * 0.1, 1e-7);
}

// Measurements on one set of layouts share its sampling error: a group of their own keeps its
// offset out of the level, which group 0 alone sets, while every group teaches the slopes.
TEST(LocalModel, GroupsShareSlopesNotLevels) {
  std::vector<Observation> all = Plane(1, 5.0);
  all.push_back({{0.5, 0.5}, {1.5}, {1}, 0});
  const LocalModel m = FitLocalModel(all, {0.5, 0.5}, 0.3, {0, 0}, 1e6);
  EXPECT_NEAR(m.residuals[0], 1.5, 1e-7);
  EXPECT_NEAR(m.jacobian[0], 2, 1e-7);
  EXPECT_NEAR(m.jacobian[1], -3, 1e-7);
}

// What paired layouts measure of one group's offset ties its intercept to group 0's: with
// evaluations alone near the centre, the level is theirs less the offset; a measurement of
// group 0 and the prior then share the say by their variances.
TEST(LocalModel, InterceptPriorTiesAGroupToTheLevel) {
  const InterceptPrior offset{1, {3.5}, {1e-8}};
  const LocalModel tied = FitLocalModel(Plane(1, 5.0), {0.5, 0.5}, 0.3, {0, 0}, 1e6, {offset});
  EXPECT_NEAR(tied.residuals[0], 1.5, 1e-6);
  EXPECT_NEAR(tied.jacobian[0], 2, 1e-6);
  std::vector<Observation> with_level = Plane(1, 5.0);
  with_level.push_back({{0.5, 0.5}, {2.5}, {0.5}, 0});
  const LocalModel shared = FitLocalModel(with_level, {0.5, 0.5}, 0.3, {0, 0}, 1e6, {{1, {3.5}, {0.5}}});
  // The evaluations say 1.5 with a variance of about 0.12 + 0.5, the measurement 2.5 with 0.5.
  EXPECT_GT(shared.residuals[0], 1.5);
  EXPECT_LT(shared.residuals[0], 2.5);
  EXPECT_NEAR(shared.residuals[0], 2.0, 0.1);
}

// A measurement far from the centre weighs less than one near it, in proportion to
// exp(-d^2 / (2 radius^2)): two measurements of the level disagree, and the fit lies nearer
// the near one.
TEST(LocalModel, DistantObservationsWeighLess) {
  const std::vector<Observation> two = {{{0.5}, {1.0}, {1}, 0}, {{0.8}, {3.0}, {1}, 0}};
  // One dimension with its slope held at 0 by a tight prior: a weighted mean of the two.
  const LocalModel m = FitLocalModel(two, {0.5}, 0.1, {0}, 1e-6);
  const double far = std::exp(-0.09 / 0.02);
  EXPECT_NEAR(m.residuals[0], (1.0 + far * 3.0) / (1 + far), 1e-6);
}

// Observations that all sit at the centre measure no slope: the prior's stands.
TEST(LocalModel, PriorHoldsUnmeasuredSlopes) {
  const std::vector<Observation> at_centre = {{{0.5, 0.5}, {0.7}, {0.01}, 0}, {{0.5, 0.5}, {0.9}, {0.01}, 0}};
  const LocalModel m = FitLocalModel(at_centre, {0.5, 0.5}, 0.3, {4, -1}, 10);
  EXPECT_NEAR(m.residuals[0], 0.8, 1e-7);
  EXPECT_NEAR(m.jacobian[0], 4, 1e-7);
  EXPECT_NEAR(m.jacobian[1], -1, 1e-7);
  EXPECT_NEAR(m.variances[0], 0.005, 1e-7);
}

// Each target is fitted on its own, with its own variances.
TEST(LocalModel, TargetsAreFittedApart) {
  std::vector<Observation> obs;
  for (double a : {0.3, 0.5, 0.7}) obs.push_back({{a}, {a, -2 * a}, {1, 4}, 0});
  const LocalModel m = FitLocalModel(obs, {0.5}, 1, {0, 0}, 1e6);
  ASSERT_EQ(m.jacobian.size(), 2u);
  EXPECT_NEAR(m.residuals[0], 0.5, 1e-7);
  EXPECT_NEAR(m.residuals[1], -1.0, 1e-7);
  EXPECT_NEAR(m.jacobian[0], 1, 1e-7);
  EXPECT_NEAR(m.jacobian[1], -2, 1e-7);
  EXPECT_GT(m.variances[1], 3 * m.variances[0]);
}

}  // namespace
}  // namespace solid::optimizer
