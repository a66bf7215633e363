// `solid optimize` as one call: resolve the start, the search space and the targets, open the
// assets, reuse a recorded fit when nothing it depends on changed, else search (Optimize) and
// write the params, the trace and the fit record.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"
#include "solid/optimizer/coco_targets.h"
#include "solid/optimizer/optimize.h"

namespace solid::optimizer {

// Where the targets come from, applied in this order: a Table-1 row, then the count and
// shares of a COCO instances file, then single targets overriding or adding. Option errors
// name these fields ("target_scale", ...), or "targets" when there is none at all.
struct TargetSpec {
  std::string target_row;
  std::filesystem::path match_coco;
  bool skip_empty_images = false;  // with match_coco: leave images without annotations out
  std::optional<double> target_count, target_occlusion;
  std::vector<double> target_scale;  // small, medium, large
  double tol_count = DefaultTolerance(Metric::kObjectsPerImage);
  double tol_occlusion = DefaultTolerance(Metric::kOcclusion);
  double tol_scale = DefaultTolerance(Metric::kSmall);
};

struct ResolvedTargets {
  std::vector<Target> targets;
  std::optional<CocoMatch> coco;  // when match_coco was given
};

// `start` gives the resolution at which COCO areas are classed.
Result<ResolvedTargets> ResolveTargets(const TargetSpec& spec, const render::LayoutParams& start);

struct FitOptions {
  // The start: a preset or a params file (one of them), else the search space's own start.
  std::string preset;
  std::filesystem::path params;
  std::filesystem::path space;  // empty: SearchSpace::FitKnobs of the start
  std::vector<std::string> free, fix;  // knobs freed (default bounds) or fixed at the start's value
  TargetSpec targets;
  std::filesystem::path assets, rooms;  // rooms empty: assets
  uint64_t asset_cache_bytes = uint64_t{2048} << 20;
  FitFiles out;        // out.params is required
  bool refit = false;  // search even when out's fit record matches
  // The search's steering (algorithm, layouts, budgets, seed, jobs, cancel, on_evaluation);
  // its start, space and targets are those resolved from the fields above.
  OptimizeOptions search;
  // Lines for people while the call runs: the targets derived from match_coco and their
  // sample sizes, a field left free.
  std::function<void(const std::string&)> on_note;
};

struct FitReport {
  // True when out's fit record matched: nothing was searched or written, and summary is the
  // recorded one.
  bool reused = false;
  std::vector<Target> targets;
  nlohmann::json summary;  // OptimizeReport::ToJson, of this search or of the recorded one
  std::optional<OptimizeReport> optimized;  // this search (not reused)
  bool all_met = false;
  bool cancelled = false;  // the search was stopped: its best point written, unconfirmed, no record
};

// kInvalidArgument naming a field (OptionError) for a wrong option; the errors of loading the
// start, the space, the COCO file and the assets as they come; kCancelled when the search was
// stopped before its first evaluation (nothing written).
Result<FitReport> Fit(const FitOptions& options);

}  // namespace solid::optimizer
