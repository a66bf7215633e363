#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <tuple>

#include "commands.h"
#include "exit_codes.h"
#include "signals.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/optimizer/dataset_metrics.h"
#include "solid/optimizer/fit.h"
#include "solid/optimizer/optimize.h"
#include "solid/render/sample.h"

namespace solid::cli {
namespace {

using optimizer::Metric;

struct OptimizeFlags {
  optimizer::FitOptions fit;
  std::string eval_resolution;
  uint64_t asset_cache_mb = 2048;
  bool json = false;
};

// The fields of FitOptions (and of its search) that a flag sets, for errors naming a field.
const FlagNames kOptimizeFlags = {{"preset", "--preset"},           {"out", "--out"},
                                  {"assets", "--assets"},           {"target_row", "--target-row"},
                                  {"target_scale", "--target-scale"}, {"targets", "--target-row"},
                                  {"algorithm", "--algorithm"},     {"global_algorithm", "--global"},
                                  {"layouts", "--layouts"},         {"confirm_layouts", "--confirm-layouts"},
                                  {"confirm_output_layouts", "--confirm-output-layouts"},
                                  {"confirm_standard_error", "--confirm-error"},
                                  {"max_rounds", "--rounds"},       {"space", "--space"},
                                  {"free", "--free"},               {"fix", "--fix"}};

std::string Percent(Metric m, double v) {
  return m == Metric::kObjectsPerImage ? fmt::format("{:.2f}", v) : fmt::format("{:.1f}%", 100 * v);
}

// The metrics of one progress line, evaluation or confirmation alike.
std::string ProgressMetrics(const ProxyMetrics& m) {
  return fmt::format("count {:5.2f}  occ {:4.1f}%  s/m/l {:4.1f}/{:4.1f}/{:4.1f}%", m.objects_per_image.mean,
                     100 * m.occlusion.mean, 100 * m.small.mean, 100 * m.medium.mean, 100 * m.large.mean);
}

// How sure a confirmed target is: its residual in tolerances and how many standard errors
// the estimate lies inside (or outside) the tolerance.
std::string HowSure(const optimizer::TargetResult& t) {
  const double residual = (t.predicted.mean - t.target.value) / t.target.tolerance;
  const double standard_error = t.predicted.ci95 / 1.959963984540054 / t.target.tolerance;
  if (!(standard_error > 0)) return fmt::format("residual {:+.2f} tol", residual);
  return fmt::format("residual {:+.2f} +- {:.2f} tol, {:.1f} SE {} the tolerance", residual, standard_error,
                     std::abs(1 - std::abs(residual)) / standard_error, std::abs(residual) <= 1 ? "inside" : "outside");
}

// What to try when a target was missed, from why the fit ended.
void PrintAdvice(const optimizer::OptimizeReport& r) {
  fmt::print("to try:\n");
  bool blocked = false;
  for (const optimizer::TargetResult& t : r.results) blocked = blocked || !t.blocked_by.empty();
  if (blocked) {
    fmt::print("  free or widen the knob at its bound (--free, or a --space file with wider bounds), or start from a "
               "preset whose structure is nearer the targets (--preset)\n");
  }
  if (r.ending == "time" || r.ending == "evaluations" || r.ending == "rounds") {
    fmt::print("  a larger budget: --max-seconds {:.0f} (or --max-evals, --rounds)\n", std::ceil(2 * r.seconds));
  }
  if (r.ending != "blocked") {
    fmt::print("  more layouts per evaluation for metrics that vary much from layout to layout (--layouts), or a "
               "nearer preset (--preset)\n");
  }
}

void PrintReport(const optimizer::OptimizeReport& r, const std::string& out) {
  fmt::print("{} after {} evaluations, {} round(s), {:.1f} s: {}\n",
             r.cancelled ? "STOPPED" : r.all_met ? "MET" : "NOT MET", r.evaluations, r.rounds, r.seconds,
             r.stop_reason);
  for (const std::string& line : r.history) fmt::print("  {}\n", line);
  fmt::print("scale classes counted at {}\n", render::ScaleClassDescription(r.best));
  if (r.cancelled) {
    fmt::print("evaluation resolution {}x{}; achieved = the search's best evaluation (95% CI), unconfirmed\n",
               r.eval_width, r.eval_height);
  } else {
    const optimizer::ConfirmationRow& c = r.confirmations.back();
    fmt::print("evaluations at {}x{}; achieved = the confirmation at the output resolution {}x{} (95% CI): {} fresh "
               "layouts{}\n",
               r.eval_width, r.eval_height, r.best.width, r.best.height, r.confirmation.images,
               c.output_layouts > 0 ? fmt::format(", {} of them also at {}x{}", c.output_layouts, r.best.width, r.best.height)
                                    : std::string());
  }
  fmt::print("  {:<18} {:>9} {:>8} {:>18}   {}\n", "metric", "target", "tol", "achieved", r.pilot ? "pilot (output res)" : "");
  for (const optimizer::TargetResult& t : r.results) {
    const Metric m = t.target.metric;
    std::string pilot;
    if (t.pilot) {
      pilot = fmt::format("  pilot {} +- {} {}", Percent(m, t.pilot->mean), Percent(m, t.pilot->ci95),
                          t.pilot_agrees ? "agrees" : "DISAGREES");
    }
    fmt::print("  {:<18} {:>9} {:>8} {:>18}   {:<6} {}{}\n", optimizer::MetricName(m), Percent(m, t.target.value),
               Percent(m, t.target.tolerance),
               fmt::format("{} +- {}", Percent(m, t.predicted.mean), Percent(m, t.predicted.ci95)),
               t.met ? "ok" : "MISSED", r.cancelled ? "" : HowSure(t), pilot);
    if (t.search_offset != 0) {
      fmt::print("      searched for {} at the evaluation resolution: the output's measures {} {}\n",
                 Percent(m, t.target.value - t.search_offset), Percent(m, std::abs(t.search_offset)),
                 t.search_offset > 0 ? "more" : "less");
    }
    for (const std::string& b : t.blocked_by) fmt::print("      blocked by {}\n", b);
  }
  if (!r.all_met && !r.cancelled) PrintAdvice(r);
  fmt::print("point:\n");
  for (size_t i = 0; i < r.dimensions.size(); ++i) {
    fmt::print("  {:<34} {:>9.4g}   [{:g}, {:g}]\n", r.dimensions[i].name, r.best_x[i], r.dimensions[i].lo,
               r.dimensions[i].hi);
  }
  fmt::print("params written to {}\n", out);
}

void PrintRecordedFit(const nlohmann::json& fit, const std::string& out) {
  fmt::print("{} is up to date: fitted for these assets, start, targets and options ({} after {} evaluations, "
             "{:.1f} s); nothing to do (--refit fits again)\n",
             out, fit.value("all_met", false) ? "MET" : "NOT MET", fit.value("evaluations", 0),
             fit.value("seconds", 0.0));
  for (const nlohmann::json& t : fit.value("targets", nlohmann::json::array())) {
    const Metric m = optimizer::MetricByName(t.value("metric", "")).value_or(Metric::kObjectsPerImage);
    fmt::print("  {:<18} {:>9} {:>8} {:>18} {}\n", t.value("metric", ""), Percent(m, t.value("target", 0.0)),
               Percent(m, t.value("tolerance", 0.0)),
               fmt::format("{} +- {}", Percent(m, t["achieved"].value("mean", 0.0)),
                           Percent(m, t["achieved"].value("ci95", 0.0))),
               t.value("met", false) ? "ok" : "MISSED");
  }
}

int RunOptimize(OptimizeFlags& f) {
  optimizer::FitOptions& o = f.fit;
  if (!f.eval_resolution.empty()) {
    SOLID_ASSIGN_OR_RETURN_EXIT(auto wh, ParseResolution("--eval-resolution", f.eval_resolution));
    std::tie(o.search.eval_width, o.search.eval_height) = wh;
  }
  o.asset_cache_bytes = f.asset_cache_mb << 20;
  o.on_note = [](const std::string& line) { fmt::print(stderr, "solid: {}\n", line); };
  o.search.on_evaluation = [](const optimizer::TraceRow& t) {
    fmt::print(stderr, "eval {:>4} r{} {:<6} objective {:>9.3f}  {}  {:6.1f} s\n", t.evaluation, t.round, t.phase,
               t.objective, ProgressMetrics(t.metrics), t.seconds);
  };
  o.search.on_confirmation = [](const optimizer::ConfirmationRow& c) {
    fmt::print(stderr, "confirm r{} {:<14} on {} fresh layouts ({} at the output resolution)  {}  {:6.1f} s\n",
               c.round, c.met ? "met" : c.clear_miss ? "missed clearly" : "missed", c.metrics.images,
               c.output_layouts, ProgressMetrics(c.metrics), c.seconds);
  };
  o.search.cancel = InstallStopHandlers();
  Result<optimizer::FitReport> fitted = optimizer::Fit(o);
  if (fitted.status().code() == StatusCode::kCancelled) {
    fmt::print(stderr, "solid: {} ({}); nothing written\n", fitted.status().message(), StopSignalName());
    return StopExitCode();
  }
  if (!fitted.ok()) return Fail(fitted.status(), kOptimizeFlags);
  const std::string out = o.out.params.string();
  if (f.json) {
    std::cout << fitted->summary.dump(2) << "\n";
  } else if (fitted->reused) {
    PrintRecordedFit(fitted->summary, out);
  } else {
    PrintReport(*fitted->optimized, out);
  }
  if (fitted->cancelled) {
    fmt::print(stderr, "solid: stopped by {}: {} evaluations done; the best point so far is in {}{} (not confirmed "
                       "on fresh layouts). A rerun starts the search again; to go on from here, start it from that "
                       "file: --params {}\n",
               StopSignalName(), fitted->optimized->evaluations, out,
               o.out.trace.empty() ? "" : ", the evaluations in " + o.out.trace.string(), out);
    return StopExitCode();
  }
  return fitted->all_met ? kExitOk : kExitProblems;
}

struct MetricsFlags {
  optimizer::MetricsOptions options;
  bool json = false;
};

const FlagNames kMetricsFlags = {{"target_row", "--target-row"}, {"compare", "--compare"},
                                 {"assets", "--assets"},         {"layouts", "--layouts"}};

int RunMetrics(const MetricsFlags& f) {
  Result<optimizer::MetricsReport> result = optimizer::MeasureDataset(f.options);
  if (!result.ok()) return Fail(result.status(), kMetricsFlags);
  const optimizer::MetricsReport& r = *result;
  if (f.json) {
    std::cout << r.ToJson().dump(2) << "\n";
  } else {
    fmt::print("{}: {} images, {} visible instances (95% CI), scale classes counted at {}x{}\n", r.dataset.string(),
               r.measured.images, r.measured.visible_instances, r.scale_classes_at.first, r.scale_classes_at.second);
    if (!r.compared_with.empty()) fmt::print("compared with {}\n", r.compared_with);
    for (const optimizer::Comparison& c : optimizer::CompareWithPrediction(r.measured, r.measured)) {
      const Metric m = c.metric;
      std::string ref;
      for (const optimizer::Comparison& k : r.comparisons) {
        if (k.metric != m) continue;
        ref = fmt::format("   vs {} +- {} (tol {}) {}", Percent(m, k.reference.mean), Percent(m, k.reference.ci95),
                          Percent(m, k.tolerance), k.agrees ? "ok" : "DIFFERS");
      }
      fmt::print("  {:<18} {:>8} +- {:<7}{}\n", optimizer::MetricName(m), Percent(m, c.measured.mean),
                 Percent(m, c.measured.ci95), ref);
    }
  }
  return r.all_agree ? kExitOk : kExitProblems;
}

}  // namespace

Command AddOptimize(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "optimize",
      "Search layout knobs with NLopt until the proxy metrics of sampled layouts (mask pass only) hit targets; "
      "write the params file.");
  auto f = std::make_shared<OptimizeFlags>();
  optimizer::FitOptions& fit = f->fit;
  optimizer::OptimizeOptions& o = fit.search;
  optimizer::TargetSpec& t = fit.targets;
  auto* preset = cmd->add_option("--preset", fit.preset, "Start from this Table-1 preset");
  auto* params = cmd->add_option("--params", fit.params, "Start from this params file");
  preset->excludes(params);
  params->excludes(preset);
  cmd->add_option("--space", fit.space, "Search-space file (schemas/search-space.schema.json); default: the fit knobs of solid-method 4.3 in 7 or 8 dimensions (README)");
  cmd->add_option("--free", fit.free, "Also free these knobs (comma-separated, default bounds)")->delimiter(',');
  cmd->add_option("--fix", fit.fix, "Fix these knobs at the start's value (comma-separated)")->delimiter(',');
  cmd->add_option("--assets", fit.assets, "Assets directory with the models")->required();
  cmd->add_option("--rooms", fit.rooms, "Assets directory with the rooms (default: --assets)");
  AddAssetCacheFlag(cmd, &f->asset_cache_mb);
  cmd->add_option("--out,-o", fit.out.params, "Params file to write (usable by solid sample --params)")->required();
  cmd->add_option("--trace", fit.out.trace, "Write every evaluation to this file (.csv, else JSON)");
  cmd->add_option("--target-row", t.target_row, "Targets of a Table-1 row (a preset name)");
  cmd->add_option("--match-coco", t.match_coco,
                  "Targets for the count and the small/medium/large shares from a COCO instances file (your "
                  "downstream data): crowd annotations left out, each area rescaled to the scale-class resolution");
  cmd->add_flag("--skip-empty-images", t.skip_empty_images,
                "With --match-coco: leave out images without annotations (default: they count as 0 objects)");
  cmd->add_option("--target-count", t.target_count, "Target visible objects per image");
  cmd->add_option("--target-occlusion", t.target_occlusion, "Target mean occlusion, a fraction (0.38)");
  cmd->add_option("--target-scale", t.target_scale, "Target small,medium,large shares, fractions (0.33,0.39,0.28)")
      ->delimiter(',');
  cmd->add_option("--tol-count", t.tol_count, "Tolerance of the count")->capture_default_str();
  cmd->add_option("--tol-occlusion", t.tol_occlusion, "Tolerance of the occlusion (fraction)")->capture_default_str();
  cmd->add_option("--tol-scale", t.tol_scale, "Tolerance of each scale share (fraction)")->capture_default_str();
  cmd->add_option("--algorithm", o.algorithm, "Local algorithm: gauss-newton (trust-region Gauss-Newton on the residuals), "
                   "or NLopt's sbplx, neldermead, bobyqa, cobyla, praxis")
      ->capture_default_str();
  cmd->add_option("--global", o.global_algorithm, "Global NLopt algorithm run first: crs2, isres, esch, direct");
  cmd->add_option("--global-evals", o.global_evaluations, "Evaluations of the global phase (default: a third of --max-evals)");
  cmd->add_option("--layouts,-n", o.layouts, "Layouts per evaluation (Gauss-Newton: each on layouts of its own; NLopt: common seeds, doubled each round)")
      ->capture_default_str()->check(CLI::Range(int64_t{1}, int64_t{1000000}));
  cmd->add_option("--eval-resolution", f->eval_resolution, "Mask resolution of evaluations (default: a quarter of the output's width and height)");
  cmd->add_option("--confirm-layouts", o.confirm_layouts, "Fresh layouts of each confirmation, at the evaluation resolution (0: as many as --confirm-error needs)")
      ->capture_default_str()->check(CLI::Range(int64_t{0}, int64_t{10000000}));
  cmd->add_option("--confirm-output-layouts", o.confirm_output_layouts, "Of them, also measured at the output resolution, which corrects the rest (0: as many as --confirm-error needs)")
      ->capture_default_str()->check(CLI::Range(int64_t{0}, int64_t{10000000}));
  cmd->add_option("--confirm-error", o.confirm_standard_error, "Standard error, in tolerances, that sized confirmations aim at")
      ->capture_default_str()->check(CLI::Range(0.01, 10.0));
  cmd->add_option("--pilot", o.pilot_layouts, "Fresh layouts at the output resolution checked against the prediction")
      ->capture_default_str();
  cmd->add_option("--max-evals", o.max_evaluations, "Evaluation budget")->capture_default_str();
  cmd->add_option("--max-seconds", o.max_seconds, "Time budget of the searches and their confirmations (the pilot comes on top)")->capture_default_str();
  cmd->add_option("--margin", o.search_margin, "Share of each tolerance within which a round's search stops and a confirmation that meets every target ends the fit; otherwise another round searches on from the confirmed point, while the budget has room")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--rounds", o.max_rounds, "Search rounds at most (each ends with a confirmation; one outside --margin with budget left starts another)")
      ->capture_default_str()->check(CLI::Range(1, 100));
  AddSeedOption(cmd, &o.seed, "Layout seed");
  AddJobsOption(cmd, &o.jobs, "Layouts in parallel (default: all cores)");
  cmd->add_flag("--json", f->json, "Print the summary as JSON");
  cmd->add_flag("--refit", fit.refit,
                "Fit even when --out was fitted by an earlier run for the same assets, start, targets and options "
                "(its fit record, OUT.fit.json, says so)");
  return [f]() { return RunOptimize(*f); };
}

Command AddMetrics(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "metrics", "Proxy metrics of a rendered dataset from its stored masks, with 95% CIs; optionally compared with "
                 "a Table-1 row's targets or with a params file's sampled prediction.");
  auto f = std::make_shared<MetricsFlags>();
  cmd->add_option("dataset", f->options.dataset, "Dataset directory")->required();
  auto* row = cmd->add_option("--target-row", f->options.target_row, "Compare with the targets of this Table-1 row");
  auto* compare = cmd->add_option("--compare", f->options.compare, "Compare with the metrics of this params file, sampled");
  row->excludes(compare);
  compare->excludes(row);
  cmd->add_option("--assets", f->options.assets, "Models for --compare");
  cmd->add_option("--rooms", f->options.rooms, "Rooms for --compare (default: --assets)");
  cmd->add_option("--layouts,-n", f->options.layouts, "Layouts sampled for --compare")->capture_default_str();
  AddSeedOption(cmd, &f->options.seed, "Seed of the layouts sampled for --compare");
  AddJobsOption(cmd, &f->options.jobs, "Layouts in parallel for --compare (default: all cores)");
  cmd->add_flag("--json", f->json, "Print JSON");
  return [f]() { return RunMetrics(*f); };
}

}  // namespace solid::cli
