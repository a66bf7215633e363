// `solid render` as a library: datasets that validate, agree with `solid sample`, and are
// the same data whatever the shard size, thread count, interruptions or repairs.
#include "solid/render/render_dataset.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <string>

#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/index.h"
#include "solid/formats/metrics.h"
#include "solid/formats/shard.h"
#include "solid/formats/validate.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

// Small enough for the sanitizer build: 96 x 72, one sample per pixel, 48-pixel queries.
std::unique_ptr<LayoutSampler> SmallSampler(const char* preset = "random-placement") {
  LayoutParams params = LoadPreset(preset).value();
  params.width = 96;
  params.height = 72;
  return LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
}

RenderOptions SmallRender(const fs::path& out, int64_t images, int64_t shard_size, int jobs) {
  RenderOptions o;
  o.out = out;
  o.seed = 3;
  o.images = images;
  o.shard_size = shard_size;
  o.jobs = jobs;
  o.shading.samples_per_pixel = 1;
  o.query_views.long_side = 48;
  o.query_views.render_size = 82;
  o.query_views.samples_per_pixel = 1;
  o.query_shard_models = 8;
  return o;
}

testing::DatasetDigest Digest(const fs::path& root) { return testing::DigestDataset(root).value(); }

TEST(RenderDataset, ValidatesAndAgreesWithSample) {
  TempDir dir;
  const auto sampler = SmallSampler();
  const auto report = RenderDataset(*sampler, SmallRender(dir.path(), 10, 4, 2));
  ASSERT_OK(report.status());
  EXPECT_EQ(report->shards_rendered, 3);
  EXPECT_EQ(report->images + report->failed_images, 10);
  EXPECT_TRUE(report->index_built);
  EXPECT_GT(report->query_shards_rendered, 0);

  const ValidationReport validation = ValidateDataset(dir.path());
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
  EXPECT_EQ(validation.images, report->images);

  // The stored masks give the metrics `solid sample` measures on the same layouts.
  SampleOptions sample;
  sample.seed = 3;
  sample.layouts = 10;
  sample.jobs = 2;
  const SampleReport sampled = RunSample(*sampler, sample).value();
  Dataset dataset = Dataset::Open(dir.path()).value();
  MetricsAccumulator stored;
  ASSERT_OK(dataset.ForEachImage([&](const ImageRecord& image, const std::vector<InstanceRecord>& instances) {
    EXPECT_EQ(image.width, 96u);
    stored.AddImage(instances);
    return Status::Ok();
  }));
  const ProxyMetrics m = stored.Finish();
  EXPECT_EQ(m.images, sampled.metrics.images);
  EXPECT_EQ(m.visible_instances, sampled.metrics.visible_instances);
  EXPECT_DOUBLE_EQ(m.occlusion.mean, sampled.metrics.occlusion.mean);
  EXPECT_DOUBLE_EQ(m.small.mean, sampled.metrics.small.mean);

  // Every instanced model has its 8 views, long side 48.
  ASSERT_OK(dataset.ForEachImage([&](const ImageRecord&, const std::vector<InstanceRecord>& instances) {
    for (const InstanceRecord& i : instances) {
      const auto views = dataset.QueryViews(i.model_key).value();
      EXPECT_EQ(views.size(), 8u) << i.model_key;
      for (const QueryViewRecord& v : views) EXPECT_EQ(std::max(v.width, v.height), 48u);
    }
    return Status::Ok();
  }));
}

TEST(RenderDataset, JpegAndWebpImagesWithDepthDecodeToTheirSize) {
  TempDir dir;
  const auto sampler = SmallSampler();
  for (ImageFormat format : {ImageFormat::kJpeg, ImageFormat::kWebp}) {
    const fs::path out = dir.path() / std::string(ImageFormatName(format));
    RenderOptions options = SmallRender(out, 3, 4, 2);
    options.format = format;
    options.quality = 80;
    options.depth = true;
    options.queries = false;
    ASSERT_OK(RenderDataset(*sampler, options).status());
    const ValidationReport validation = ValidateDataset(out);  // decodes every image and depth map
    EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
    Dataset dataset = Dataset::Open(out).value();
    const ImageRecord image = dataset.ReadImage(0).value();
    EXPECT_EQ(image.format, format);
    ASSERT_TRUE(image.depth_exr.has_value());
    const DepthImage depth = DecodeDepthExr(*image.depth_exr).value();
    EXPECT_EQ(depth.width, 96u);
    EXPECT_EQ(depth.height, 72u);
  }
}

TEST(RenderDataset, SameDataForAnyShardSizeAndThreadCount) {
  TempDir dir;
  const auto sampler = SmallSampler();
  ASSERT_OK(RenderDataset(*sampler, SmallRender(dir.path() / "a", 9, 4, 1)).status());
  ASSERT_OK(RenderDataset(*sampler, SmallRender(dir.path() / "b", 9, 3, 2)).status());
  const auto a = Digest(dir.path() / "a");
  EXPECT_EQ(a.images.size(), 9u) << "every image has a usable layout here";
  EXPECT_EQ(a, Digest(dir.path() / "b"));
}

TEST(RenderDataset, RerunRendersOnlyMissingShardsAndRefusesOtherSettings) {
  TempDir dir;
  const auto sampler = SmallSampler();
  const RenderOptions options = SmallRender(dir.path(), 8, 4, 2);
  ASSERT_OK(RenderDataset(*sampler, options).status());
  const auto before = Digest(dir.path());

  const auto again = RenderDataset(*sampler, options);
  ASSERT_OK(again.status());
  EXPECT_EQ(again->shards_rendered, 0);
  EXPECT_EQ(again->shards_present, 2);
  EXPECT_EQ(again->query_shards_rendered, 0);

  fs::remove(DatasetPaths(dir.path()).shard(1));
  const auto resumed = RenderDataset(*sampler, options);
  ASSERT_OK(resumed.status());
  EXPECT_EQ(resumed->shards_rendered, 1);
  EXPECT_EQ(Digest(dir.path()), before);

  RenderOptions other = options;
  other.seed = 4;
  const auto refused = RenderDataset(*sampler, other);
  EXPECT_EQ(refused.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(refused.status().message().find("seed"), std::string::npos) << refused.status().message();

  // Uniform and adaptive pixels differ: a dataset begun with one does not resume with the other.
  other = options;
  other.shading.sampling = options.shading.sampling == Sampling::kAdaptive ? Sampling::kUniform : Sampling::kAdaptive;
  const auto resampled = RenderDataset(*sampler, other);
  EXPECT_EQ(resampled.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(resampled.status().message().find("sampling"), std::string::npos) << resampled.status().message();
}

TEST(RenderDataset, RepairReRendersOnlyTheDamagedShard) {
  TempDir dir;
  const auto sampler = SmallSampler();
  RenderOptions options = SmallRender(dir.path(), 8, 4, 2);
  ASSERT_OK(RenderDataset(*sampler, options).status());
  const auto before = Digest(dir.path());
  const fs::path damaged = DatasetPaths(dir.path()).shard(0), intact = DatasetPaths(dir.path()).shard(1);
  const auto intact_bytes = files::ReadFile(intact, 1 << 30).value();

  // Flip bytes of an image's encoded bytes, which its row checksum covers. (A fixed place,
  // such as the file's middle, may fall in free space between rows, which changes the
  // file's hash in the index but no row: that shard is whole, and --repair keeps it.)
  auto bytes = files::ReadFile(damaged, 1 << 30).value();
  const std::vector<uint8_t> image = [&] {
    ShardReader reader = ShardReader::Open(damaged).value();
    return reader.ReadImage(reader.ImageIds().value().front()).value().image;
  }();
  ASSERT_GT(image.size(), 64u);
  // 32 bytes from the middle of the image: within one page of the file, unless a page
  // boundary splits them; then the next 32.
  auto at = bytes.end();
  for (size_t from = image.size() / 2; at == bytes.end() && from + 32 <= image.size(); from += 32) {
    at = std::search(bytes.begin(), bytes.end(), image.begin() + static_cast<ptrdiff_t>(from),
                     image.begin() + static_cast<ptrdiff_t>(from + 32));
  }
  ASSERT_NE(at, bytes.end());
  for (auto b = at; b != at + 32; ++b) *b ^= 0x5a;
  ASSERT_OK(files::WriteFileAtomically(damaged, bytes));
  EXPECT_FALSE(ValidateDataset(dir.path()).ok());

  const auto trusted = RenderDataset(*sampler, options);
  ASSERT_OK(trusted.status());
  EXPECT_EQ(trusted->shards_rendered, 0) << "without repair a present shard is trusted";

  options.repair = true;
  const auto repaired = RenderDataset(*sampler, options);
  ASSERT_OK(repaired.status());
  EXPECT_EQ(repaired->shards_repaired, 1);
  EXPECT_TRUE(ValidateDataset(dir.path()).ok());
  EXPECT_EQ(Digest(dir.path()), before);
  EXPECT_EQ(files::ReadFile(intact, 1 << 30).value(), intact_bytes);

  // A truncated shard is repaired the same way.
  std::filesystem::resize_file(damaged, fs::file_size(damaged) / 3);
  const auto truncated = RenderDataset(*sampler, options);
  ASSERT_OK(truncated.status());
  EXPECT_EQ(truncated->shards_repaired, 1);
  EXPECT_EQ(Digest(dir.path()), before);
}

TEST(RenderDataset, ShardRangesFillOneDatasetLikeOneRun) {
  TempDir dir;
  const auto sampler = SmallSampler();
  ASSERT_OK(RenderDataset(*sampler, SmallRender(dir.path() / "whole", 9, 3, 2)).status());
  RenderOptions part = SmallRender(dir.path() / "parts", 9, 3, 1);
  for (int64_t k : {2, 0, 1}) {
    part.shards = std::pair{k, k};
    const auto r = RenderDataset(*sampler, part);
    ASSERT_OK(r.status());
    EXPECT_EQ(r->index_built, k == 1) << "the index waits for the last shard";
  }
  EXPECT_EQ(Digest(dir.path() / "parts"), Digest(dir.path() / "whole"));
  part.shards = std::pair{int64_t{3}, int64_t{3}};
  EXPECT_EQ(RenderDataset(*sampler, part).status().code(), StatusCode::kInvalidArgument);
}

// `solid render` in process: the params resolved from their source, the assets opened, and
// the query render size and texture cache derived, as RenderDataset with them set by hand.
TEST(RenderCommand, EqualsRenderDatasetWithTheDerivedSettings) {
  TempDir dir;
  RenderCommandOptions options;
  options.source.params = {.preset = "random-placement", .resolution = "96x72"};
  options.source.assets = testing::ProceduralAssetsDir();
  options.render = SmallRender(dir.path() / "command", 6, 3, 2);
  options.render.query_views.render_size = 0;  // derived
  options.render.query_views.samples_per_pixel = 0;  // derived
  const auto report = RenderCommand(options);
  ASSERT_OK(report.status());
  EXPECT_EQ(report->params.width, 96);
  EXPECT_EQ(report->render.shards_rendered, 2);
  EXPECT_EQ(report->ToJson(), report->render.ToJson());

  RenderOptions by_hand = SmallRender(dir.path() / "by-hand", 6, 3, 2);
  by_hand.query_views.render_size = QueryRenderSize(48);
  ASSERT_OK(RenderDataset(*SmallSampler(), by_hand).status());
  EXPECT_EQ(Digest(dir.path() / "command"), Digest(dir.path() / "by-hand"));
}

TEST(RenderCommand, QueryViewsRenderAt384For224StoredAndInTheSameRatioOtherwise) {
  EXPECT_EQ(QueryRenderSize(224), 384);
  EXPECT_EQ(QueryRenderSize(48), 83);
  EXPECT_EQ(QueryRenderSize(16), 28);
}

TEST(RenderCommand, WrongOptionsNameTheirField) {
  TempDir dir;
  RenderCommandOptions options;
  options.source.assets = testing::ProceduralAssetsDir();
  options.render = SmallRender(dir.path() / "d", 2, 2, 1);
  EXPECT_EQ(RenderCommand(options).status().option(), "params") << "neither a params file nor a preset";
  options.source.params.preset = "occlusion";
  options.source.params.resolution = "96x";
  EXPECT_EQ(RenderCommand(options).status().option(), "resolution");
  options.source.params.resolution = "96x72";
  options.source.params.scale_classes_at = "8x8";
  EXPECT_EQ(RenderCommand(options).status().option(), "scale_classes_at");
  options.source.params.scale_classes_at.clear();

  const auto sampler = SmallSampler();
  RenderOptions render = SmallRender(dir.path() / "d", -1, 2, 1);
  EXPECT_EQ(RenderDataset(*sampler, render).status().option(), "images");
  render = SmallRender(dir.path() / "d", 2, 0, 1);
  EXPECT_EQ(RenderDataset(*sampler, render).status().option(), "shard_size");
  render = SmallRender(dir.path() / "d", 2, 2, 1);
  render.query_shard_models = 0;
  EXPECT_EQ(RenderDataset(*sampler, render).status().option(), "query_shard_models");
  render = SmallRender(dir.path() / "d", 2, 2, 1);
  render.queries = false;
  render.shards = std::pair<int64_t, int64_t>{1, 1};
  const Status shards = RenderDataset(*sampler, render).status();
  EXPECT_EQ(shards.option(), "shards");
  EXPECT_EQ(shards.message(), "shards: 1-1: the dataset has shards 0-0 (2 images of 2)");
}

TEST(RenderCommand, ShardRangesParseOrNameTheirField) {
  EXPECT_EQ(ParseShardRange("shards", "3-7").value(), (std::pair<int64_t, int64_t>{3, 7}));
  EXPECT_EQ(ParseShardRange("shards", "0-0").value(), (std::pair<int64_t, int64_t>{0, 0}));
  for (const char* bad : {"7-3", "-1-2", "3", "3-", "3-4x", "a-b"}) {
    const Status status = ParseShardRange("shards", bad).status();
    EXPECT_EQ(status.option(), "shards") << bad;
    EXPECT_EQ(status.message(), fmt::format("shards: {}: expected FIRST-LAST, e.g. 0-15", bad));
  }
}

// Restores an environment variable when the test ends.
class ScopedVariable {
 public:
  ScopedVariable(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value != nullptr) {
      ::setenv(name, value, 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedVariable() {
    if (old_) {
      ::setenv(name_, old_->c_str(), 1);
    } else {
      ::unsetenv(name_);
    }
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

TEST(RenderCommand, TheSchedulersArrayIndexIsTheShard) {
  {
    ScopedVariable slurm("SLURM_ARRAY_TASK_ID", nullptr), kubernetes("JOB_COMPLETION_INDEX", nullptr);
    EXPECT_FALSE(ShardFromEnvironment().value().has_value());
  }
  {
    ScopedVariable slurm("SLURM_ARRAY_TASK_ID", "4"), kubernetes("JOB_COMPLETION_INDEX", "9");
    const auto shard = ShardFromEnvironment().value();
    ASSERT_TRUE(shard.has_value());
    EXPECT_EQ(shard->shard, 4);
    EXPECT_EQ(shard->variable, "SLURM_ARRAY_TASK_ID");
  }
  {
    ScopedVariable slurm("SLURM_ARRAY_TASK_ID", ""), kubernetes("JOB_COMPLETION_INDEX", "9");
    EXPECT_EQ(ShardFromEnvironment().value()->variable, "JOB_COMPLETION_INDEX");
  }
  {
    ScopedVariable slurm("SLURM_ARRAY_TASK_ID", "-1"), kubernetes("JOB_COMPLETION_INDEX", nullptr);
    const Status status = ShardFromEnvironment().status();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(status.message(), "SLURM_ARRAY_TASK_ID=-1: not a shard index");
  }
}

// `solid sample` in process: the same report as RunSample on a sampler made by hand, or
// the one layout exported.
TEST(SampleCommand, EqualsRunSampleOrExportsOneLayout) {
  TempDir dir;
  SampleCommandOptions options;
  options.source.params = {.preset = "random-placement", .resolution = "96x72"};
  options.source.assets = testing::ProceduralAssetsDir();
  options.sample.seed = 5;
  options.sample.first = 3;
  options.sample.layouts = 6;
  options.sample.jobs = 2;
  const auto report = SampleCommand(options);
  ASSERT_OK(report.status());
  ASSERT_TRUE(report->sample.has_value());
  SampleOptions by_hand = options.sample;
  by_hand.jobs = 1;
  const auto expected = RunSample(*SmallSampler(), by_hand);
  ASSERT_OK(expected.status());
  nlohmann::json got = report->ToJson(), want = expected->ToJson();
  for (const char* timing : {"seconds", "sample_ms_per_layout", "mask_ms_per_layout"}) {
    got.erase(timing);
    want.erase(timing);
  }
  EXPECT_EQ(got["params"], ParamsToJson(SmallSampler()->params()));
  EXPECT_EQ(got["seed"], 5);
  EXPECT_EQ(got["first"], 3);
  for (const char* added : {"params", "seed", "first"}) got.erase(added);
  EXPECT_EQ(got, want);

  options.export_scene = 4;
  EXPECT_EQ(SampleCommand(options).status().option(), "export_path");
  options.export_path = dir.path() / "scene.glb";
  const auto exported = SampleCommand(options);
  ASSERT_OK(exported.status());
  ASSERT_TRUE(exported->exported.has_value());
  EXPECT_FALSE(exported->sample.has_value());
  EXPECT_EQ(exported->exported->index, 4);
  EXPECT_GT(exported->exported->objects, 0u);
  EXPECT_GT(fs::file_size(options.export_path), 0u);
  options.export_scene = -1;
  EXPECT_EQ(SampleCommand(options).status().option(), "export_scene");
}

TEST(SampleCommand, WrongOptionsNameTheirField) {
  const auto sampler = SmallSampler();
  SampleOptions options;
  options.layouts = -1;
  EXPECT_EQ(RunSample(*sampler, options).status().option(), "layouts");
  options.layouts = 1;
  options.first = -1;
  EXPECT_EQ(RunSample(*sampler, options).status().option(), "first");
}

}  // namespace
}  // namespace solid::render
