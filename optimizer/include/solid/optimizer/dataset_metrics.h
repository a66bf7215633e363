// `solid metrics` as one call: a rendered dataset's proxy metrics from its stored masks, with
// 95% CIs, optionally compared with a Table-1 row's targets or with the metrics that a
// params file's layouts are predicted to have (sampled, mask pass only).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/metrics.h"
#include "solid/formats/status.h"
#include "solid/optimizer/optimize.h"

namespace solid::optimizer {

struct MetricsOptions {
  std::filesystem::path dataset;
  // At most one of these two: the comparison.
  std::string target_row;
  std::filesystem::path compare;  // a params file, sampled with the fields below
  std::filesystem::path assets, rooms;  // models (required with compare) and rooms (default: assets)
  int64_t layouts = 2000;
  uint64_t seed = 1;
  int jobs = 0;  // 0: all cores
};

struct MetricsReport {
  std::filesystem::path dataset;
  ProxyMetrics measured;
  std::pair<int, int> scale_classes_at;  // the manifest's scale-class resolution
  std::string compared_with;             // "Table-1 row more-objects", "<params> sampled (...)"; empty: none
  std::vector<Comparison> comparisons;
  bool all_agree = true;  // every comparison agrees (vacuously without one)
  // {"dataset", "metrics", "scale_classes_at", and with a comparison "compared_with",
  //  "comparison": [{"metric", "measured", "reference", "tolerance", "agrees"}], "all_agree"}
  nlohmann::json ToJson() const;
};

// Option errors name the field (OptionError: "target_row", "compare", "assets", "layouts");
// dataset errors name the shard and image.
Result<MetricsReport> MeasureDataset(const MetricsOptions& options);

}  // namespace solid::optimizer
