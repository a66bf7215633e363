// The paper's proxy metrics over stored instances (solid-method.md 1.2):
// visible objects per image, mean occlusion pooled over visible instances, and
// the COCO small/medium/large shares of visible objects by visible-mask area.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

#include <nlohmann/json.hpp>

#include "solid/formats/records.h"
#include "solid/formats/status.h"

namespace solid {

// A mean with its 95% confidence half-width (normal approximation; for shares,
// the binomial standard error).
struct Estimate {
  double mean = 0;
  double ci95 = 0;
};

struct ProxyMetrics {
  int64_t images = 0;
  int64_t instances = 0;          // stored, visible or not
  int64_t visible_instances = 0;  // visible_area >= 1
  Estimate objects_per_image;     // visible objects per image
  Estimate occlusion;             // over visible instances
  Estimate small, medium, large;  // shares of visible instances
  nlohmann::json ToJson() const;
};

// What one image adds to the proxy metrics, as sums over its visible instances: each metric
// is a ratio of such sums over images (objects per image: visible / images; occlusion:
// occlusion / visible; a share: its count / visible). Kept per image they give standard
// errors over images, the unit that is drawn (the instances of one image are not independent
// draws), and they pair two measurements of the same image, at two resolutions say.
struct ImageTotals {
  int64_t index = 0;  // the image's (or layout's) index, for pairing
  int64_t visible = 0;
  double occlusion = 0;  // summed over the visible instances
  int64_t small = 0, medium = 0, large = 0;
};
// Instances with visible_area 0 are not counted; scale classes as MetricsAccumulator's.
ImageTotals TotalsOfImage(int64_t index, std::span<const InstanceRecord> instances, double area_scale = 1);

class MetricsAccumulator {
 public:
  MetricsAccumulator() = default;
  // COCO scale classes are defined at the output resolution. Areas measured at a
  // resolution with `area_scale` times fewer pixels (a mask pass at 160x120 for a
  // 320x240 dataset: 4) are classed as visible_area * area_scale. Occlusion, a ratio
  // of areas, is unaffected.
  explicit MetricsAccumulator(double area_scale) : area_scale_(area_scale) {}
  // One image with all of its instances.
  void AddImage(std::span<const InstanceRecord> instances);
  // The same from counts alone, for callers that stream instances.
  void AddImageCounts(int64_t instances, int64_t visible_instances);
  void AddVisibleInstance(uint64_t visible_area, uint64_t full_area);
  // Adds everything `other` has seen, as if it had been added here. Both must have
  // the same area_scale.
  void Merge(const MetricsAccumulator& other);
  ProxyMetrics Finish() const;

 private:
  struct Moments {
    int64_t n = 0;
    double mean = 0, m2 = 0;  // Welford
    void Add(double x);
    void Merge(const Moments& o);
    Estimate Get() const;
  };
  double area_scale_ = 1;
  int64_t images_ = 0, instances_ = 0;
  Moments objects_, occlusion_;
  int64_t visible_ = 0, small_ = 0, medium_ = 0, large_ = 0;
};

// The proxy metrics of a rendered dataset: every target shard present, in shard order
// (ShardReader::AddToMetrics), classed at the manifest's scale-class resolution
// (Manifest::ScaleClassAreaScale), from the stored areas (validate checks them against the
// masks). No image is read. The one computation behind inspect, index, report and
// `solid metrics`. Errors name the shard.
Result<ProxyMetrics> DatasetMetrics(const std::filesystem::path& dataset_root);

}  // namespace solid
