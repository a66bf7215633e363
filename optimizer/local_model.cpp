#include "local_model.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace solid::optimizer {

double SquaredDistance(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0;
  for (size_t j = 0; j < a.size(); ++j) sum += (a[j] - b[j]) * (a[j] - b[j]);
  return sum;
}

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
    // The normal equations a theta = b of the weighted least squares with its priors.
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(p);
    for (size_t k = 0; k < g; ++k) a(k, k) = kInterceptRidge;
    for (size_t j = 0; j < n; ++j) {
      a(g + j, g + j) += 1 / (prior_sd * prior_sd);
      b(g + j) += prior_jacobian[i * n + j] / (prior_sd * prior_sd);
    }
    for (const InterceptPrior& prior : intercept_priors) {
      const auto k = static_cast<size_t>(std::find(groups.begin(), groups.end(), prior.group) - groups.begin());
      if (k == g || k == 0 || prior.mean.size() != m || prior.variance.size() != m) continue;
      // A pseudo-observation of a_k - a_0.
      const double weight = 1 / std::max(prior.variance[i], 1e-12);
      a(k, k) += weight;
      a(0, 0) += weight;
      a(k, 0) -= weight;
      a(0, k) -= weight;
      b(k) += weight * prior.mean[i];
      b(0) -= weight * prior.mean[i];
    }
    Eigen::VectorXd phi(p);
    for (const Observation& o : observations) {
      if (o.x.size() != n || o.residuals.size() != m || o.variances.size() != m) continue;
      const double weight = std::exp(-SquaredDistance(o.x, centre) / (2 * radius * radius)) / std::max(o.variances[i], 1e-9);
      phi.setZero();
      phi(std::find(groups.begin(), groups.end(), o.group) - groups.begin()) = 1;
      for (size_t j = 0; j < n; ++j) phi(g + j) = o.x[j] - centre[j];
      a.noalias() += weight * phi * phi.transpose();
      b += weight * o.residuals[i] * phi;
    }
    const Eigen::LDLT<Eigen::MatrixXd> normal(a);
    const Eigen::VectorXd theta = normal.solve(b);
    model.residuals[i] = theta(0);
    model.variances[i] = normal.solve(Eigen::VectorXd::Unit(p, 0))(0);  // (A^-1)_00: the intercept's variance
    for (size_t j = 0; j < n; ++j) model.jacobian[i * n + j] = theta(g + j);
  }
  return model;
}

}  // namespace solid::optimizer
