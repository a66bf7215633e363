// The proxy metrics of a point and their standard errors from per-layout totals
// (ImageTotals), and the sizes of a confirmation that reaches a standard error.
//
// Every metric is a function of the layouts' mean totals (objects per image, or a ratio of
// two means), so its sampling error is taken over layouts, by linearization: each layout's
// influence is what it moves the metric by, times the number of layouts. Instances of one
// layout are not independent draws, so an error over instances (a binomial share) would
// understate it: the camera that sees few objects sees them all small.
//
// A confirmation measures many fresh layouts at the evaluation resolution and the first of
// them again at the output resolution; the output's metric is estimated as the low
// resolution's over all of them plus the difference the pairs measure (a two-phase, or
// difference, estimator). The difference varies far less from layout to layout than the
// metric does, so a few pairs at the costly resolution correct many cheap layouts.
#pragma once

#include <cstdint>
#include <vector>

#include "solid/formats/metrics.h"
#include "solid/optimizer/optimize.h"

namespace solid::optimizer {

struct TwoPhaseEstimate {
  double mean = 0;
  double standard_error = 0;
  // Per-layout variances for sizing: the standard error of N low and K paired layouts is
  // about sqrt(low_variance / N + difference_variance / K) (low_variance includes twice
  // the covariance of the low influence and the paired difference).
  double low_variance = 0, difference_variance = 0;
};

// `low`: layouts at the evaluation resolution; `high`: some of them (matched by index) at the
// output resolution, or none, for the low resolution's own estimate. Both sorted by index.
TwoPhaseEstimate EstimateMetric(const std::vector<ImageTotals>& low, const std::vector<ImageTotals>& high,
                                Metric metric);

// The five metrics as ProxyMetrics (ci95 = 1.96 standard errors; images, instances and
// visible_instances of `low`).
ProxyMetrics EstimateMetrics(const std::vector<ImageTotals>& low, const std::vector<ImageTotals>& high);

struct ConfirmationSize {
  int64_t low = 0, high = 0;  // layouts at the evaluation resolution; of them, also at the output's
};

// The cheapest sizes (by the seconds a layout costs at each resolution) at which every
// target's standard error, in tolerances, is at most `standard_error`, from the per-layout
// variances of `estimates` (one per target, same order). With high_cost 0 (the evaluation
// resolution is the output's), high is 0.
ConfirmationSize SizeConfirmation(const std::vector<TwoPhaseEstimate>& estimates, const std::vector<Target>& targets,
                                  double low_cost, double high_cost, double standard_error);

// Each target's residual, (metric - target) / tolerance, at the point of the latest of
// `confirmations`, over every confirmation of that point pooled with inverse-variance
// weights, and its standard error in tolerances: a point confirmed in several rounds is
// judged on all its layouts, not on whichever confirmation happened to pass.
struct PooledResidual {
  double residual = 0;
  double standard_error = 0;
};
std::vector<PooledResidual> PoolConfirmations(const std::vector<ConfirmationRow>& confirmations,
                                              const std::vector<Target>& targets);

}  // namespace solid::optimizer
