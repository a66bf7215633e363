#include "solid/optimizer/dataset_metrics.h"

#include <fmt/format.h>

#include <memory>

#include "solid/formats/dataset.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

namespace solid::optimizer {

nlohmann::json MetricsReport::ToJson() const {
  nlohmann::json j = {{"dataset", dataset.string()},
                      {"metrics", measured.ToJson()},
                      {"scale_classes_at", {scale_classes_at.first, scale_classes_at.second}}};
  if (compared_with.empty()) return j;
  nlohmann::json rows = nlohmann::json::array();
  for (const Comparison& c : comparisons) {
    rows.push_back({{"metric", MetricName(c.metric)},
                    {"measured", {{"mean", c.measured.mean}, {"ci95", c.measured.ci95}}},
                    {"reference", {{"mean", c.reference.mean}, {"ci95", c.reference.ci95}}},
                    {"tolerance", c.tolerance},
                    {"agrees", c.agrees}});
  }
  j["compared_with"] = compared_with;
  j["comparison"] = rows;
  j["all_agree"] = all_agree;
  return j;
}

Result<MetricsReport> MeasureDataset(const MetricsOptions& options) {
  if (!options.target_row.empty() && !options.compare.empty()) {
    return OptionError("target_row", "compare with a Table-1 row or with a params file, not both");
  }
  if (!options.compare.empty() && options.assets.empty()) {
    return OptionError("assets", "comparing with a params file samples its layouts: the assets are required");
  }
  if (options.layouts < 1) return OptionError("layouts", fmt::format("must be >= 1, got {}", options.layouts));
  MetricsReport report;
  report.dataset = options.dataset;
  SOLID_ASSIGN_OR_RETURN(report.measured, DatasetMetrics(options.dataset));
  SOLID_ASSIGN_OR_RETURN(const Manifest manifest, ReadManifest(options.dataset));
  report.scale_classes_at = manifest.ScaleClassResolution();
  if (!options.target_row.empty()) {
    Result<std::vector<Target>> targets = TableRowTargets(options.target_row);
    if (!targets.ok()) return OptionError("target_row", targets.status().message(), targets.status().code());
    report.comparisons = CompareWithTargets(report.measured, *targets);
    report.compared_with = "Table-1 row " + options.target_row;
  } else if (!options.compare.empty()) {
    SOLID_ASSIGN_OR_RETURN(render::LayoutParams params, render::LoadParamsFile(options.compare));
    SOLID_ASSIGN_OR_RETURN(
        std::shared_ptr<render::AssetLibrary> library,
        render::AssetLibrary::Open(options.assets, options.rooms.empty() ? options.assets : options.rooms));
    SOLID_ASSIGN_OR_RETURN(std::unique_ptr<render::LayoutSampler> sampler,
                           render::LayoutSampler::Create(params, library));
    render::SampleOptions sample;
    sample.seed = options.seed;
    sample.first = kPilotFirst;
    sample.layouts = options.layouts;
    sample.jobs = options.jobs;
    SOLID_ASSIGN_OR_RETURN(render::SampleReport predicted, render::RunSample(*sampler, sample));
    report.comparisons = CompareWithPrediction(report.measured, predicted.metrics);
    report.compared_with = fmt::format("{} sampled ({} layouts at {}x{})", options.compare.string(), options.layouts,
                                       params.width, params.height);
  }
  for (const Comparison& c : report.comparisons) report.all_agree = report.all_agree && c.agrees;
  return report;
}

}  // namespace solid::optimizer
