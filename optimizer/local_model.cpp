#include "local_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace solid::optimizer {
namespace {

// x with a x = b, a row-major p x p and symmetric positive definite in use (normal
// equations plus a ridge), by Gaussian elimination with partial pivoting.
std::vector<double> Solve(std::vector<double> a, std::vector<double> b, size_t p) {
  for (size_t col = 0; col < p; ++col) {
    size_t pivot = col;
    for (size_t row = col + 1; row < p; ++row) {
      if (std::abs(a[row * p + col]) > std::abs(a[pivot * p + col])) pivot = row;
    }
    if (pivot != col) {
      for (size_t k = 0; k < p; ++k) std::swap(a[col * p + k], a[pivot * p + k]);
      std::swap(b[col], b[pivot]);
    }
    const double diagonal = a[col * p + col];
    if (diagonal == 0) continue;
    for (size_t row = col + 1; row < p; ++row) {
      const double factor = a[row * p + col] / diagonal;
      if (factor == 0) continue;
      for (size_t k = col; k < p; ++k) a[row * p + k] -= factor * a[col * p + k];
      b[row] -= factor * b[col];
    }
  }
  std::vector<double> x(p);
  for (size_t col = p; col-- > 0;) {
    double sum = b[col];
    for (size_t k = col + 1; k < p; ++k) sum -= a[col * p + k] * x[k];
    x[col] = a[col * p + col] != 0 ? sum / a[col * p + col] : 0;
  }
  return x;
}

}  // namespace

LocalModel FitLocalModel(const std::vector<Observation>& observations, const std::vector<double>& centre,
                         double radius, const std::vector<double>& prior_jacobian, double prior_sd,
                         const std::vector<InterceptPrior>& intercept_priors) {
  const size_t n = centre.size(), m = prior_jacobian.size() / std::max<size_t>(1, n);
  // The groups present, group 0 first: each has an intercept.
  std::vector<int> groups = {0};
  for (const Observation& o : observations) {
    if (std::find(groups.begin(), groups.end(), o.group) == groups.end()) groups.push_back(o.group);
  }
  const size_t g = groups.size(), p = g + n;
  // A group whose observations all lie far from the centre has an intercept that the data
  // hardly fix; this keeps its equation defined without moving the others.
  constexpr double kInterceptRidge = 1e-9;
  LocalModel model{std::vector<double>(m), std::vector<double>(m), std::vector<double>(m * n)};
  for (size_t i = 0; i < m; ++i) {
    std::vector<double> a(p * p, 0.0), b(p, 0.0);
    for (size_t k = 0; k < g; ++k) a[k * p + k] = kInterceptRidge;
    for (size_t j = 0; j < n; ++j) {
      a[(g + j) * p + g + j] += 1 / (prior_sd * prior_sd);
      b[g + j] += prior_jacobian[i * n + j] / (prior_sd * prior_sd);
    }
    for (const InterceptPrior& prior : intercept_priors) {
      const auto k = static_cast<size_t>(std::find(groups.begin(), groups.end(), prior.group) - groups.begin());
      if (k == g || k == 0 || prior.mean.size() != m || prior.variance.size() != m) continue;
      // A pseudo-observation of a_k - a_0.
      const double weight = 1 / std::max(prior.variance[i], 1e-12);
      a[k * p + k] += weight;
      a[0] += weight;
      a[k * p] -= weight;
      a[k] -= weight;
      b[k] += weight * prior.mean[i];
      b[0] -= weight * prior.mean[i];
    }
    for (const Observation& o : observations) {
      if (o.x.size() != n || o.residuals.size() != m || o.variances.size() != m) continue;
      double distance_sq = 0;
      for (size_t j = 0; j < n; ++j) distance_sq += (o.x[j] - centre[j]) * (o.x[j] - centre[j]);
      const double weight = std::exp(-distance_sq / (2 * radius * radius)) / std::max(o.variances[i], 1e-9);
      std::vector<double> phi(p, 0.0);
      phi[static_cast<size_t>(std::find(groups.begin(), groups.end(), o.group) - groups.begin())] = 1;
      for (size_t j = 0; j < n; ++j) phi[g + j] = o.x[j] - centre[j];
      for (size_t r = 0; r < p; ++r) {
        if (phi[r] == 0) continue;
        b[r] += weight * phi[r] * o.residuals[i];
        for (size_t c = 0; c < p; ++c) a[r * p + c] += weight * phi[r] * phi[c];
      }
    }
    const std::vector<double> theta = Solve(a, b, p);
    std::vector<double> unit(p, 0.0);
    unit[0] = 1;
    model.residuals[i] = theta[0];
    model.variances[i] = Solve(a, unit, p)[0];  // (A^-1)_00: the intercept's variance
    for (size_t j = 0; j < n; ++j) model.jacobian[i * n + j] = theta[g + j];
  }
  return model;
}

}  // namespace solid::optimizer
