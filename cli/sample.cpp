#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <numbers>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/render/sample.h"

namespace solid::cli {
namespace {

struct SampleFlags {
  render::SampleCommandOptions options;
  int64_t export_index = -1;
  uint64_t asset_cache_mb = 2048;
  bool json = false;
};

const FlagNames kSampleFlags =
    WithParamsFlags({{"layouts", "--layouts"}, {"first", "--first"}, {"export_scene", "--export-scene"},
                     {"export_path", "--out"}});

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

int Run(SampleFlags& f) {
  render::SampleCommandOptions& options = f.options;
  options.source.library = AssetLibraryOptionsFor(f.asset_cache_mb);
  if (f.export_index >= 0) options.export_scene = f.export_index;
  options.sample.cancel = InstallStopHandlers();
  Result<render::SampleCommandReport> report = [&] {
    ProgressLine progress("sample", "layouts");
    if (!options.export_scene) options.sample.progress = progress.Callback();
    return render::SampleCommand(options);
  }();
  if (report.status().code() == StatusCode::kCancelled) {
    fmt::print(stderr, "solid: {} ({}); sample writes no file: rerun it for the report\n", report.status().message(),
               StopSignalName());
    return StopExitCode();
  }
  if (!report.ok()) return Fail(report.status(), kSampleFlags);
  if (const std::optional<render::ExportedScene>& e = report->exported) {
    fmt::print(stderr, "solid: wrote layout {} ({} objects, {} visible, room {}) to {}\n", e->index, e->objects,
               e->visible_objects, e->room, e->path.string());
    return kExitOk;
  }
  if (f.json) {
    std::cout << report->ToJson().dump(2) << "\n";
  } else {
    PrintReport(*report->sample, report->params);
  }
  return report->sample->failed_layouts > 0 ? kExitProblems : kExitOk;
}

}  // namespace

Command AddSample(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "sample",
      "Sample layouts, run the mask pass and print the proxy metrics (objects per image, occlusion, "
      "small/medium/large shares, viewpoints) with 95% confidence intervals; or export one layout as glTF.");
  auto f = std::make_shared<SampleFlags>();
  AddParamsFlags(cmd, &f->options.source.params);
  cmd->add_option("--assets", f->options.source.assets, "Assets directory with the models (from `solid convert`)")->required();
  cmd->add_option("--rooms", f->options.source.rooms, "Assets directory with the rooms (default: --assets)");
  AddAssetCacheFlag(cmd, &f->asset_cache_mb);
  cmd->add_option("--layouts,-n", f->options.sample.layouts, "Number of layouts")->capture_default_str()->check(CLI::Range(1, 100000000));
  cmd->add_option("--first", f->options.sample.first, "Index of the first layout")->capture_default_str();
  AddSeedOption(cmd, &f->options.sample.seed, "Dataset seed: layout i depends only on (params, assets, seed, i)");
  AddJobsOption(cmd, &f->options.sample.jobs, "Layouts in parallel (default: all cores)");
  cmd->add_flag("--json", f->json, "Print the report as JSON (with the resolved params)");
  cmd->add_option("--export-scene", f->export_index, "Write layout I as a glTF scene to --out instead of sampling")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--out,-o", f->options.export_path, "Output .glb for --export-scene");
  return [f, cmd]() -> int {
    if (f->options.source.params.params.empty() && f->options.source.params.preset.empty()) {
      fmt::print(stderr, "solid sample: give --params FILE or --preset NAME\n{}", cmd->help());
      return kExitUsage;
    }
    if (f->export_index >= 0 && f->options.export_path.empty()) {
      fmt::print(stderr, "solid sample: --export-scene I needs --out OUT.glb\n");
      return kExitUsage;
    }
    return Run(*f);
  };
}

}  // namespace solid::cli
