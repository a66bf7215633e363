// The confirmation's estimator (optimizer/estimator.h) on hand-made per-layout totals, where
// every figure can be worked out by hand: the metrics as ratios of sums, standard errors over
// layouts, the two-phase estimate and its error, and the sizes that reach a standard error.
#include "estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace solid::optimizer {
namespace {

// A layout with `visible` objects, each occluded `occlusion` and all of one scale class.
ImageTotals Layout(int64_t index, int64_t visible, double occlusion, int scale_class) {
  ImageTotals t{index, visible, occlusion * static_cast<double>(visible), 0, 0, 0};
  (scale_class == 0 ? t.small : scale_class == 1 ? t.medium : t.large) = visible;
  return t;
}

TEST(EstimateMetric, CountIsTheMeanWithItsStandardErrorOverLayouts) {
  const std::vector<ImageTotals> low = {Layout(0, 2, 0, 0), Layout(1, 4, 0, 0), Layout(2, 9, 0, 0)};
  const TwoPhaseEstimate e = EstimateMetric(low, {}, Metric::kObjectsPerImage);
  EXPECT_DOUBLE_EQ(e.mean, 5);
  // Sample variance (9 + 1 + 16) / 2 = 13.
  EXPECT_DOUBLE_EQ(e.low_variance, 13);
  EXPECT_DOUBLE_EQ(e.standard_error, std::sqrt(13.0 / 3));
  EXPECT_EQ(e.difference_variance, 0);
}

// Every object of a layout shares its class (the camera that sees few objects sees them all
// small): the share's error is the layouts', far above a binomial error over the objects.
TEST(EstimateMetric, ShareErrorIsOverLayoutsNotObjects) {
  std::vector<ImageTotals> low;
  for (int i = 0; i < 100; ++i) low.push_back(Layout(i, 10, 0, i % 2));
  const TwoPhaseEstimate e = EstimateMetric(low, {}, Metric::kSmall);
  EXPECT_DOUBLE_EQ(e.mean, 0.5);
  // Influences (a_i - 0.5 v_i) / 10 = +-0.5: variance 0.25 * 100 / 99.
  EXPECT_NEAR(e.standard_error, std::sqrt(0.25 / 99), 1e-12);
  const double binomial = std::sqrt(0.5 * 0.5 / 1000);
  EXPECT_GT(e.standard_error, 3 * binomial);
}

TEST(EstimateMetric, OcclusionIsPooledOverVisibleObjects) {
  const std::vector<ImageTotals> low = {Layout(0, 1, 0.9, 0), Layout(1, 3, 0.1, 0)};
  EXPECT_DOUBLE_EQ(EstimateMetric(low, {}, Metric::kOcclusion).mean, (0.9 + 0.3) / 4);
}

// The output resolution sees one more object in every paired layout: the estimate is the low
// resolution's mean plus one, and a difference that never varies adds no error.
TEST(EstimateMetric, TwoPhaseAddsThePairedDifference) {
  std::vector<ImageTotals> low, high;
  for (int i = 0; i < 40; ++i) low.push_back(Layout(i, 3 + i % 7, 0, 0));
  for (int i = 0; i < 10; ++i) high.push_back(Layout(i, 3 + i % 7 + 1, 0, 0));
  const TwoPhaseEstimate alone = EstimateMetric(low, {}, Metric::kObjectsPerImage);
  const TwoPhaseEstimate e = EstimateMetric(low, high, Metric::kObjectsPerImage);
  EXPECT_DOUBLE_EQ(e.mean, alone.mean + 1);
  EXPECT_DOUBLE_EQ(e.difference_variance, 0);
  EXPECT_NEAR(e.standard_error, alone.standard_error, 1e-12);
}

// Pairs are matched by index: a high-resolution layout without its low-resolution twin (a
// failed draw) is left out, and the difference is taken over the matched ones only.
TEST(EstimateMetric, PairsMatchByIndex) {
  const std::vector<ImageTotals> low = {Layout(0, 2, 0, 0), Layout(2, 4, 0, 0), Layout(3, 6, 0, 0)};
  const std::vector<ImageTotals> high = {Layout(0, 3, 0, 0), Layout(1, 100, 0, 0), Layout(2, 7, 0, 0)};
  // Low over all: 4; pairs 0 and 2: high 5, low 3.
  EXPECT_DOUBLE_EQ(EstimateMetric(low, high, Metric::kObjectsPerImage).mean, 4 + 5 - 3);
}

// A difference that varies adds its own error: the two-phase error against its formula,
// sum over layouts of (influence / N + [paired] difference / K)^2, N / (N - 1).
TEST(EstimateMetric, TwoPhaseErrorAgainstItsFormula) {
  std::vector<ImageTotals> low, high;
  for (int i = 0; i < 6; ++i) low.push_back(Layout(i, 2 + (i * 5) % 6, 0, 0));
  for (int i = 0; i < 3; ++i) high.push_back(Layout(i, low[i].visible + (i == 1 ? 2 : 0), 0, 0));
  const TwoPhaseEstimate e = EstimateMetric(low, high, Metric::kObjectsPerImage);
  double mean_low = 0;
  for (const ImageTotals& t : low) mean_low += static_cast<double>(t.visible) / 6;
  const double pair_low = static_cast<double>(low[0].visible + low[1].visible + low[2].visible) / 3;
  const double pair_high = static_cast<double>(high[0].visible + high[1].visible + high[2].visible) / 3;
  EXPECT_DOUBLE_EQ(e.mean, mean_low + pair_high - pair_low);
  double sum = 0;
  for (int i = 0; i < 6; ++i) {
    double w = (static_cast<double>(low[i].visible) - mean_low) / 6;
    if (i < 3) {
      w += ((static_cast<double>(high[i].visible) - pair_high) - (static_cast<double>(low[i].visible) - pair_low)) / 3;
    }
    sum += w * w;
  }
  EXPECT_NEAR(e.standard_error, std::sqrt(sum * 6 / 5), 1e-12);
  EXPECT_GT(e.difference_variance, 0);
}

TEST(EstimateMetrics, CarryTheirErrorsAsNinetyFivePercentIntervals) {
  std::vector<ImageTotals> low;
  for (int i = 0; i < 50; ++i) low.push_back(Layout(i, 1 + i % 5, 0.2 * (i % 3), i % 3));
  const ProxyMetrics m = EstimateMetrics(low, {});
  EXPECT_EQ(m.images, 50);
  EXPECT_DOUBLE_EQ(m.objects_per_image.ci95,
                   1.959963984540054 * EstimateMetric(low, {}, Metric::kObjectsPerImage).standard_error);
  EXPECT_NEAR(m.small.mean + m.medium.mean + m.large.mean, 1, 1e-12);
}

// The sizes minimise the cost at the error asked for: the error is reached, and moving layouts
// from one resolution to the other at the same cost misses it.
TEST(SizeConfirmation, CheapestSizesThatReachTheError) {
  TwoPhaseEstimate noise;
  noise.low_variance = 16 * 0.25 * 0.25;       // 16 tolerances^2 of a count with tolerance 0.25
  noise.difference_variance = 1 * 0.25 * 0.25;  // 1 tolerance^2
  const std::vector<Target> targets = {{Metric::kObjectsPerImage, 8, 0.25}};
  const double low_cost = 1, high_cost = 9, error = 0.2;
  const ConfirmationSize size = SizeConfirmation({noise}, targets, low_cost, high_cost, error);
  auto variance = [](double n, double k) { return 16 / n + 1 / k; };
  EXPECT_LE(variance(static_cast<double>(size.low), static_cast<double>(size.high)), error * error * 1.0001);
  // Lagrange: N = (4 + 3) / 0.04 * 4 = 700, K = (4 + 3) / 0.04 / 3 = 58.3.
  EXPECT_EQ(size.low, 700);
  EXPECT_EQ(size.high, 59);
  const double cost = low_cost * 700 + high_cost * 58.33;
  for (double k : {45.0, 75.0}) {
    const double n = (cost - high_cost * k) / low_cost;
    EXPECT_GT(variance(n, k), error * error) << k;
  }
  // One resolution only: N = 16 / 0.04.
  EXPECT_EQ(SizeConfirmation({noise}, targets, 1, 0, error).low, 400);
  EXPECT_EQ(SizeConfirmation({noise}, targets, 1, 0, error).high, 0);
}

// A confirmation row at unit point `x` with a count of `mean` +- `se` (one standard error).
ConfirmationRow Confirmed(std::vector<double> x, double mean, double se) {
  ConfirmationRow c;
  c.x = std::move(x);
  c.metrics.objects_per_image = {mean, 1.959963984540054 * se};
  return c;
}

TEST(PoolConfirmations, PoolsEveryConfirmationOfTheLatestPointByInverseVariance) {
  // Count 14 with tolerance 0.25: the point at x = 0.5 confirmed twice, once at 14.20 +- 0.10
  // (0.8 +- 0.4 tolerances) and once at 13.95 +- 0.05 (-0.2 +- 0.2); another point between.
  const std::vector<ConfirmationRow> rows = {Confirmed({0.5}, 14.20, 0.10), Confirmed({0.7}, 15.0, 0.01),
                                             Confirmed({0.5}, 13.95, 0.05)};
  const std::vector<PooledResidual> pooled = PoolConfirmations(rows, {{Metric::kObjectsPerImage, 14, 0.25}});
  ASSERT_EQ(pooled.size(), 1u);
  // Weights 1 / 0.16 and 1 / 0.04: residual (0.8 / 0.16 - 0.2 / 0.04) / 31.25 = 0, standard
  // error 1 / sqrt(31.25).
  EXPECT_NEAR(pooled[0].residual, 0, 1e-12);
  EXPECT_NEAR(pooled[0].standard_error, 1 / std::sqrt(31.25), 1e-12);
  // Of one confirmation, its own residual and error.
  const std::vector<PooledResidual> alone =
      PoolConfirmations({rows[1]}, {{Metric::kObjectsPerImage, 14, 0.25}});
  EXPECT_NEAR(alone[0].residual, 4, 1e-12);
  EXPECT_NEAR(alone[0].standard_error, 0.04, 1e-12);
}

}  // namespace
}  // namespace solid::optimizer
