#include "solid/formats/metrics.h"

#include <algorithm>
#include <cmath>

#include "solid/formats/dataset.h"
#include "solid/formats/shard.h"
#include "solid/formats/status.h"

namespace solid {

void MetricsAccumulator::Moments::Add(double x) {
  ++n;
  double delta = x - mean;
  mean += delta / static_cast<double>(n);
  m2 += delta * (x - mean);
}

void MetricsAccumulator::Moments::Merge(const Moments& o) {
  if (o.n == 0) return;
  int64_t total = n + o.n;
  double delta = o.mean - mean;
  mean += delta * static_cast<double>(o.n) / static_cast<double>(total);
  m2 += o.m2 + delta * delta * static_cast<double>(n) * static_cast<double>(o.n) / static_cast<double>(total);
  n = total;
}

void MetricsAccumulator::Merge(const MetricsAccumulator& o) {
  SOLID_CHECK(area_scale_ == o.area_scale_);
  images_ += o.images_;
  instances_ += o.instances_;
  objects_.Merge(o.objects_);
  occlusion_.Merge(o.occlusion_);
  visible_ += o.visible_;
  small_ += o.small_;
  medium_ += o.medium_;
  large_ += o.large_;
}

Estimate MetricsAccumulator::Moments::Get() const {
  if (n == 0) return {};
  double variance = n > 1 ? m2 / static_cast<double>(n - 1) : 0.0;
  return {mean, 1.959963984540054 * std::sqrt(variance / static_cast<double>(n))};
}

namespace {

double OcclusionOf(uint64_t visible_area, uint64_t full_area) {
  return static_cast<double>(full_area - std::min(full_area, visible_area)) / static_cast<double>(full_area);
}

}  // namespace

ImageTotals TotalsOfImage(int64_t index, std::span<const InstanceRecord> instances, double area_scale) {
  ImageTotals t;
  t.index = index;
  for (const InstanceRecord& in : instances) {
    if (in.visible_area == 0) continue;
    ++t.visible;
    if (in.full_area > 0) t.occlusion += OcclusionOf(in.visible_area, in.full_area);
    switch (ScaleClassOfArea(in.visible_area, area_scale)) {
      case ScaleClass::kSmall: ++t.small; break;
      case ScaleClass::kMedium: ++t.medium; break;
      case ScaleClass::kLarge: ++t.large; break;
    }
  }
  return t;
}

void MetricsAccumulator::AddImage(std::span<const InstanceRecord> instances) {
  int64_t visible = 0;
  for (const InstanceRecord& in : instances) {
    if (in.visible_area == 0) continue;
    ++visible;
    AddVisibleInstance(in.visible_area, in.full_area);
  }
  AddImageCounts(static_cast<int64_t>(instances.size()), visible);
}

void MetricsAccumulator::AddImageCounts(int64_t instances, int64_t visible_instances) {
  ++images_;
  instances_ += instances;
  objects_.Add(static_cast<double>(visible_instances));
}

void MetricsAccumulator::AddVisibleInstance(uint64_t visible_area, uint64_t full_area) {
  ++visible_;
  if (full_area > 0) {
    occlusion_.Add(OcclusionOf(visible_area, full_area));
  }
  switch (ScaleClassOfArea(visible_area, area_scale_)) {
    case ScaleClass::kSmall: ++small_; break;
    case ScaleClass::kMedium: ++medium_; break;
    case ScaleClass::kLarge: ++large_; break;
  }
}

ProxyMetrics MetricsAccumulator::Finish() const {
  ProxyMetrics m;
  m.images = images_;
  m.instances = instances_;
  m.visible_instances = visible_;
  m.objects_per_image = objects_.Get();
  m.occlusion = occlusion_.Get();
  auto share = [&](int64_t k) -> Estimate {
    if (visible_ == 0) return {};
    double p = static_cast<double>(k) / static_cast<double>(visible_);
    return {p, 1.959963984540054 * std::sqrt(p * (1 - p) / static_cast<double>(visible_))};
  };
  m.small = share(small_);
  m.medium = share(medium_);
  m.large = share(large_);
  return m;
}

nlohmann::json ProxyMetrics::ToJson() const {
  auto est = [](const Estimate& e) { return nlohmann::json{{"mean", e.mean}, {"ci95", e.ci95}}; };
  return {{"images", images},
          {"instances", instances},
          {"visible_instances", visible_instances},
          {"objects_per_image", est(objects_per_image)},
          {"occlusion", est(occlusion)},
          {"scale", {{"small", est(small)}, {"medium", est(medium)}, {"large", est(large)}}}};
}

Result<ProxyMetrics> DatasetMetrics(const std::filesystem::path& dataset_root) {
  SOLID_ASSIGN_OR_RETURN(Manifest manifest, ReadManifest(dataset_root));
  SOLID_ASSIGN_OR_RETURN(ShardListing listing, ListShards(dataset_root));
  MetricsAccumulator metrics(manifest.ScaleClassAreaScale());
  for (const ShardFile& file : listing.targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader shard, ShardReader::Open(file.path));
    SOLID_RETURN_IF_ERROR(shard.AddToMetrics(metrics));
  }
  return metrics.Finish();
}

}  // namespace solid
