// A linear model of the residuals near a point, fitted by weighted least squares to every
// measurement of the fit near it.
//
// Common random numbers pair the layouts of nearby points poorly here: a camera ring moved
// by 0.2 m leaves 7 of 400 layouts as they were, and the difference of the count between the
// two points varies by 5.9 objects per layout against 6.4 for independent layouts (the
// fitted more-objects point, procedural default). So a difference of two evaluations of 100
// layouts is nearly as noisy as two independent ones, and a Jacobian of central differences
// is mostly noise where the targets are near. Pooled over every measurement near the point,
// the slopes and the level average that noise away instead of discarding all but the last.
//
// Measurements that share a bias (one set of layouts' sampling error, or a resolution's
// offset from the output's) form a group with an intercept of its own, and only the slopes are
// shared: evaluations at the evaluation resolution teach the slopes, and the level as far as
// the offset between the resolutions is known; measurements at the output resolution
// (confirmations) teach the level.
#pragma once

#include <vector>

namespace solid::optimizer {

struct Observation {
  std::vector<double> x;          // in the unit cube
  std::vector<double> residuals;  // (metric - target) / tolerance, per target
  std::vector<double> variances;  // of each residual, in tolerances squared
  int group = 0;  // 0: fresh layouts at the output resolution; k > 0: one set of common layouts
};

struct LocalModel {
  std::vector<double> residuals;  // at the centre, as fresh layouts at the output resolution measure
  std::vector<double> variances;  // of those
  std::vector<double> jacobian;   // targets x dimensions, row-major, per unit of the cube
};

// What is known of one group's intercept against group 0's before the fit: a_group - a_0 is
// about `mean`, with `variance` (per target), as paired layouts measure the offset of one
// resolution from another.
struct InterceptPrior {
  int group = 1;
  std::vector<double> mean, variance;
};

// |a - b|^2 over the dimensions of the unit cube.
double SquaredDistance(const std::vector<double>& a, const std::vector<double>& b);

// Per target, r = a_group + J (x - centre) by least squares, each observation weighted by the
// inverse of its variance times exp(-|x - centre|^2 / (2 radius^2)) (the model is local), the
// slopes drawn toward `prior_jacobian` with a standard deviation of `prior_sd` (so that the
// fit stays defined where the observations do not span every dimension), and intercepts
// toward their priors. Observations with another number of targets are ignored.
LocalModel FitLocalModel(const std::vector<Observation>& observations, const std::vector<double>& centre,
                         double radius, const std::vector<double>& prior_jacobian, double prior_sd,
                         const std::vector<InterceptPrior>& intercept_priors = {});

}  // namespace solid::optimizer
