#include "solid/render/sample.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>
#include <thread>
#include <tuple>

#include <fmt/format.h>

#include "solid/formats/files.h"
#include "solid/formats/workers.h"
#include "room.h"
#include "scene_export.h"

namespace solid::render {
namespace {

// What one layout contributes to the report; merged in index order so that the
// report is the same for any number of jobs.
struct LayoutSummary {
  bool ok = false;
  std::string failure;
  int restarts = 0, attempts = 0, placed = 0;
  int64_t proposals = 0;
  double sample_ms = 0, mask_ms = 0;
  std::vector<InstanceRecord> annotated;  // mask strings dropped
};

}  // namespace

Result<GeneratedLayout> GenerateLayout(const LayoutSampler& sampler, uint64_t dataset_seed, int64_t index,
                                       MaskPassOptions options) {
  const LayoutParams& p = sampler.params();
  options.area_scale = ScaleClassAreaScale(p, p.width, p.height);
  GeneratedLayout g;
  std::vector<std::string> reasons;
  for (int restart = 0; restart <= p.max_scene_restarts; ++restart) {
    auto start = std::chrono::steady_clock::now();
    SOLID_ASSIGN_OR_RETURN(g.layout, sampler.Sample(dataset_seed, index, restart));
    g.sample_ms += MillisecondsSince(start);
    if (!g.layout.rejection.empty()) {
      reasons.push_back(g.layout.rejection);
      continue;
    }
    start = std::chrono::steady_clock::now();
    Result<LightRig> lights = SampleLights(g.layout);
    g.sample_ms += MillisecondsSince(start);
    if (!lights.ok()) {
      if (lights.status().code() != StatusCode::kLimitExceeded) return lights.status();
      reasons.push_back(lights.status().message());
      continue;
    }
    g.lights = *lights;
    start = std::chrono::steady_clock::now();
    SOLID_ASSIGN_OR_RETURN(g.masks, RunMaskPass(g.layout, p.min_visible_pixels, options));
    g.mask_ms += MillisecondsSince(start);
    if (g.masks.visible_objects > 0) return g;
    reasons.push_back(fmt::format("no object with {} visible pixel(s) among {}", p.min_visible_pixels,
                                  g.layout.objects.size()));
  }
  std::string why;
  for (size_t i = 0; i < reasons.size() && i < 3; ++i) why += (i > 0 ? "; " : "") + reasons[i];
  return LimitExceededError(fmt::format("layout {}: no usable draw in {} restarts ({}{})", index,
                                        p.max_scene_restarts + 1, why, reasons.size() > 3 ? "; ..." : ""));
}

void ViewpointHistogram::Add(double azimuth, double elevation) {
  constexpr double kPi = std::numbers::pi;
  const int a = std::clamp(static_cast<int>(std::floor((azimuth + kPi) / (2 * kPi) * azimuth_bins)), 0,
                           azimuth_bins - 1);
  const int e = std::clamp(static_cast<int>(std::floor((elevation + kPi / 2) / kPi * elevation_bins)), 0,
                           elevation_bins - 1);
  ++counts[static_cast<size_t>(e) * azimuth_bins + a];
}

Result<SampleReport> RunSample(const LayoutSampler& sampler, const SampleOptions& options) {
  if (options.layouts < 0) return OptionError("layouts", "must be >= 0");
  if (options.first < 0) return OptionError("first", "must be >= 0");
  const auto start = std::chrono::steady_clock::now();
  const int64_t n = options.layouts;
  std::vector<LayoutSummary> summaries(static_cast<size_t>(n));
  std::atomic<int64_t> next{0}, done{0};
  std::mutex error_mutex;
  Status error;
  const int min_visible = std::max(1, sampler.params().min_visible_pixels);
  auto worker = [&] {
    for (int64_t i = next++; i < n; i = next++) {
      {
        std::lock_guard lock(error_mutex);
        if (!error.ok()) return;
      }
      if (CancelRequested(options.cancel)) return;
      LayoutSummary& s = summaries[static_cast<size_t>(i)];
      MaskPassOptions mask_options;
      mask_options.metrics_only = options.metrics_only;
      Result<GeneratedLayout> g = GenerateLayout(sampler, options.seed, options.first + i, mask_options);
      if (!g.ok()) {
        if (g.status().code() != StatusCode::kLimitExceeded) {
          std::lock_guard lock(error_mutex);
          if (error.ok()) error = g.status();
          return;
        }
        s.failure = g.status().message();
      } else {
        s.ok = true;
        s.restarts = g->layout.restart;
        s.attempts = g->layout.stats.attempts;
        s.placed = g->layout.stats.placed;
        s.proposals = g->layout.stats.proposals;
        s.sample_ms = g->sample_ms;
        s.mask_ms = g->mask_ms;
        for (InstanceRecord& r : g->masks.instances) {
          if (r.visible_area < static_cast<uint64_t>(min_visible)) continue;
          r.visible_rle.clear();
          r.full_rle.clear();
          s.annotated.push_back(std::move(r));
        }
      }
      ++done;
    }
  };
  const int jobs = WorkerCount(options.jobs);
  if (options.progress) {
    // The calling thread reports progress while `jobs` threads work.
    BackgroundWorkers pool(jobs, worker);
    while (done.load() < n && !CancelRequested(options.cancel)) {
      {
        std::lock_guard lock(error_mutex);
        if (!error.ok()) break;
      }
      options.progress(done.load(), n);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    pool.Join();
    options.progress(done.load(), n);
  } else {
    RunOnThreads(jobs, worker);
  }
  SOLID_RETURN_IF_ERROR(error);
  if (done.load() < n) {
    return CancelledError(fmt::format("sample: stopped after {} of {} layouts", done.load(), n));
  }

  SampleReport report;
  const LayoutParams& params = sampler.params();
  MetricsAccumulator metrics(ScaleClassAreaScale(params, params.width, params.height));
  std::tie(report.scale_width, report.scale_height) = ScaleClassResolution(params);
  double truncation_sum = 0, truncation_sq = 0;
  int64_t truncation_n = 0;
  double sample_ms = 0, mask_ms = 0, attempts = 0, placed = 0, proposals = 0;
  for (const LayoutSummary& s : summaries) {
    ++report.layouts;
    if (!s.ok) {
      ++report.failed_layouts;
      if (report.failures.size() < 5) report.failures.push_back(s.failure);
      continue;
    }
    report.restarts += s.restarts;
    metrics.AddImage(s.annotated);
    if (options.image_totals) {
      report.image_totals.push_back(TotalsOfImage(options.first + (&s - summaries.data()), s.annotated,
                                                  ScaleClassAreaScale(params, params.width, params.height)));
    }
    for (const InstanceRecord& r : s.annotated) {
      report.viewpoints.Add(r.view_azimuth, r.view_elevation);
      truncation_sum += r.truncation;
      truncation_sq += r.truncation * r.truncation;
      ++truncation_n;
    }
    sample_ms += s.sample_ms;
    mask_ms += s.mask_ms;
    attempts += s.attempts;
    placed += s.placed;
    proposals += static_cast<double>(s.proposals);
  }
  report.metrics = metrics.Finish();
  if (truncation_n > 0) {
    const double mean = truncation_sum / truncation_n;
    const double var = truncation_n > 1 ? std::max(0.0, (truncation_sq - truncation_n * mean * mean) / (truncation_n - 1)) : 0;
    report.truncation = {mean, 1.96 * std::sqrt(var / truncation_n)};
  }
  const double ok_layouts = static_cast<double>(report.layouts - report.failed_layouts);
  if (ok_layouts > 0) {
    report.sample_ms_per_layout = sample_ms / ok_layouts;
    report.mask_ms_per_layout = mask_ms / ok_layouts;
    report.mean_attempts = attempts / ok_layouts;
    report.mean_placed = placed / ok_layouts;
    report.mean_proposals = proposals / ok_layouts;
  }
  report.seconds = MillisecondsSince(start) / 1000;
  return report;
}

nlohmann::json SampleReport::ToJson() const {
  nlohmann::json j = metrics.ToJson();
  j["scale_classes_at"] = {scale_width, scale_height};
  j["truncation"] = {{"mean", truncation.mean}, {"ci95", truncation.ci95}};
  j["viewpoints"] = {{"azimuth_bins", viewpoints.azimuth_bins},
                     {"elevation_bins", viewpoints.elevation_bins},
                     {"azimuth_range_deg", {-180, 180}},
                     {"elevation_range_deg", {-90, 90}},
                     {"counts", viewpoints.counts}};
  j["layouts"] = layouts;
  j["failed_layouts"] = failed_layouts;
  j["failures"] = failures;
  j["restarts"] = restarts;
  j["mean_attempts"] = mean_attempts;
  j["mean_placed"] = mean_placed;
  j["mean_proposals"] = mean_proposals;
  j["seconds"] = seconds;
  j["sample_ms_per_layout"] = sample_ms_per_layout;
  j["mask_ms_per_layout"] = mask_ms_per_layout;
  return j;
}

Result<std::unique_ptr<LayoutSampler>> OpenSampler(const SamplerSource& source) {
  SOLID_ASSIGN_OR_RETURN(const LayoutParams params, ResolveParams(source.params));
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<AssetLibrary> library,
                         AssetLibrary::Open(source.assets, source.rooms.empty() ? source.assets : source.rooms,
                                            source.library));
  return LayoutSampler::Create(params, std::move(library));
}

Result<SampleCommandReport> SampleCommand(const SampleCommandOptions& options) {
  if (options.export_scene) {
    if (*options.export_scene < 0) return OptionError("export_scene", "a layout index is >= 0");
    if (options.export_path.empty()) return OptionError("export_path", "export_scene needs the .glb to write");
  }
  SOLID_ASSIGN_OR_RETURN(const std::unique_ptr<LayoutSampler> sampler, OpenSampler(options.source));
  SampleCommandReport report;
  report.params = sampler->params();
  report.seed = options.sample.seed;
  report.first = options.sample.first;
  if (options.export_scene) {
    SOLID_ASSIGN_OR_RETURN(const GeneratedLayout g, GenerateLayout(*sampler, options.sample.seed, *options.export_scene));
    SOLID_ASSIGN_OR_RETURN(const std::vector<uint8_t> glb, ExportSceneGlb(g.layout));
    SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(options.export_path, glb));
    report.exported = ExportedScene{*options.export_scene, g.layout.objects.size(),
                                    static_cast<size_t>(g.masks.visible_objects), g.layout.room->key(),
                                    options.export_path};
    return report;
  }
  SOLID_ASSIGN_OR_RETURN(report.sample, RunSample(*sampler, options.sample));
  return report;
}

nlohmann::json SampleCommandReport::ToJson() const {
  nlohmann::json j = sample ? sample->ToJson() : nlohmann::json::object();
  j["params"] = ParamsToJson(params);
  j["seed"] = seed;
  j["first"] = first;
  return j;
}

}  // namespace solid::render
