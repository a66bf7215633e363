// `solid report`: one self-contained HTML page about a dataset, to look at before
// training on it: the manifest and params, the proxy metrics against a Table-1 row's
// targets, histograms of occlusion, scale classes and objects per image, the viewpoint
// distribution (azimuth x elevation, the paper's Fig. 3), and sample images with their
// visible masks, full masks and boxes drawn in, next to the query views of their objects.
//
// Plots are inline SVG and images base64 data URIs: the page needs no network and no
// other file. The statistics stream over the instances (no image is read for them);
// only the sample images and their query views are decoded.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "solid/formats/metrics.h"
#include "solid/formats/status.h"

namespace solid::exporters {

inline constexpr int kMaxReportSamples = 1000, kMaxReportQueryModels = 64;

struct ReportOptions {
  std::filesystem::path dataset;
  std::filesystem::path out;  // the .html file, written atomically
  // A Table-1 row (preset name) whose targets the metrics are compared with; empty: the
  // preset whose layout params equal the manifest's (resolution aside), if any; "none": no targets.
  std::string target_row;
  int samples = 12;        // sample images, evenly spaced over the image ids; 0 to kMaxReportSamples
  int query_models = 4;    // query views shown per sample (the largest visible objects'); 0 to kMaxReportQueryModels
};

struct ReportSummary {
  std::filesystem::path out;  // the page written
  int64_t images = 0, instances = 0, samples = 0;
  std::string target_row;  // the row compared with, empty when none
  int64_t bytes = 0;       // size of the page
  ProxyMetrics metrics;    // the dataset's (DatasetMetrics), as the page shows them
  nlohmann::json ToJson() const;
  // "<out>: N images, M instances, K samples, targets of ROW, X MB"
  std::string ToText() const;
};

// kInvalidArgument for an empty `dataset` or `out`, for `samples` or `query_models` out of
// range; kNotFound for a `target_row` that is no Table-1 row; the dataset's errors. On
// error, no page is written.
Result<ReportSummary> WriteReport(const ReportOptions& options);

}  // namespace solid::exporters
