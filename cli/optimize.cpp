#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <tuple>

#include "commands.h"
#include "exit_codes.h"
#include "signals.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/optimizer/coco_targets.h"
#include "solid/optimizer/optimize.h"
#include "solid/render/sample.h"

namespace solid::cli {
namespace {

using optimizer::Metric;

struct OptimizeFlags {
  std::string preset, params, space, assets, rooms, out, trace, target_row, eval_resolution, match_coco;
  bool skip_empty_images = false;
  std::vector<std::string> free, fix;
  std::optional<double> count, occlusion;
  std::vector<double> scale;
  double tol_count = optimizer::DefaultTolerance(Metric::kObjectsPerImage);
  double tol_occlusion = optimizer::DefaultTolerance(Metric::kOcclusion);
  double tol_scale = optimizer::DefaultTolerance(Metric::kSmall);
  optimizer::OptimizeOptions options;
  uint64_t asset_cache_mb = 2048;
  bool json = false;
  bool refit = false;
};

std::string Percent(Metric m, double v) {
  return m == Metric::kObjectsPerImage ? fmt::format("{:.2f}", v) : fmt::format("{:.1f}%", 100 * v);
}

// --target-row first, then --match-coco's count and shares, then the single targets
// override or add. `start` gives the resolution the COCO areas are classed at.
Result<std::vector<optimizer::Target>> ResolveTargets(const OptimizeFlags& f, const render::LayoutParams& start) {
  std::vector<optimizer::Target> targets;
  if (!f.target_row.empty()) {
    SOLID_ASSIGN_OR_RETURN(targets, optimizer::TableRowTargets(f.target_row));
  }
  auto set = [&](Metric m, double value) {
    std::erase_if(targets, [&](const optimizer::Target& t) { return t.metric == m; });
    targets.push_back({m, value, 0});
  };
  if (!f.match_coco.empty()) {
    optimizer::CocoMatchOptions coco;
    std::tie(coco.width, coco.height) = render::ScaleClassResolution(start);
    coco.skip_empty_images = f.skip_empty_images;
    SOLID_ASSIGN_OR_RETURN(const optimizer::CocoMatch match, optimizer::TargetsFromCoco(f.match_coco, coco));
    fmt::print(stderr, "solid: targets from {}: {} images ({} counted, {} without annotations{}), {} annotations "
                       "({} crowd left out), areas classed at {}x{}\n",
               f.match_coco, match.images, match.images_counted, match.empty_images,
               f.skip_empty_images ? ", skipped" : ", counted as 0 objects", match.annotations, match.crowd_skipped,
               match.width, match.height);
    for (const optimizer::Target& t : match.targets) {
      const Estimate e = t.metric == Metric::kObjectsPerImage ? match.objects_per_image
                         : t.metric == Metric::kSmall         ? match.small
                         : t.metric == Metric::kMedium        ? match.medium
                                                              : match.large;
      fmt::print(stderr, "solid:   {:<18} {:>8} +- {} (n = {})\n", optimizer::MetricName(t.metric),
                 Percent(t.metric, t.value), Percent(t.metric, e.ci95),
                 t.metric == Metric::kObjectsPerImage ? match.images_counted : match.annotations);
      set(t.metric, t.value);
    }
    if (!f.occlusion && f.target_row.empty()) {
      fmt::print(stderr, "solid:   occlusion is not in COCO annotations and is left free (--target-occlusion or "
                         "--target-row sets it)\n");
    }
  }
  if (f.count) set(Metric::kObjectsPerImage, *f.count);
  if (f.occlusion) set(Metric::kOcclusion, *f.occlusion);
  if (!f.scale.empty()) {
    if (f.scale.size() != 3) return InvalidArgumentError("--target-scale: expected three shares SMALL,MEDIUM,LARGE");
    set(Metric::kSmall, f.scale[0]);
    set(Metric::kMedium, f.scale[1]);
    set(Metric::kLarge, f.scale[2]);
  }
  for (optimizer::Target& t : targets) {
    t.tolerance = t.metric == Metric::kObjectsPerImage ? f.tol_count
                  : t.metric == Metric::kOcclusion     ? f.tol_occlusion
                                                       : f.tol_scale;
  }
  if (targets.empty()) {
    return InvalidArgumentError("no target: give --target-row, --match-coco or --target-count/-occlusion/-scale");
  }
  return targets;
}

void PrintReport(const optimizer::OptimizeReport& r, const std::string& out) {
  fmt::print("{} after {} evaluations, {} round(s), {:.1f} s: {}\n",
             r.cancelled ? "STOPPED" : r.all_met ? "MET" : "NOT MET", r.evaluations, r.rounds, r.seconds,
             r.stop_reason);
  fmt::print("scale classes counted at {}\n", render::ScaleClassDescription(r.best));
  if (r.cancelled) {
    fmt::print("evaluation resolution {}x{}; achieved = the search's common layouts (95% CI), unconfirmed\n",
               r.eval_width, r.eval_height);
  } else {
    fmt::print("evaluations at {}x{}; achieved = {} fresh layouts at the output resolution {}x{} (95% CI)\n",
               r.eval_width, r.eval_height, r.confirmation.images, r.best.width, r.best.height);
  }
  fmt::print("  {:<18} {:>9} {:>8} {:>18} {}\n", "metric", "target", "tol", "achieved", r.pilot ? "  pilot (output res)" : "");
  for (const optimizer::TargetResult& t : r.results) {
    const Metric m = t.target.metric;
    std::string pilot;
    if (t.pilot) {
      pilot = fmt::format("  {} +- {} {}", Percent(m, t.pilot->mean), Percent(m, t.pilot->ci95),
                          t.pilot_agrees ? "agrees" : "DISAGREES");
    }
    fmt::print("  {:<18} {:>9} {:>8} {:>18} {}{}\n", optimizer::MetricName(m), Percent(m, t.target.value),
               Percent(m, t.target.tolerance),
               fmt::format("{} +- {}", Percent(m, t.predicted.mean), Percent(m, t.predicted.ci95)),
               t.met ? "ok" : "MISSED", pilot);
    if (t.search_offset != 0) {
      fmt::print("      searched for {} on the common layouts: at the last round's start, fresh ones measured {} {}\n",
                 Percent(m, t.target.value - t.search_offset), Percent(m, std::abs(t.search_offset)),
                 t.search_offset > 0 ? "more" : "less");
    }
    for (const std::string& b : t.blocked_by) fmt::print("      blocked by {}\n", b);
    if (!t.met && t.blocked_by.empty()) {
      fmt::print("      no free dimension at a bound holds it back: the search stopped ({}) first\n", r.stop_reason);
    }
  }
  fmt::print("point:\n");
  for (size_t i = 0; i < r.dimensions.size(); ++i) {
    fmt::print("  {:<34} {:>9.4g}   [{:g}, {:g}]\n", r.dimensions[i].name, r.best_x[i], r.dimensions[i].lo,
               r.dimensions[i].hi);
  }
  fmt::print("params written to {}\n", out);
}

int RunOptimize(OptimizeFlags& f) {
  optimizer::OptimizeOptions& o = f.options;
  optimizer::SearchSpace space;
  if (!f.space.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(space, optimizer::SearchSpace::Load(f.space));
  }
  Result<render::LayoutParams> start = !f.params.empty()                ? render::LoadParamsFile(f.params)
                                       : !f.preset.empty()              ? render::LoadPreset(f.preset)
                                       : space.start_params().has_value() ? render::LoadParamsFile(*space.start_params())
                                       : space.start_preset().has_value() ? render::LoadPreset(*space.start_preset())
                                                                          : InvalidArgumentError("give --preset, --params, or a --space with a start");
  if (!start.ok()) return Fail(start.status());
  o.start = *start;
  if (f.space.empty()) space = optimizer::SearchSpace::FitKnobs(o.start);
  for (const std::string& k : f.free) {
    if (Status s = space.Free(k, o.start); !s.ok()) return Fail(s);
  }
  for (const std::string& k : f.fix) {
    if (Status s = space.Fix(k); !s.ok()) return Fail(s);
  }
  o.space = std::move(space);
  SOLID_ASSIGN_OR_RETURN_EXIT(o.targets, ResolveTargets(f, o.start));
  if (!f.eval_resolution.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(auto wh, ParseResolution("--eval-resolution", f.eval_resolution));
    std::tie(o.eval_width, o.eval_height) = wh;
  }
  SOLID_ASSIGN_OR_RETURN_EXIT(std::shared_ptr<render::AssetLibrary> library,
                              render::AssetLibrary::Open(f.assets, f.rooms.empty() ? f.assets : f.rooms,
                                                         AssetLibraryOptionsFor(f.asset_cache_mb)));
  o.on_evaluation = [](const optimizer::TraceRow& t) {
    const ProxyMetrics& m = t.metrics;
    fmt::print(stderr, "eval {:>4} r{} {:<6} objective {:>9.3f}  count {:5.2f}  occ {:4.1f}%  s/m/l {:4.1f}/{:4.1f}/{:4.1f}%  {:6.1f} s\n",
               t.evaluation, t.round, t.phase, t.objective, m.objects_per_image.mean, 100 * m.occlusion.mean,
               100 * m.small.mean, 100 * m.medium.mean, 100 * m.large.mean, t.seconds);
  };
  const optimizer::FitFiles files{f.out, f.trace};
  const uint64_t fingerprint = optimizer::FitFingerprint(o, library->catalog_hash());
  if (!f.refit) {
    if (const std::optional<nlohmann::json> fit = optimizer::ReusableFit(files, fingerprint)) {
      const bool met = fit->value("all_met", false);
      if (f.json) {
        std::cout << fit->dump(2) << "\n";
      } else {
        fmt::print("{} is up to date: fitted for these assets, start, targets and options ({} after {} evaluations, "
                   "{:.1f} s); nothing to do (--refit fits again)\n",
                   f.out, met ? "MET" : "NOT MET", fit->value("evaluations", 0), fit->value("seconds", 0.0));
        for (const nlohmann::json& t : fit->value("targets", nlohmann::json::array())) {
          const Metric m = optimizer::MetricByName(t.value("metric", "")).value_or(Metric::kObjectsPerImage);
          fmt::print("  {:<18} {:>9} {:>8} {:>18} {}\n", t.value("metric", ""), Percent(m, t.value("target", 0.0)),
                     Percent(m, t.value("tolerance", 0.0)),
                     fmt::format("{} +- {}", Percent(m, t["achieved"].value("mean", 0.0)),
                                 Percent(m, t["achieved"].value("ci95", 0.0))),
                     t.value("met", false) ? "ok" : "MISSED");
        }
      }
      return met ? kExitOk : kExitProblems;
    }
  }
  o.cancel = InstallStopHandlers();
  Result<optimizer::OptimizeReport> optimized = optimizer::Optimize(library, o);
  if (optimized.status().code() == StatusCode::kCancelled) {
    fmt::print(stderr, "solid: {} ({}); nothing written\n", optimized.status().message(), StopSignalName());
    return StopExitCode();
  }
  SOLID_ASSIGN_OR_RETURN_EXIT(optimizer::OptimizeReport report, std::move(optimized));
  const std::string comment = report.cancelled
                                  ? fmt::format("solid optimize: stopped by {} after {} evaluations; the best point so "
                                                "far, not confirmed on fresh layouts",
                                                StopSignalName(), report.evaluations)
                                  : fmt::format("solid optimize: {} evaluations, targets {}", report.evaluations,
                                                report.all_met ? "met" : "NOT met");
  if (Status s = optimizer::WriteFit(report, files, fingerprint, comment); !s.ok()) return Fail(s);
  if (f.json) {
    std::cout << report.ToJson().dump(2) << "\n";
  } else {
    PrintReport(report, f.out);
  }
  if (report.cancelled) {
    fmt::print(stderr, "solid: stopped by {}: {} evaluations done; the best point so far is in {}{} (not confirmed "
                       "on fresh layouts). A rerun starts the search again; to go on from here, start it from that "
                       "file: --params {}\n",
               StopSignalName(), report.evaluations, f.out, f.trace.empty() ? "" : ", the evaluations in " + f.trace,
               f.out);
    return StopExitCode();
  }
  return report.all_met ? kExitOk : kExitProblems;
}

struct MetricsFlags {
  std::string dataset, compare, target_row, assets, rooms;
  int64_t layouts = 2000;
  uint64_t seed = 1;
  int jobs = 0;
  bool json = false;
};

int RunMetrics(const MetricsFlags& f) {
  SOLID_ASSIGN_OR_RETURN_EXIT(ProxyMetrics measured, DatasetMetrics(f.dataset));
  SOLID_ASSIGN_OR_RETURN_EXIT(const Manifest manifest, ReadManifest(f.dataset));
  const std::string scale_classes =
      fmt::format("{}x{}", manifest.ScaleClassResolution().first, manifest.ScaleClassResolution().second);
  std::vector<optimizer::Comparison> comparisons;
  std::string against;
  if (!f.target_row.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(std::vector<optimizer::Target> targets, optimizer::TableRowTargets(f.target_row));
    comparisons = optimizer::CompareWithTargets(measured, targets);
    against = "Table-1 row " + f.target_row;
  } else if (!f.compare.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(render::LayoutParams params, render::LoadParamsFile(f.compare));
    SOLID_ASSIGN_OR_RETURN_EXIT(std::shared_ptr<render::AssetLibrary> library,
                                render::AssetLibrary::Open(f.assets, f.rooms.empty() ? f.assets : f.rooms));
    SOLID_ASSIGN_OR_RETURN_EXIT(std::unique_ptr<render::LayoutSampler> sampler,
                                render::LayoutSampler::Create(params, library));
    render::SampleOptions options;
    options.seed = f.seed;
    options.first = optimizer::kPilotFirst;
    options.layouts = f.layouts;
    options.jobs = f.jobs;
    SOLID_ASSIGN_OR_RETURN_EXIT(render::SampleReport predicted, render::RunSample(*sampler, options));
    comparisons = optimizer::CompareWithPrediction(measured, predicted.metrics);
    against = fmt::format("{} sampled ({} layouts at {}x{})", f.compare, f.layouts, params.width, params.height);
  }
  bool agree = true;
  for (const optimizer::Comparison& c : comparisons) agree = agree && c.agrees;
  if (f.json) {
    nlohmann::json j = {{"dataset", f.dataset},
                        {"metrics", measured.ToJson()},
                        {"scale_classes_at", {manifest.ScaleClassResolution().first, manifest.ScaleClassResolution().second}}};
    if (!comparisons.empty()) {
      nlohmann::json rows = nlohmann::json::array();
      for (const optimizer::Comparison& c : comparisons) {
        rows.push_back({{"metric", optimizer::MetricName(c.metric)},
                        {"measured", {{"mean", c.measured.mean}, {"ci95", c.measured.ci95}}},
                        {"reference", {{"mean", c.reference.mean}, {"ci95", c.reference.ci95}}},
                        {"tolerance", c.tolerance},
                        {"agrees", c.agrees}});
      }
      j["compared_with"] = against;
      j["comparison"] = rows;
      j["all_agree"] = agree;
    }
    std::cout << j.dump(2) << "\n";
  } else {
    fmt::print("{}: {} images, {} visible instances (95% CI), scale classes counted at {}\n", f.dataset,
               measured.images, measured.visible_instances, scale_classes);
    if (!comparisons.empty()) fmt::print("compared with {}\n", against);
    for (const optimizer::Comparison& c : optimizer::CompareWithPrediction(measured, measured)) {
      const Metric m = c.metric;
      std::string ref;
      for (const optimizer::Comparison& k : comparisons) {
        if (k.metric != m) continue;
        ref = fmt::format("   vs {} +- {} (tol {}) {}", Percent(m, k.reference.mean), Percent(m, k.reference.ci95),
                          Percent(m, k.tolerance), k.agrees ? "ok" : "DIFFERS");
      }
      fmt::print("  {:<18} {:>8} +- {:<7}{}\n", optimizer::MetricName(m), Percent(m, c.measured.mean),
                 Percent(m, c.measured.ci95), ref);
    }
  }
  return agree ? kExitOk : kExitProblems;
}

}  // namespace

Command AddOptimize(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "optimize",
      "Search layout knobs with NLopt until the proxy metrics of sampled layouts (mask pass only) hit targets; "
      "write the params file.");
  auto f = std::make_shared<OptimizeFlags>();
  optimizer::OptimizeOptions& o = f->options;
  auto* preset = cmd->add_option("--preset", f->preset, "Start from this Table-1 preset");
  auto* params = cmd->add_option("--params", f->params, "Start from this params file");
  preset->excludes(params);
  params->excludes(preset);
  cmd->add_option("--space", f->space, "Search-space file (schemas/search-space.schema.json); default: the fit knobs");
  cmd->add_option("--free", f->free, "Also free these knobs (comma-separated, default bounds)")->delimiter(',');
  cmd->add_option("--fix", f->fix, "Fix these knobs at the start's value (comma-separated)")->delimiter(',');
  cmd->add_option("--assets", f->assets, "Assets directory with the models")->required();
  cmd->add_option("--rooms", f->rooms, "Assets directory with the rooms (default: --assets)");
  AddAssetCacheFlag(cmd, &f->asset_cache_mb);
  cmd->add_option("--out,-o", f->out, "Params file to write (usable by solid sample --params)")->required();
  cmd->add_option("--trace", f->trace, "Write every evaluation to this file (.csv, else JSON)");
  cmd->add_option("--target-row", f->target_row, "Targets of a Table-1 row (a preset name)");
  cmd->add_option("--match-coco", f->match_coco,
                  "Targets for the count and the small/medium/large shares from a COCO instances file (your "
                  "downstream data): crowd annotations left out, each area rescaled to the scale-class resolution");
  cmd->add_flag("--skip-empty-images", f->skip_empty_images,
                "With --match-coco: leave out images without annotations (default: they count as 0 objects)");
  cmd->add_option("--target-count", f->count, "Target visible objects per image");
  cmd->add_option("--target-occlusion", f->occlusion, "Target mean occlusion, a fraction (0.38)");
  cmd->add_option("--target-scale", f->scale, "Target small,medium,large shares, fractions (0.33,0.39,0.28)")
      ->delimiter(',');
  cmd->add_option("--tol-count", f->tol_count, "Tolerance of the count")->capture_default_str();
  cmd->add_option("--tol-occlusion", f->tol_occlusion, "Tolerance of the occlusion (fraction)")->capture_default_str();
  cmd->add_option("--tol-scale", f->tol_scale, "Tolerance of each scale share (fraction)")->capture_default_str();
  cmd->add_option("--algorithm", o.algorithm, "Local algorithm: gauss-newton (trust-region Gauss-Newton on the residuals), "
                   "or NLopt's sbplx, neldermead, bobyqa, cobyla, praxis")
      ->capture_default_str();
  cmd->add_option("--global", o.global_algorithm, "Global NLopt algorithm run first: crs2, isres, esch, direct");
  cmd->add_option("--global-evals", o.global_evaluations, "Evaluations of the global phase (default: a third of --max-evals)");
  cmd->add_option("--layouts,-n", o.layouts, "Layouts per evaluation (common seeds; doubled each round)")
      ->capture_default_str()->check(CLI::Range(int64_t{1}, int64_t{1000000}));
  cmd->add_option("--eval-resolution", f->eval_resolution, "Mask resolution of evaluations (default: a quarter of the output's width and height)");
  cmd->add_option("--confirm-layouts", o.confirm_layouts, "Fresh layouts at the output resolution that re-measure the best point (the acceptance of solid-method.md 4.3 is over 2,000: raise it for a final check)")
      ->capture_default_str()->check(CLI::Range(int64_t{1}, int64_t{10000000}));
  cmd->add_option("--pilot", o.pilot_layouts, "Fresh layouts at the output resolution checked against the prediction")
      ->capture_default_str();
  cmd->add_option("--max-evals", o.max_evaluations, "Evaluation budget")->capture_default_str();
  cmd->add_option("--max-seconds", o.max_seconds, "Time budget of the search and its confirmation (the pilot comes on top)")->capture_default_str();
  cmd->add_option("--margin", o.search_margin, "Stop the search within this share of each tolerance")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--rounds", o.max_rounds, "Search rounds at most (a missed confirmation starts another)")
      ->capture_default_str()->check(CLI::Range(1, 10));
  AddSeedOption(cmd, &o.seed, "Layout seed");
  AddJobsOption(cmd, &o.jobs, "Layouts in parallel (default: all cores)");
  cmd->add_flag("--json", f->json, "Print the summary as JSON");
  cmd->add_flag("--refit", f->refit,
                "Fit even when --out was fitted by an earlier run for the same assets, start, targets and options "
                "(its fit record, OUT.fit.json, says so)");
  return [f]() { return RunOptimize(*f); };
}

Command AddMetrics(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "metrics", "Proxy metrics of a rendered dataset from its stored masks, with 95% CIs; optionally compared with "
                 "a Table-1 row's targets or with a params file's sampled prediction.");
  auto f = std::make_shared<MetricsFlags>();
  cmd->add_option("dataset", f->dataset, "Dataset directory")->required();
  auto* row = cmd->add_option("--target-row", f->target_row, "Compare with the targets of this Table-1 row");
  auto* compare = cmd->add_option("--compare", f->compare, "Compare with the metrics of this params file, sampled");
  row->excludes(compare);
  compare->excludes(row);
  cmd->add_option("--assets", f->assets, "Models for --compare");
  cmd->add_option("--rooms", f->rooms, "Rooms for --compare (default: --assets)");
  cmd->add_option("--layouts,-n", f->layouts, "Layouts sampled for --compare")->capture_default_str();
  AddSeedOption(cmd, &f->seed, "Seed of the layouts sampled for --compare");
  AddJobsOption(cmd, &f->jobs, "Layouts in parallel for --compare (default: all cores)");
  cmd->add_flag("--json", f->json, "Print JSON");
  return [f]() -> int {
    if (!f->compare.empty() && f->assets.empty()) {
      fmt::print(stderr, "solid metrics: --compare needs --assets\n");
      return kExitUsage;
    }
    return RunMetrics(*f);
  };
}

}  // namespace solid::cli
