// `solid sample`: draw layouts, run the mask pass, and measure the proxy metrics of
// the paper (objects per image, occlusion, small/medium/large shares) and the
// viewpoint distribution, without shading a single pixel.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/cancel.h"
#include "solid/formats/metrics.h"
#include "solid/formats/progress.h"
#include "solid/render/assets.h"
#include "solid/render/layout.h"
#include "solid/render/mask_pass.h"
#include "solid/render/params.h"
#include "solid/render/shade.h"

namespace solid::render {

// A usable layout of image `index` with its lights and mask pass: the first restart whose
// layout places an object, finds a position for each light, and shows at least one object
// with min_visible_pixels visible pixels (solid-method.md 2 and 2.6: an empty image or an
// unlit room restarts the scene; D9: a bounded budget). `solid sample` and `solid render`
// draw the same layouts.
struct GeneratedLayout {
  Layout layout;
  LightRig lights;
  MaskPassResult masks;
  double sample_ms = 0, mask_ms = 0;  // summed over restarts
};
// kLimitExceeded after params.max_scene_restarts + 1 unusable draws, with their reasons.
// Scale classes are counted at the params' ScaleClassResolution (options.area_scale is
// set from it).
Result<GeneratedLayout> GenerateLayout(const LayoutSampler& sampler, uint64_t dataset_seed, int64_t index,
                                       MaskPassOptions options = {});

// Camera directions in the objects' frames, visible instances only: azimuth in
// `azimuth_bins` bins over [-180, 180) degrees, elevation in `elevation_bins` over
// [-90, 90]; counts[e * azimuth_bins + a].
struct ViewpointHistogram {
  int azimuth_bins = 12, elevation_bins = 6;
  std::vector<int64_t> counts = std::vector<int64_t>(72, 0);
  void Add(double azimuth, double elevation);
};

struct SampleOptions {
  uint64_t seed = 1;
  int64_t first = 0;  // layouts first .. first + layouts - 1
  int64_t layouts = 100;
  int jobs = 0;       // layouts in parallel; 0: all cores
  // The mask pass counts areas only (MaskPassOptions::metrics_only): the same metrics,
  // truncation 0; what the optimizer's evaluations use.
  bool metrics_only = false;
  // Fill SampleReport::image_totals.
  bool image_totals = false;
  ProgressCallback progress;
  // Stops between layouts (solid/formats/cancel.h): RunSample then returns kCancelled,
  // since metrics of the layouts done so far would depend on thread timing.
  const CancelFlag* cancel = nullptr;
};

struct SampleReport {
  // Over annotated instances (>= min_visible_pixels visible); scale classes as at the
  // params' ScaleClassResolution (the optimizer measures at a lower resolution than the
  // dataset it aims for, with scale_classes_at set to the dataset's).
  ProxyMetrics metrics;
  int scale_width = 0, scale_height = 0;  // the params' ScaleClassResolution
  Estimate truncation;   // over visible instances
  ViewpointHistogram viewpoints;
  int64_t layouts = 0, failed_layouts = 0, restarts = 0;
  std::vector<std::string> failures;  // the first few reasons
  double mean_attempts = 0, mean_placed = 0, mean_proposals = 0;
  double seconds = 0;
  double sample_ms_per_layout = 0, mask_ms_per_layout = 0;  // thread time per layout
  // With SampleOptions::image_totals: each usable layout's totals (its index the layout's),
  // in index order; what the metrics above sum.
  std::vector<ImageTotals> image_totals;
  nlohmann::json ToJson() const;
};

Result<SampleReport> RunSample(const LayoutSampler& sampler, const SampleOptions& options);

// What sample and render draw layouts from: the params, and the assets directories of
// the models and of the rooms.
struct SamplerSource {
  ParamsSource params;
  std::filesystem::path assets;  // the models (an assets directory of `solid convert`)
  std::filesystem::path rooms;   // the rooms; empty: `assets`
  AssetLibraryOptions library;
};
// The params resolved (ResolveParams, whose OptionErrors it returns), the library opened
// and the sampler created.
Result<std::unique_ptr<LayoutSampler>> OpenSampler(const SamplerSource& source);

// `solid sample` as one call: samples options.sample's layouts, or, with export_scene,
// writes that one layout as a glTF scene (scene_export) to export_path instead.
struct SampleCommandOptions {
  SamplerSource source;
  SampleOptions sample;
  std::optional<int64_t> export_scene;  // a layout index, >= 0
  std::filesystem::path export_path;    // the .glb written with export_scene
};

// The exported layout of SampleCommandOptions::export_scene.
struct ExportedScene {
  int64_t index = 0;
  size_t objects = 0, visible_objects = 0;
  std::string room;  // the room's asset key
  std::filesystem::path path;
};

struct SampleCommandReport {
  LayoutParams params;  // as resolved
  uint64_t seed = 1;
  int64_t first = 0;
  std::optional<SampleReport> sample;      // without export_scene
  std::optional<ExportedScene> exported;  // with export_scene
  // The sample report with the resolved params, the seed and the first index.
  nlohmann::json ToJson() const;
};

// OptionError "export_scene" (negative) or "export_path" (empty with export_scene); the
// errors of OpenSampler, RunSample (kCancelled when stopped), GenerateLayout and writing.
Result<SampleCommandReport> SampleCommand(const SampleCommandOptions& options);

}  // namespace solid::render
