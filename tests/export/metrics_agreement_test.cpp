// The dataset's proxy metrics have one home (DatasetMetrics, ShardReader::Metrics): inspect,
// index, report and `solid metrics` give the same numbers, to the last bit, on one rendered
// dataset whose scale classes are counted at another resolution than it was rendered at.
#include <gtest/gtest.h>

#include "formats/test_util.h"
#include "render/test_assets.h"
#include "solid/export/report.h"
#include "solid/formats/index.h"
#include "solid/formats/inspect.h"
#include "solid/formats/metrics.h"
#include "solid/formats/shard.h"
#include "solid/render/render_dataset.h"
#include "solid/render/sample.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

TEST(DatasetMetrics, InspectIndexReportAndMetricsAgreeExactly) {
  TempDir dir;
  const fs::path dataset = dir.path() / "d";
  render::LayoutParams params = render::LoadPreset("random-placement").value();
  params.width = 96;
  params.height = 72;
  // Classed as at 4x the pixels: a metric computed at the rendered resolution would differ.
  params.scale_width = 192;
  params.scale_height = 144;
  auto sampler = render::LayoutSampler::Create(params, render::testing::ProceduralLibrary());
  ASSERT_OK(sampler.status());
  render::RenderOptions o;
  o.out = dataset;
  o.seed = 11;
  o.images = 7;
  o.shard_size = 3;
  o.jobs = 2;
  o.shading.samples_per_pixel = 1;
  o.queries = false;
  ASSERT_OK(render::RenderDataset(**sampler, o).status());

  Result<ProxyMetrics> metrics = DatasetMetrics(dataset);
  ASSERT_OK(metrics.status());
  ASSERT_GT(metrics->visible_instances, 0);
  const nlohmann::json want = metrics->ToJson();
  ASSERT_EQ(want["images"], 7);

  Result<InspectReport> inspected = Inspect({dataset});
  ASSERT_OK(inspected.status());
  EXPECT_EQ(inspected->summary["metrics"], want);

  Result<IndexReport> indexed = Index({.dataset = dataset});
  ASSERT_OK(indexed.status());
  EXPECT_EQ(indexed->metrics.ToJson(), want);

  ReportOptions r;
  r.dataset = dataset;
  r.out = dir.path() / "r.html";
  r.samples = 0;
  r.target_row = "none";
  Result<ReportSummary> reported = WriteReport(r);
  ASSERT_OK(reported.status());
  EXPECT_EQ(reported->metrics.ToJson(), want);

  // A shard inspected alone is classed by the manifest in its provenance.
  Result<InspectReport> shard = Inspect({dataset / "shards" / "shard-000000.sqlite"});
  ASSERT_OK(shard.status());
  Result<ShardReader> reader = ShardReader::Open(dataset / "shards" / "shard-000000.sqlite");
  ASSERT_OK(reader.status());
  MetricsAccumulator alone(4);
  ASSERT_OK(reader->AddToMetrics(alone));
  EXPECT_EQ(shard->summary["metrics"], alone.Finish().ToJson());
}

}  // namespace
}  // namespace solid::exporters
