#include <fmt/format.h>

#include <iostream>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/render/render_dataset.h"

namespace solid::cli {
namespace {

struct RenderFlags {
  render::RenderCommandOptions options;
  std::string shards, format = "png", sampling = "adaptive";
  int64_t shard = -1;
  uint64_t asset_cache_mb = 2048;
  bool no_queries = false, json = false;
};

void PrintReport(const render::RenderReport& r, const render::LayoutParams& p) {
  fmt::print("shards             {} requested: {} rendered ({} repaired), {} already present{}\n", r.shards_requested,
             r.shards_rendered, r.shards_repaired, r.shards_present,
             r.shards_by_others > 0 ? fmt::format(" ({} published by other processes meanwhile)", r.shards_by_others)
                                    : "");
  fmt::print("images             {} at {}x{}, {} instances", r.images, p.width, p.height, r.instances);
  if (r.failed_images > 0) fmt::print(", {} left out (no usable layout)", r.failed_images);
  fmt::print("\n");
  for (const std::string& f : r.failures) fmt::print("  left out: {}\n", f);
  fmt::print("query shards       {} rendered ({} views), {} already present\n", r.query_shards_rendered,
             r.query_views, r.query_shards_present);
  const render::StageTimes& s = r.stages;
  const double per_image = r.images > 0 ? 1.0 / r.images : 0.0;
  fmt::print("time per image     layout {:.1f} ms, mask pass {:.1f} ms, shading {:.1f} ms ({}), encoding {:.1f} ms, "
             "writing {:.1f} ms (one thread each)\n",
             s.layout * per_image, s.mask_pass * per_image, s.shading * per_image, r.shading_instruction_set,
             s.encoding * per_image, s.writing * per_image);
  fmt::print("query views        {:.1f} s over all threads\n", s.query_views / 1000);
  fmt::print("total              {:.1f} s, {:.2f} images/s, peak memory {:.0f} MiB{}\n", r.seconds,
             r.seconds > 0 ? r.images / r.seconds : 0.0, r.peak_rss_bytes / 1048576.0,
             r.index_built ? "; index.sqlite rebuilt" : "");
}

int Run(RenderFlags& f) {
  render::RenderOptions& options = f.options.render;
  // --shard K, --shards A-B, or the index a scheduler gives each task of an array job.
  std::string shard_source = f.shard >= 0 ? "--shard" : "--shards";
  if (f.shard >= 0) {
    options.shards = std::pair{f.shard, f.shard};
  } else if (!f.shards.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(options.shards, render::ParseShardRange("--shards", f.shards));
  } else {
    SOLID_ASSIGN_OR_RETURN_EXIT(const std::optional<render::ScheduledShard> scheduled, render::ShardFromEnvironment());
    if (scheduled) {
      options.shards = std::pair{scheduled->shard, scheduled->shard};
      shard_source = scheduled->variable;
    }
  }
  SOLID_ASSIGN_OR_RETURN_EXIT(options.format, ParseImageFormat(f.format));
  options.shading.sampling = f.sampling == "adaptive" ? render::Sampling::kAdaptive : render::Sampling::kUniform;
  options.queries = !f.no_queries;
  f.options.source.library = AssetLibraryOptionsFor(f.asset_cache_mb);
  if (options.shards && !f.json) {
    fmt::print(stderr, "solid: shards {}-{} (from {})\n", options.shards->first, options.shards->second, shard_source);
  }
  options.cancel = InstallStopHandlers();
  options.on_note = [](const std::string& line) { fmt::print(stderr, "solid: {}\n", InCommandTerms(line)); };
  Result<render::RenderCommandReport> report = [&] {
    ProgressLine progress("render", "images");
    options.progress = progress.Callback();
    return render::RenderCommand(f.options);
  }();
  const FlagNames flags = WithParamsFlags({{"images", "--images"}, {"shard_size", "--shard-size"}, {"shards", shard_source}});
  if (!report.ok()) return Fail(report.status(), flags);
  if (f.json) {
    std::cout << report->ToJson().dump(2) << "\n";
  } else {
    PrintReport(report->render, report->params);
  }
  const render::RenderReport& r = report->render;
  if (r.cancelled) {
    fmt::print(stderr, "solid: stopped by {}: {} of {} requested shards complete ({} rendered by this run){}; {}\n",
               StopSignalName(), r.shards_requested - static_cast<int64_t>(r.shards_missing.size()),
               r.shards_requested, r.shards_rendered,
               r.abandoned_shard >= 0
                   ? fmt::format(", shard {} abandoned (its temporary file removed, nothing published)", r.abandoned_shard)
                   : "",
               r.shards_missing.empty() ? "query shards and index not finished"
                                        : "missing shards: " + Ranges(r.shards_missing));
    fmt::print(stderr, "solid: to resume, run the same command again:\n  {}\n", CommandLine());
    return StopExitCode();
  }
  return r.failed_images > 0 ? kExitProblems : kExitOk;
}

}  // namespace

Command AddRender(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "render",
      "Render target images with visible and full masks, boxes and depth, and query views of every model they "
      "use, into a sharded dataset; reruns render only what is missing.");
  auto f = std::make_shared<RenderFlags>();
  AddParamsFlags(cmd, &f->options.source.params);
  cmd->add_option("--assets", f->options.source.assets, "Assets directory with the models (from `solid convert`)")->required();
  cmd->add_option("--rooms", f->options.source.rooms, "Assets directory with the rooms (default: --assets)");
  AddAssetCacheFlag(cmd, &f->asset_cache_mb);
  cmd->add_option("--out,-o", f->options.render.out, "Dataset directory (created, or resumed when its manifest agrees)")->required();
  cmd->add_option("--images,-n", f->options.render.images, "Images in the dataset")
      ->capture_default_str()
      ->check(SchemaRange("manifest.schema.json", "/properties/images"));
  cmd->add_option("--shard-size", f->options.render.shard_size, "Images per shard")
      ->capture_default_str()
      ->check(SchemaRange("manifest.schema.json", "/properties/shard_size"));
  auto* shard = cmd->add_option("--shard", f->shard,
                                "Render this shard only (default: $SLURM_ARRAY_TASK_ID or $JOB_COMPLETION_INDEX when "
                                "set, else every shard)")
                    ->check(CLI::NonNegativeNumber);
  auto* range = cmd->add_option("--shards", f->shards, "Render shards FIRST-LAST only");
  shard->excludes(range);
  range->excludes(shard);
  AddSeedOption(cmd, &f->options.render.seed, "Dataset seed: image i depends only on (params, assets, seed, i)");
  AddJobsOption(cmd, &f->options.render.jobs, "Images in parallel");
  cmd->add_option("--format", f->format, "Image format: png, jpeg or webp")->capture_default_str();
  cmd->add_option("--quality", f->options.render.quality, "JPEG/WebP quality")->capture_default_str()->check(CLI::Range(1, 100));
  cmd->add_flag("--depth", f->options.render.depth, "Store depth as OpenEXR (half float, ZIP)");
  cmd->add_option("--spp", f->options.render.shading.samples_per_pixel, "Samples per pixel (stratified), of images and query views")->capture_default_str()->check(
      CLI::Range(1, 1024));
  cmd->add_option("--sampling", f->sampling,
                  "Sampling of the images: adaptive (mask-driven: edges get spp camera rays, flat pixels one "
                  "with spp/4 light samples whose lighting is filtered over their surface) or uniform (spp camera "
                  "rays per pixel)")
      ->capture_default_str()
      ->check(CLI::IsMember({"uniform", "adaptive"}));
  cmd->add_option("--query-size", f->options.render.query_views.long_side, "Long side of query views, pixels")->capture_default_str()->check(
      CLI::Range(16, 4096));
  cmd->add_flag("--no-queries", f->no_queries, "Do not render query views");
  cmd->add_flag("--repair", f->options.render.repair,
                "Validate present shards and re-render those that fail (damaged, another dataset's or another "
                "shard's, not a regular file); the others keep their bytes");
  cmd->add_flag("--adopt", f->options.render.adopt,
                "When DATASET has shards but no manifest.json: rebuild it from the shards' provenance, if they all "
                "agree, and go on (without it such a directory is refused)");
  cmd->add_flag("--json", f->json, "Print the report as JSON");
  return [f]() -> int { return Run(*f); };
}

}  // namespace solid::cli
