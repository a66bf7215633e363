// The fitted loop end to end, at reduced sizes: fit, render the fitted params, measure the
// dataset; and targets matched from the dataset's own COCO export. Output at 80x60 with
// scale classes counted as at 640x480 (render.scale_classes_at), one sample per pixel and
// no query views, so that the renders stay cheap under the sanitizers.
#include <gtest/gtest.h>

#include <cmath>
#include <tuple>
#include <utility>
#include <vector>

#include "formats/test_util.h"
#include "render/test_assets.h"
#include "solid/export/coco.h"
#include "solid/optimizer/coco_targets.h"
#include "solid/optimizer/optimize.h"
#include "solid/render/render_dataset.h"

namespace solid::optimizer {
namespace {

render::LayoutParams SmallOutput(std::string_view preset) {
  render::LayoutParams p = render::LoadPreset(preset).value();
  std::tie(p.scale_width, p.scale_height) = render::ScaleClassResolution(p);
  p.width = 80;
  p.height = 60;
  return p;
}

Result<render::RenderReport> Render(const render::LayoutParams& params, const std::filesystem::path& out,
                                    int64_t images) {
  SOLID_ASSIGN_OR_RETURN(std::unique_ptr<render::LayoutSampler> sampler,
                         render::LayoutSampler::Create(params, render::testing::ProceduralLibrary()));
  render::RenderOptions options;
  options.out = out;
  options.images = images;
  options.shard_size = 32;
  options.jobs = 2;
  options.shading.samples_per_pixel = 1;
  options.queries = false;
  return render::RenderDataset(*sampler, options);
}

// A fit at the small output: masks at the output resolution (so no "output" evaluation),
// 40 layouts, 200 fresh ones, two rounds, bounded by evaluations.
OptimizeOptions SmallFit(const render::LayoutParams& start, std::vector<Target> targets) {
  OptimizeOptions o;
  o.start = start;
  o.space = SearchSpace::FitKnobs(start);
  o.targets = std::move(targets);
  o.layouts = 40;
  o.eval_width = start.width;
  o.eval_height = start.height;
  o.confirm_layouts = 200;
  o.max_evaluations = 60;
  o.max_seconds = 600;  // a loaded sanitizer run must not cut it short
  o.max_rounds = 2;
  o.jobs = 2;
  return o;
}

// A dataset is image i = layout i of its seed, through the same mask pass: its stored
// masks give exactly the metrics the optimizer's evaluation of those layouts measures.
TEST(FittedLoop, RenderedDatasetHasExactlyTheMetricsOfItsLayoutsEvaluated) {
  const render::LayoutParams params = SmallOutput("more-objects");
  solid::testing::TempDir dir;
  ASSERT_OK(Render(params, dir.path() / "ds", 48).status());
  Result<ProxyMetrics> stored = DatasetMetrics(dir.path() / "ds");
  ASSERT_OK(stored.status());
  Result<Evaluation> evaluated =
      Evaluate(params, render::testing::ProceduralLibrary(), {1, 0, 48, 0, 0, 2});  // seed 1, the output resolution
  ASSERT_OK(evaluated.status());
  EXPECT_EQ(stored->images, evaluated->metrics.images);
  EXPECT_EQ(stored->visible_instances, evaluated->metrics.visible_instances);
  for (Metric m : {Metric::kObjectsPerImage, Metric::kOcclusion, Metric::kSmall, Metric::kMedium, Metric::kLarge}) {
    EXPECT_DOUBLE_EQ(MetricOf(*stored, m).mean, MetricOf(evaluated->metrics, m).mean) << MetricName(m);
  }
}

// The main job's sequence: optimize to targets, render the fitted params, and the dataset's
// metrics agree with the optimizer's confirmation (the default tolerance plus the CIs). The
// targets are a reachable point's (more attempts, less occlusion than the preset), measured
// on fresh layouts: at 80x60 the procedural assets do not reach the more-objects row itself.
TEST(FittedLoop, FittedParamsReachTheRenderAndItsMetricsAgreeWithTheConfirmation) {
  render::LayoutParams goal = SmallOutput("more-objects");
  goal.attempts = {24, 28};
  goal.occlude_prob = 0.4;
  Result<Evaluation> at_goal =
      Evaluate(goal, render::testing::ProceduralLibrary(), {7, kConfirmFirst + 100000, 200, 0, 0, 2});
  ASSERT_OK(at_goal.status());
  std::vector<Target> targets;
  for (Metric m : {Metric::kObjectsPerImage, Metric::kOcclusion, Metric::kSmall, Metric::kMedium, Metric::kLarge}) {
    targets.push_back({m, MetricOf(at_goal->metrics, m).mean, 4 * DefaultTolerance(m)});
  }
  OptimizeOptions o = SmallFit(SmallOutput("more-objects"), targets);
  Result<OptimizeReport> fit = Optimize(render::testing::ProceduralLibrary(), o);
  ASSERT_OK(fit.status());
  EXPECT_TRUE(fit->all_met) << fit->ToJson().dump(1);
  solid::testing::TempDir dir;
  const FitFiles files{dir.path() / "fitted.json", {}};
  ASSERT_OK(WriteFit(*fit, files, FitFingerprint(o, 0), "test"));
  Result<render::LayoutParams> fitted = render::LoadParamsFile(files.params);
  ASSERT_OK(fitted.status());
  EXPECT_EQ(*fitted, fit->best);
  ASSERT_OK(Render(*fitted, dir.path() / "ds", 96).status());
  Result<ProxyMetrics> measured = DatasetMetrics(dir.path() / "ds");
  ASSERT_OK(measured.status());
  EXPECT_EQ(measured->images, 96);
  for (const Comparison& c : CompareWithPrediction(*measured, fit->confirmation)) {
    EXPECT_TRUE(c.agrees) << MetricName(c.metric) << ": dataset " << c.measured.mean << " +- " << c.measured.ci95
                          << ", confirmation " << c.reference.mean << " +- " << c.reference.ci95;
  }
}

// `--match-coco` on the dataset's own export: the derived count and shares are the
// dataset's metrics exactly, and a fit to them from another start lands on them.
TEST(FittedLoop, TargetsMatchedFromTheDatasetsCocoExportAreItsMetricsAndAreReached) {
  const render::LayoutParams params = SmallOutput("more-objects");
  solid::testing::TempDir dir;
  ASSERT_OK(Render(params, dir.path() / "ds", 96).status());
  exporters::CocoExportOptions coco;
  coco.dataset = dir.path() / "ds";
  coco.out_dir = dir.path() / "coco";
  coco.masks = exporters::CocoMasks::kVisible;
  ASSERT_OK(exporters::ExportCoco(coco).status());
  CocoMatchOptions match_options;
  std::tie(match_options.width, match_options.height) = render::ScaleClassResolution(params);
  Result<CocoMatch> match = TargetsFromCoco(dir.path() / "coco" / "annotations.json", match_options);
  ASSERT_OK(match.status());
  Result<ProxyMetrics> own = DatasetMetrics(dir.path() / "ds");
  ASSERT_OK(own.status());
  EXPECT_EQ(match->images, own->images);
  EXPECT_EQ(match->annotations, own->visible_instances);
  EXPECT_DOUBLE_EQ(match->objects_per_image.mean, own->objects_per_image.mean);
  EXPECT_DOUBLE_EQ(match->small.mean, own->small.mean);
  EXPECT_DOUBLE_EQ(match->medium.mean, own->medium.mean);
  EXPECT_DOUBLE_EQ(match->large.mean, own->large.mean);

  render::LayoutParams start = params;
  start.attempts = {12, 14};  // a start far below the dataset's count
  OptimizeOptions o = SmallFit(start, match->targets);
  // The dataset's own sampling error (96 images) comes on top of the acceptance.
  for (Target& t : o.targets) t.tolerance = 2 * DefaultTolerance(t.metric) + MetricOf(*own, t.metric).ci95;
  Result<OptimizeReport> fit = Optimize(render::testing::ProceduralLibrary(), o);
  ASSERT_OK(fit.status());
  ASSERT_FALSE(fit->trace.empty());
  EXPECT_GT(std::abs(fit->trace.front().metrics.objects_per_image.mean - match->objects_per_image.mean),
            o.targets[0].tolerance)
      << "the start should be outside the count's tolerance";
  EXPECT_TRUE(fit->all_met) << fit->ToJson().dump(1);
}

}  // namespace
}  // namespace solid::optimizer
