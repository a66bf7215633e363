// `solid optimize`: search the layout knobs of a search space (search_space.h) with NLopt
// until the proxy metrics of sampled layouts (mask pass only) hit targets, before any
// full render; and the metrics of rendered datasets (`solid metrics`).
//
// Evaluation of a point: `layouts` layouts drawn with the same seeds for every point
// (common random numbers: the objective is a deterministic function of the point), areas
// counted by a metrics-only mask pass at the evaluation resolution, and COCO scale classes
// as at the params' scale-class resolution (render::ScaleClassResolution: areas scaled by
// the pixel-count ratio; see MetricsAccumulator). The objective is
// sum_i ((metric_i - target_i) / tolerance_i)^2. Common seeds (round one's start, NLopt's
// methods) are the layout indices [0, layouts); Gauss-Newton measures each evaluation on
// layouts of its own from kSearchFirst on; each round's best point is re-measured
// (confirmed) on a disjoint index range of its own from kConfirmFirst on, and pilots start
// at kPilotFirst.
//
// Thread safety: Optimize and Evaluate use `jobs` threads and may run concurrently on
// one AssetLibrary.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/cancel.h"
#include "solid/formats/metrics.h"
#include "solid/formats/status.h"
#include "solid/optimizer/search_space.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"

namespace solid::optimizer {

// Gauss-Newton's k-th evaluation (from 0) measures layouts from kSearchFirst + k * kSearchStride.
inline constexpr int64_t kSearchFirst = int64_t{1} << 36;
inline constexpr int64_t kSearchStride = int64_t{1} << 24;
inline constexpr int64_t kConfirmFirst = int64_t{1} << 40;
// The k-th confirmation (from 0, one per round) measures layouts
// from kConfirmFirst + k * kConfirmRoundStride.
inline constexpr int64_t kConfirmRoundStride = int64_t{1} << 32;
inline constexpr int64_t kPilotFirst = int64_t{1} << 41;

enum class Metric { kObjectsPerImage, kOcclusion, kSmall, kMedium, kLarge };
// "objects_per_image", "occlusion", "small", "medium", "large".
std::string_view MetricName(Metric metric);
std::optional<Metric> MetricByName(std::string_view name);
Estimate MetricOf(const ProxyMetrics& metrics, Metric metric);

// The acceptance of solid-method.md 4.3 (schemas/table1.json "tolerances"): count +-0.25,
// occlusion +-1.5 points, each scale share +-2 points (as fractions: 0.015, 0.02).
double DefaultTolerance(Metric metric);

struct Target {
  Metric metric = Metric::kObjectsPerImage;
  double value = 0;
  double tolerance = 0;
};

// The rows of Table 1 (schemas/table1.json, checked by schemas/table1.schema.json), named as
// their presets, in the paper's order.
std::vector<std::string> TableRows();

// The targets of a Table-1 row by its preset name (solid-method.md 4.3), with the default
// tolerances; kNotFound lists the rows.
Result<std::vector<Target>> TableRowTargets(std::string_view row);

// sum over targets of ((metric - target) / tolerance)^2.
double Objective(const ProxyMetrics& metrics, const std::vector<Target>& targets);

struct EvaluationOptions {
  uint64_t seed = 1;
  int64_t first = 0;
  int64_t layouts = 200;
  // Mask resolution; 0: the params' output resolution. Other resolutions should keep the
  // output's aspect ratio, or the layouts themselves change (the frustum test).
  int width = 0, height = 0;
  int jobs = 0;  // 0: all cores
  const CancelFlag* cancel = nullptr;  // Evaluate returns kCancelled once it is set
};

struct Evaluation {
  ProxyMetrics metrics;
  std::vector<ImageTotals> totals;  // per usable layout, in index order: what the metrics sum
  int64_t failed_layouts = 0;  // no usable draw within the restart budget; not in the metrics
  double seconds = 0;
};

// The proxy metrics of `params` over layouts first .. first + layouts - 1. Deterministic:
// the same for any number of jobs.
Result<Evaluation> Evaluate(const render::LayoutParams& params, std::shared_ptr<render::AssetLibrary> library,
                            const EvaluationOptions& options);

// The evaluation resolution used when none is given: a quarter of the output's width and
// height (160x120 for 640x480). A power-of-two divisor scales every projection exactly in
// floating point, so the layouts are the output's, bit for bit (the frustum and clearance
// tests compare pixel coordinates): only pixel counts differ, a mask pass costs about a
// sixteenth, and the search corrects for the difference (OptimizeOptions::layouts).
void DefaultEvaluationResolution(const render::LayoutParams& params, int* width, int* height);

struct TraceRow {
  int evaluation = 0;  // from 1
  int round = 0;
  // "output" (round one's start on its common layouts at the output resolution), "start",
  // "global", "jacobian" (gauss-newton's design of differences), "local", "probe"
  std::string phase;
  std::vector<double> x;
  ProxyMetrics metrics;
  double objective = 0;
  double seconds = 0;  // since the start of Optimize
  int64_t layouts = 0;
};

// A round's best point re-measured on fresh layouts, its metrics estimated at the output
// resolution (OptimizeOptions::confirm_layouts). These decide what is reported and whether
// the search goes on; the trace has the evaluations only.
struct ConfirmationRow {
  int round = 0;
  std::vector<double> x;
  ProxyMetrics metrics;  // metrics.images: the layouts measured at the evaluation resolution
  int64_t output_layouts = 0;  // of them, also measured at the output resolution
  bool met = false;    // every target within its tolerance
  // Stopped after a part of its layouts: a target was missed by more than three standard
  // errors beyond its tolerance, which the rest could not have turned.
  bool clear_miss = false;
  double seconds = 0;  // since the start of Optimize, when it was done
};

struct OptimizeOptions {
  render::LayoutParams start;
  SearchSpace space;
  std::vector<Target> targets;
  // Local algorithm. "gauss-newton" (default): a trust-region Gauss-Newton search on the
  // residuals (metric - target) / tolerance of a local linear model fitted to every
  // evaluation and confirmation near the point (optimizer/local_model.h; a design of
  // differences, two evaluations per free dimension at 0.15 of its bounds each side, 0.3
  // within 0.15 of a bound), each evaluation on layouts of its own, and each
  // step's bounded linear least-squares problem solved by NLopt's SLSQP. Or an NLopt
  // derivative-free method on the objective over common layouts: "sbplx", "neldermead",
  // "bobyqa", "cobyla", "praxis".
  std::string algorithm = "gauss-newton";
  // Optional global phase first: "crs2", "isres", "esch", "direct"; it gets
  // global_evaluations (0: a third of max_evaluations).
  std::string global_algorithm;
  int global_evaluations = 0;
  uint64_t seed = 1;
  // Per evaluation (NLopt's methods: in the first round, then twice as many each round, up
  // to eight times). The first round measures its start on the same layouts at the output
  // resolution too, and the search aims at the targets shifted by what the evaluation
  // resolution changes there (TargetResult::search_offset; Gauss-Newton pools it with the
  // confirmations' pairs).
  int64_t layouts = 100;
  int eval_width = 0, eval_height = 0;  // 0: DefaultEvaluationResolution
  // Fresh layouts that confirm each round's best point: what the
  // report states, and what decides whether the search goes on. They are measured at the
  // evaluation resolution, the first confirm_output_layouts of them at the output resolution
  // too, and the output's metrics estimated as the former plus the difference the pairs
  // measure (optimizer/estimator.h: a difference varies far less between layouts than the
  // metrics do, so few costly pairs correct many cheap layouts); when the evaluation
  // resolution is the output's, the layouts are measured once. 0: sized from the per-layout
  // variances and costs measured so far, the cheapest sizes at which every target's
  // standard error is at most confirm_standard_error tolerances (within the time left). A
  // confirmation runs in parts, is sized again after each, and stops after one that shows
  // a clear miss.
  int64_t confirm_layouts = 0;
  int64_t confirm_output_layouts = 0;
  double confirm_standard_error = 0.3;
  int64_t pilot_layouts = 0;  // 0: no pilot
  int max_evaluations = 300;
  // Bounds the searches and the confirmations together: a search stops early enough to
  // confirm at the rates measured so far. The pilot comes on top.
  double max_seconds = 300;
  int jobs = 0;
  // A round's search stops once every target is within this share of its tolerance (for
  // Gauss-Newton, its local model's level, known to within 0.4 tolerances; for NLopt's
  // methods, on their common layouts, or within those layouts' own standard error), and a
  // confirmation within it ends the fit, leaving the rest of the tolerance to sampling error.
  double search_margin = 0.5;
  // A confirmation outside search_margin starts another round from the best point: for
  // Gauss-Newton the confirmation joins the local model as its most precise measurement; for
  // NLopt's methods, the round searches new common layouts for the targets shifted by it.
  // Rounds go on until the budget ends (time, evaluations, or this many rounds). The report
  // gives the latest confirmed point, or the latest that met every target when the last
  // one missed.
  int max_rounds = 10;
  std::function<void(const TraceRow&)> on_evaluation;  // called after each evaluation
  std::function<void(const ConfirmationRow&)> on_confirmation;  // and after each confirmation
  // Seconds on a monotonic clock, what the time budget is counted on (empty: the steady
  // clock). Tests give one that advances by a fixed step at each reading, so that every
  // decision the budget makes is the same on any machine and under any load.
  std::function<double()> clock;
  // Stops the search (solid/formats/cancel.h): the evaluation in flight is dropped, and
  // Optimize returns the best point of the evaluations done, unconfirmed (report.cancelled),
  // or kCancelled when none was done.
  const CancelFlag* cancel = nullptr;
};


struct TargetResult {
  Target target;
  Estimate predicted;  // on the fresh seeds at the output resolution (the confirmation)
  bool met = false;    // |predicted - target| <= tolerance
  // The search aimed at target - search_offset at the evaluation resolution. Gauss-Newton:
  // what the output resolution measures more on the same layouts, pooled over round one's
  // start and the confirmations' pairs. NLopt's methods: in the first round that difference
  // at the start; from the second on, the confirmation's difference from the round's common
  // layouts at its start.
  double search_offset = 0;
  std::optional<Estimate> pilot;  // at the output resolution
  bool pilot_agrees = false;      // |pilot - predicted| <= tolerance + the difference's 95% CI
  // Why an unmet target could not be met: free dimensions at a bound in the direction
  // that would help ("objects.attempts.low at its upper bound 60").
  std::vector<std::string> blocked_by;
};

struct OptimizeReport {
  render::LayoutParams best;
  std::vector<Dimension> dimensions;
  std::vector<double> best_x;
  std::vector<TargetResult> results;
  bool all_met = false;
  ProxyMetrics search_metrics;  // of the best point's evaluation
  ProxyMetrics confirmation;    // fresh seeds, output resolution
  std::optional<ProxyMetrics> pilot;
  int eval_width = 0, eval_height = 0;
  int evaluations = 0, rounds = 0;
  int last_rounds = 0;  // of rounds, those run as last rounds (docs/optimizer.md, "Rounds")
  double seconds = 0;
  // Why the fit ended (docs/optimize.md, "Stop reasons"): "met" (a confirmation within the
  // margin of every target), "time", "evaluations" or
  // "rounds" (that budget was spent), "blocked" (the local model can get no closer within
  // the bounds), "cancelled"; stop_reason says it in words, history round by round.
  std::string ending;
  std::string stop_reason;
  std::vector<std::string> history;
  // Stopped through options.cancel: best and search_metrics are those of the evaluations
  // done; results compare the search metrics with the targets, and
  // confirmation, pilot and blocked_by are empty.
  bool cancelled = false;
  std::vector<TraceRow> trace;
  std::vector<ConfirmationRow> confirmations;  // in order; the k-th on the k-th fresh range
  nlohmann::json ToJson() const;  // everything but the trace
};

// kInvalidArgument for an unknown algorithm, a space that does not fit the start, or no
// targets; evaluation errors (unreadable assets) end the search with their status. An
// infeasible target is not an error: the report has the closest point, met = false and
// blocked_by.
Result<OptimizeReport> Optimize(std::shared_ptr<render::AssetLibrary> library, const OptimizeOptions& options);

// A fit's outputs: the params file, optionally the trace, and beside the params the fit
// record `<stem>.fit.json` ({"fingerprint", "params_xxh64", "summary": OptimizeReport::ToJson}),
// by which a rerun recognises a fit it has done.
struct FitFiles {
  std::filesystem::path params;
  std::filesystem::path trace;  // empty: none
  std::filesystem::path Record() const;
};

// What a fit's result depends on, hashed: the project version and the search's own
// revision (raised when the search changes), the asset catalogs (`catalog_hash`), the start,
// the space's dimensions, the targets, and every option that steers the search (algorithm,
// global phase, seed, layouts, evaluation resolution, confirmation, pilot, budgets, margin,
// rounds). Not jobs, on_evaluation, on_confirmation or cancel: results are the same for any of them.
uint64_t FitFingerprint(const OptimizeOptions& options, uint64_t catalog_hash);

// Writes the params (with a $comment saying how they were found), the trace and the fit
// record, each atomically, the params file last but the record (so that a record never
// describes params that are not there). A cancelled report writes no record: its best
// point is unconfirmed.
Status WriteFit(const OptimizeReport& report, const FitFiles& files, uint64_t fingerprint,
                std::string_view comment);

// The summary of the fit recorded beside files.params when that fit had `fingerprint` and
// the params file is still the one it wrote; nullopt otherwise (no record, another
// fingerprint, params edited or missing).
std::optional<nlohmann::json> ReusableFit(const FitFiles& files, uint64_t fingerprint);

// The trace as CSV (for a path ending in .csv: one row per evaluation, metrics and every
// dimension by name) or JSON (an array of objects).
std::string TraceText(const OptimizeReport& report, const std::filesystem::path& path);

// One metric of a dataset against a target or a prediction.
struct Comparison {
  Metric metric = Metric::kObjectsPerImage;
  Estimate measured, reference;  // a target has ci95 0
  double tolerance = 0;
  bool agrees = false;  // see the two functions below
};
// Against targets: agreement is |measured - target| <= tolerance + measured.ci95: a finite
// dataset meets a target when the target is within tolerance of its 95% confidence
// interval (the acceptance over >= 2,000 images, where the CI is small, is the optimizer's
// confirmation).
std::vector<Comparison> CompareWithTargets(const ProxyMetrics& measured, const std::vector<Target>& targets);
// Against a prediction (the metrics of sampled layouts): agreement is within the default
// tolerance plus the 95% CI of the difference.
std::vector<Comparison> CompareWithPrediction(const ProxyMetrics& measured, const ProxyMetrics& predicted);

}  // namespace solid::optimizer
