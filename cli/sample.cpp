#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <numbers>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/formats/files.h"
#include "solid/render/sample.h"
#include "solid/render/scene_export.h"

namespace solid::cli {
namespace {

struct SampleFlags {
  ParamsFlags params;
  std::string assets, rooms, export_path;
  int64_t layouts = 100, first = 0, export_index = -1;
  uint64_t asset_cache_mb = 2048;
  uint64_t seed = 1;
  int jobs = 0;
  bool json = false;
};

void PrintReport(const render::SampleReport& r, const render::LayoutParams& p) {
  const ProxyMetrics& m = r.metrics;
  fmt::print("layouts            {} ({} failed, {} restarts)\n", r.layouts, r.failed_layouts, r.restarts);
  for (const std::string& f : r.failures) fmt::print("  failed: {}\n", f);
  fmt::print("resolution         {}x{}\n", p.width, p.height);
  fmt::print("scale classes      counted at {}\n", render::ScaleClassDescription(p));
  fmt::print("objects per image  {:.2f} +- {:.2f}   (placed {:.2f} of {:.2f} attempts)\n", m.objects_per_image.mean,
             m.objects_per_image.ci95, r.mean_placed, r.mean_attempts);
  fmt::print("occlusion          {:.1f}% +- {:.1f}\n", 100 * m.occlusion.mean, 100 * m.occlusion.ci95);
  fmt::print("scale s / m / l    {:.1f}% / {:.1f}% / {:.1f}%   (+- {:.1f} / {:.1f} / {:.1f})\n", 100 * m.small.mean,
             100 * m.medium.mean, 100 * m.large.mean, 100 * m.small.ci95, 100 * m.medium.ci95, 100 * m.large.ci95);
  fmt::print("truncation         {:.1f}% +- {:.1f}\n", 100 * r.truncation.mean, 100 * r.truncation.ci95);
  fmt::print("time per layout    {:.2f} ms sampling + {:.2f} ms mask pass (one thread); {:.1f} layouts/s\n",
             r.sample_ms_per_layout, r.mask_ms_per_layout, r.seconds > 0 ? r.layouts / r.seconds : 0.0);
  // The viewpoint distribution, as the paper's Fig. 3: elevation rows, azimuth columns.
  const auto& v = r.viewpoints;
  int64_t total = 0;
  for (int64_t c : v.counts) total += c;
  fmt::print("viewpoints         % of visible objects; rows: elevation, columns: azimuth ({} deg bins)\n",
             360 / v.azimuth_bins);
  fmt::print("          ");
  for (int a = 0; a < v.azimuth_bins; ++a) fmt::print("{:>6}", -180 + a * 360 / v.azimuth_bins);
  fmt::print("\n");
  for (int e = v.elevation_bins - 1; e >= 0; --e) {
    fmt::print("  {:>+4}..  ", -90 + e * 180 / v.elevation_bins);
    for (int a = 0; a < v.azimuth_bins; ++a) {
      const int64_t c = v.counts[static_cast<size_t>(e) * v.azimuth_bins + a];
      fmt::print("{:>6.1f}", total > 0 ? 100.0 * c / total : 0.0);
    }
    fmt::print("\n");
  }
}

int Run(const SampleFlags& f) {
  SOLID_ASSIGN_OR_RETURN_EXIT(render::LayoutParams params, ResolveParams(f.params));
  SOLID_ASSIGN_OR_RETURN_EXIT(std::shared_ptr<render::AssetLibrary> library,
                              render::AssetLibrary::Open(f.assets, f.rooms.empty() ? f.assets : f.rooms,
                                                         AssetLibraryOptionsFor(f.asset_cache_mb)));
  SOLID_ASSIGN_OR_RETURN_EXIT(std::unique_ptr<render::LayoutSampler> sampler,
                              render::LayoutSampler::Create(params, library));
  if (f.export_index >= 0) {
    SOLID_ASSIGN_OR_RETURN_EXIT(render::GeneratedLayout g,
                                render::GenerateLayout(*sampler, f.seed, f.export_index));
    SOLID_ASSIGN_OR_RETURN_EXIT(std::vector<uint8_t> glb, render::ExportSceneGlb(g.layout));
    const Status written = files::WriteFileAtomically(f.export_path, glb);
    if (!written.ok()) return Fail(written);
    fmt::print(stderr, "solid: wrote layout {} ({} objects, {} visible, room {}) to {}\n", f.export_index,
               g.layout.objects.size(), g.masks.visible_objects, g.layout.room->key(), f.export_path);
    return kExitOk;
  }
  render::SampleOptions options;
  options.seed = f.seed;
  options.first = f.first;
  options.layouts = f.layouts;
  options.jobs = f.jobs;
  options.cancel = InstallStopHandlers();
  Result<render::SampleReport> report = [&] {
    ProgressLine progress("sample", "layouts");
    options.progress = progress.Callback();
    return render::RunSample(*sampler, options);
  }();
  if (report.status().code() == StatusCode::kCancelled) {
    fmt::print(stderr, "solid: {} ({}); sample writes no file: rerun it for the report\n", report.status().message(),
               StopSignalName());
    return StopExitCode();
  }
  if (!report.ok()) return Fail(report.status());
  if (f.json) {
    nlohmann::json j = report->ToJson();
    j["params"] = render::ParamsToJson(params);
    j["seed"] = f.seed;
    j["first"] = f.first;
    std::cout << j.dump(2) << "\n";
  } else {
    PrintReport(*report, params);
  }
  return report->failed_layouts > 0 ? kExitProblems : kExitOk;
}

}  // namespace

Command AddSample(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "sample",
      "Sample layouts, run the mask pass and print the proxy metrics (objects per image, occlusion, "
      "small/medium/large shares, viewpoints) with 95% confidence intervals; or export one layout as glTF.");
  auto f = std::make_shared<SampleFlags>();
  AddParamsFlags(cmd, &f->params);
  cmd->add_option("--assets", f->assets, "Assets directory with the models (from `solid convert`)")->required();
  cmd->add_option("--rooms", f->rooms, "Assets directory with the rooms (default: --assets)");
  AddAssetCacheFlag(cmd, &f->asset_cache_mb);
  cmd->add_option("--layouts,-n", f->layouts, "Number of layouts")->capture_default_str()->check(CLI::Range(1, 100000000));
  cmd->add_option("--first", f->first, "Index of the first layout")->capture_default_str();
  AddSeedOption(cmd, &f->seed, "Dataset seed: layout i depends only on (params, assets, seed, i)");
  AddJobsOption(cmd, &f->jobs, "Layouts in parallel (default: all cores)");
  cmd->add_flag("--json", f->json, "Print the report as JSON (with the resolved params)");
  cmd->add_option("--export-scene", f->export_index, "Write layout I as a glTF scene to --out instead of sampling")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--out,-o", f->export_path, "Output .glb for --export-scene");
  return [f, cmd]() -> int {
    if (f->params.params.empty() && f->params.preset.empty()) {
      fmt::print(stderr, "solid sample: give --params FILE or --preset NAME\n{}", cmd->help());
      return kExitUsage;
    }
    if (f->export_index >= 0 && f->export_path.empty()) {
      fmt::print(stderr, "solid sample: --export-scene I needs --out OUT.glb\n");
      return kExitUsage;
    }
    return Run(*f);
  };
}

}  // namespace solid::cli
