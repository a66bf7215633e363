#include "estimator.h"

#include <algorithm>
#include <cmath>

namespace solid::optimizer {
namespace {

constexpr double kZ95 = 1.959963984540054;

// The numerator of `metric`'s ratio in one layout (the count's is its visible objects, over 1).
double Numerator(const ImageTotals& t, Metric metric) {
  switch (metric) {
    case Metric::kObjectsPerImage: return static_cast<double>(t.visible);
    case Metric::kOcclusion: return t.occlusion;
    case Metric::kSmall: return static_cast<double>(t.small);
    case Metric::kMedium: return static_cast<double>(t.medium);
    case Metric::kLarge: return static_cast<double>(t.large);
  }
  return 0;
}

struct Influence {
  double value = 0;
  std::vector<double> of_layout;  // centred: they sum to 0
};

// The metric over `totals`, and each layout's influence on it: for the count, the layout's
// count less the mean; for a ratio sum(a) / sum(v), (a_i - ratio * v_i) / mean(v).
Influence InfluenceOf(const std::vector<ImageTotals>& totals, Metric metric) {
  Influence out;
  const size_t n = totals.size();
  if (n == 0) return out;
  double sum_a = 0, sum_v = 0;
  for (const ImageTotals& t : totals) {
    sum_a += Numerator(t, metric);
    sum_v += static_cast<double>(t.visible);
  }
  out.of_layout.resize(n);
  if (metric == Metric::kObjectsPerImage) {
    out.value = sum_v / static_cast<double>(n);
    for (size_t i = 0; i < n; ++i) out.of_layout[i] = static_cast<double>(totals[i].visible) - out.value;
    return out;
  }
  if (sum_v <= 0) return out;
  out.value = sum_a / sum_v;
  const double mean_v = sum_v / static_cast<double>(n);
  for (size_t i = 0; i < n; ++i) {
    out.of_layout[i] = (Numerator(totals[i], metric) - out.value * static_cast<double>(totals[i].visible)) / mean_v;
  }
  return out;
}

double SumOfSquares(const std::vector<double>& v) {
  double sum = 0;
  for (double e : v) sum += e * e;
  return sum;
}

}  // namespace

TwoPhaseEstimate EstimateMetric(const std::vector<ImageTotals>& low, const std::vector<ImageTotals>& high,
                                Metric metric) {
  TwoPhaseEstimate e;
  const Influence all = InfluenceOf(low, metric);
  const double n = static_cast<double>(low.size());
  e.mean = all.value;
  if (n < 2) return e;
  e.low_variance = SumOfSquares(all.of_layout) / (n - 1);
  // The layouts measured at both resolutions, and where each sits in `low`.
  std::vector<ImageTotals> low_paired, high_paired;
  std::vector<size_t> position;
  for (size_t i = 0, j = 0; i < low.size() && j < high.size();) {
    if (low[i].index < high[j].index) {
      ++i;
    } else if (high[j].index < low[i].index) {
      ++j;
    } else {
      low_paired.push_back(low[i]);
      high_paired.push_back(high[j]);
      position.push_back(i);
      ++i, ++j;
    }
  }
  std::vector<double> weight(all.of_layout.size());
  for (size_t i = 0; i < weight.size(); ++i) weight[i] = all.of_layout[i] / n;
  const double k = static_cast<double>(position.size());
  if (k >= 2) {
    const Influence lo = InfluenceOf(low_paired, metric), hi = InfluenceOf(high_paired, metric);
    e.mean += hi.value - lo.value;
    double difference_sq = 0, covariance = 0;
    for (size_t p = 0; p < position.size(); ++p) {
      const double difference = hi.of_layout[p] - lo.of_layout[p];
      weight[position[p]] += difference / k;
      difference_sq += difference * difference;
      covariance += all.of_layout[position[p]] * difference;
    }
    e.difference_variance = difference_sq / (k - 1);
    // A difference that moves against the layout's own metric lowers the variance of their
    // sum, but never below a quarter of the low resolution's (a guard against few pairs).
    e.low_variance = std::max(0.25 * e.low_variance, e.low_variance + 2 * covariance / (k - 1));
  }
  e.standard_error = std::sqrt(SumOfSquares(weight) * n / (n - 1));
  return e;
}

ProxyMetrics EstimateMetrics(const std::vector<ImageTotals>& low, const std::vector<ImageTotals>& high) {
  ProxyMetrics m;
  m.images = static_cast<int64_t>(low.size());
  for (const ImageTotals& t : low) m.visible_instances += t.visible;
  m.instances = m.visible_instances;
  auto set = [&](Estimate& out, Metric metric) {
    const TwoPhaseEstimate e = EstimateMetric(low, high, metric);
    out = {e.mean, kZ95 * e.standard_error};
  };
  set(m.objects_per_image, Metric::kObjectsPerImage);
  set(m.occlusion, Metric::kOcclusion);
  set(m.small, Metric::kSmall);
  set(m.medium, Metric::kMedium);
  set(m.large, Metric::kLarge);
  return m;
}

ConfirmationSize SizeConfirmation(const std::vector<TwoPhaseEstimate>& estimates, const std::vector<Target>& targets,
                                  double low_cost, double high_cost, double standard_error) {
  ConfirmationSize size;
  const double budget = standard_error * standard_error;
  for (size_t i = 0; i < estimates.size() && i < targets.size(); ++i) {
    const double tol_sq = targets[i].tolerance * targets[i].tolerance;
    const double a = estimates[i].low_variance / tol_sq;
    const double b = high_cost > 0 ? estimates[i].difference_variance / tol_sq : 0;
    // Minimizes low_cost * N + high_cost * K subject to a / N + b / K = budget (Lagrange):
    // N and K in proportion to sqrt(a / low_cost) and sqrt(b / high_cost).
    const double scale = (std::sqrt(a * low_cost) + std::sqrt(b * high_cost)) / budget;
    const double low = low_cost > 0 ? scale * std::sqrt(a / low_cost) : a / budget;
    const double high = b > 0 ? scale * std::sqrt(b / high_cost) : 0;
    size.low = std::max(size.low, static_cast<int64_t>(std::ceil(low)));
    size.high = std::max(size.high, static_cast<int64_t>(std::ceil(high)));
  }
  size.high = std::min(size.high, size.low);
  return size;
}

std::vector<PooledResidual> PoolConfirmations(const std::vector<ConfirmationRow>& confirmations,
                                              const std::vector<Target>& targets) {
  std::vector<PooledResidual> out;
  if (confirmations.empty()) return out;
  const std::vector<double>& x = confirmations.back().x;
  for (const Target& t : targets) {
    double weights = 0, weighted = 0;
    for (const ConfirmationRow& c : confirmations) {
      if (c.x != x) continue;
      const Estimate& e = MetricOf(c.metrics, t.metric);
      const double se = e.ci95 / kZ95 / t.tolerance;
      const double w = 1 / std::max(se * se, 1e-24);
      weights += w;
      weighted += w * (e.mean - t.value) / t.tolerance;
    }
    out.push_back({weighted / weights, 1 / std::sqrt(weights)});
  }
  return out;
}

}  // namespace solid::optimizer
