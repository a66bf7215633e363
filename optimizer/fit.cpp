#include "solid/optimizer/fit.h"

#include <fmt/format.h>

#include <utility>

#include "solid/optimizer/search_space.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"

namespace solid::optimizer {
namespace {

std::string Formatted(Metric m, double v) {
  return m == Metric::kObjectsPerImage ? fmt::format("{:.2f}", v) : fmt::format("{:.1f}%", 100 * v);
}

void Note(const FitOptions& options, const std::string& line) {
  if (options.on_note) options.on_note(line);
}

Result<render::LayoutParams> ResolveStart(const FitOptions& o, const SearchSpace& space) {
  if (!o.preset.empty() && !o.params.empty()) return OptionError("preset", "give a preset or a params file, not both");
  if (!o.params.empty()) return render::LoadParamsFile(o.params);
  if (!o.preset.empty()) return render::LoadPreset(o.preset);
  if (space.start_params()) return render::LoadParamsFile(*space.start_params());
  if (space.start_preset()) return render::LoadPreset(*space.start_preset());
  return OptionError("preset", "no start: give a preset, a params file, or a search space with a start");
}

}  // namespace

Result<ResolvedTargets> ResolveTargets(const TargetSpec& spec, const render::LayoutParams& start) {
  ResolvedTargets resolved;
  std::vector<Target>& targets = resolved.targets;
  if (!spec.target_row.empty()) {
    Result<std::vector<Target>> row = TableRowTargets(spec.target_row);
    if (!row.ok()) return OptionError("target_row", row.status().message(), row.status().code());
    targets = *std::move(row);
  }
  auto set = [&](Metric m, double value) {
    std::erase_if(targets, [&](const Target& t) { return t.metric == m; });
    targets.push_back({m, value, 0});
  };
  if (!spec.match_coco.empty()) {
    CocoMatchOptions coco;
    std::tie(coco.width, coco.height) = render::ScaleClassResolution(start);
    coco.skip_empty_images = spec.skip_empty_images;
    SOLID_ASSIGN_OR_RETURN(CocoMatch match, TargetsFromCoco(spec.match_coco, coco));
    for (const Target& t : match.targets) set(t.metric, t.value);
    resolved.coco = std::move(match);
  }
  if (spec.target_count) set(Metric::kObjectsPerImage, *spec.target_count);
  if (spec.target_occlusion) set(Metric::kOcclusion, *spec.target_occlusion);
  if (!spec.target_scale.empty()) {
    if (spec.target_scale.size() != 3) return OptionError("target_scale", "expected three shares SMALL,MEDIUM,LARGE");
    set(Metric::kSmall, spec.target_scale[0]);
    set(Metric::kMedium, spec.target_scale[1]);
    set(Metric::kLarge, spec.target_scale[2]);
  }
  for (Target& t : targets) {
    t.tolerance = t.metric == Metric::kObjectsPerImage ? spec.tol_count
                  : t.metric == Metric::kOcclusion     ? spec.tol_occlusion
                                                       : spec.tol_scale;
  }
  if (targets.empty()) {
    return OptionError("targets", "no target: give a Table-1 row, a COCO file to match, or single targets");
  }
  return resolved;
}

Result<FitReport> Fit(const FitOptions& options) {
  if (options.out.params.empty()) return OptionError("out", "the params file to write is required");
  if (options.assets.empty()) return OptionError("assets", "the assets directory is required");
  OptimizeOptions o = options.search;
  SearchSpace space;
  if (!options.space.empty()) {
    SOLID_ASSIGN_OR_RETURN(space, SearchSpace::Load(options.space));
  }
  SOLID_ASSIGN_OR_RETURN(o.start, ResolveStart(options, space));
  if (options.space.empty()) space = SearchSpace::FitKnobs(o.start);
  for (const std::string& k : options.free) {
    if (Status s = space.Free(k, o.start); !s.ok()) return OptionError("free", s.message());
  }
  for (const std::string& k : options.fix) {
    if (Status s = space.Fix(k); !s.ok()) return OptionError("fix", s.message());
  }
  o.space = std::move(space);

  SOLID_ASSIGN_OR_RETURN(ResolvedTargets resolved, ResolveTargets(options.targets, o.start));
  if (const std::optional<CocoMatch>& match = resolved.coco) {
    Note(options, fmt::format("targets from {}: {} images ({} counted, {} without annotations{}), {} annotations ({} "
                              "crowd left out), areas classed at {}x{}",
                              options.targets.match_coco.string(), match->images, match->images_counted,
                              match->empty_images,
                              options.targets.skip_empty_images ? ", skipped" : ", counted as 0 objects",
                              match->annotations, match->crowd_skipped, match->width, match->height));
    for (const Target& t : match->targets) {
      const Estimate e = t.metric == Metric::kObjectsPerImage ? match->objects_per_image
                         : t.metric == Metric::kSmall         ? match->small
                         : t.metric == Metric::kMedium        ? match->medium
                                                              : match->large;
      Note(options, fmt::format("  {:<18} {:>8} +- {} (n = {})", MetricName(t.metric), Formatted(t.metric, t.value),
                                Formatted(t.metric, e.ci95),
                                t.metric == Metric::kObjectsPerImage ? match->images_counted : match->annotations));
    }
    if (!options.targets.target_occlusion && options.targets.target_row.empty()) {
      Note(options, "  occlusion is not in COCO annotations and is left free (a target occlusion or a Table-1 row "
                    "sets it)");
    }
  }
  o.targets = resolved.targets;

  render::AssetLibraryOptions cache;
  cache.cache_bytes = options.asset_cache_bytes;
  SOLID_ASSIGN_OR_RETURN(
      std::shared_ptr<render::AssetLibrary> library,
      render::AssetLibrary::Open(options.assets, options.rooms.empty() ? options.assets : options.rooms, cache));

  FitReport report;
  report.targets = o.targets;
  const uint64_t fingerprint = FitFingerprint(o, library->catalog_hash());
  if (!options.refit) {
    if (std::optional<nlohmann::json> recorded = ReusableFit(options.out, fingerprint)) {
      report.reused = true;
      report.all_met = recorded->value("all_met", false);
      report.summary = *std::move(recorded);
      return report;
    }
  }
  SOLID_ASSIGN_OR_RETURN(OptimizeReport optimized, Optimize(library, o));
  const std::string comment =
      optimized.cancelled
          ? fmt::format("solid optimize: stopped after {} evaluations; the best point so far, not confirmed on fresh "
                        "layouts",
                        optimized.evaluations)
          : fmt::format("solid optimize: {} evaluations, targets {}", optimized.evaluations,
                        optimized.all_met ? "met" : "NOT met");
  SOLID_RETURN_IF_ERROR(WriteFit(optimized, options.out, fingerprint, comment));
  report.all_met = optimized.all_met;
  report.cancelled = optimized.cancelled;
  report.summary = optimized.ToJson();
  report.optimized = std::move(optimized);
  return report;
}

}  // namespace solid::optimizer
