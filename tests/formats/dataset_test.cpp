#include "solid/formats/dataset.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fixtures/layered_dataset.h"
#include "formats/test_util.h"
#include "solid/formats/file_lock.h"
#include "solid/formats/files.h"
#include "solid/formats/index.h"
#include "solid/formats/inspect.h"
#include "solid/formats/validate.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using fixtures::LayeredDatasetOptions;
using testing::TempDir;

TEST(Manifest, RoundTripsThroughJson) {
  Manifest m = fixtures::LayeredManifest({});
  m.seed = 0xfedcba9876543210ULL;
  m.generator_version = "9.9.9";
  auto parsed = Manifest::Parse(m.ToJson().dump(2), "manifest.json");
  ASSERT_OK(parsed.status());
  EXPECT_EQ(ManifestDifference(m, *parsed), "");
  EXPECT_EQ(parsed->seed, 0xfedcba9876543210ULL);
}

TEST(Manifest, UnknownKeyIsAnErrorWithItsLocation) {
  nlohmann::json j = fixtures::LayeredManifest({}).ToJson();
  j["shard_sise"] = 3;
  auto parsed = Manifest::Parse(j.dump(2), "manifest.json");
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.status().message().find("manifest.json"), std::string::npos) << parsed.status().message();
  EXPECT_NE(parsed.status().message().find("shard_sise"), std::string::npos) << parsed.status().message();
}

TEST(Manifest, TamperedParamsAreDetected) {
  nlohmann::json j = fixtures::LayeredManifest({}).ToJson();
  j["params"]["max_objects"] = 99;
  auto parsed = Manifest::Parse(j.dump(), "manifest.json");
  EXPECT_EQ(parsed.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(parsed.status().message().find("params_hash"), std::string::npos);
}

TEST(Manifest, DifferenceNamesWhatDiffers) {
  Manifest a = fixtures::LayeredManifest({}), b = a;
  b.seed = 7;
  b.width = 320;
  std::string diff = ManifestDifference(a, b);
  EXPECT_NE(diff.find("seed"), std::string::npos);
  EXPECT_NE(diff.find("width"), std::string::npos);
  EXPECT_EQ(diff.find("height"), std::string::npos);
}

TEST(Dataset, FixtureDatasetValidatesAndReadsBack) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 10;
  options.shard_size = 4;
  options.depth = true;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  ValidationReport report = ValidateDataset(dir.path());
  for (const auto& p : report.problems) ADD_FAILURE() << p.location << ": " << p.message;
  EXPECT_TRUE(report.ok());
  EXPECT_EQ(report.shards, 3);
  EXPECT_EQ(report.images, 10);
  EXPECT_EQ(report.query_views, 8 * options.models);

  auto dataset = Dataset::Open(dir.path());
  ASSERT_OK(dataset.status());
  EXPECT_EQ(dataset->shards().targets.size(), 3u);
  for (int64_t id = 0; id < options.images; ++id) {
    auto expected = fixtures::MakeLayeredImage(options, id);
    ASSERT_OK(expected.status());
    auto image = dataset->ReadImage(id);
    ASSERT_OK(image.status());
    EXPECT_EQ(image->image, expected->image.image);
    auto instances = dataset->Instances(id);
    ASSERT_OK(instances.status());
    ASSERT_EQ(instances->size(), expected->instances.size());
  }
  int64_t walked = 0;
  ASSERT_OK(dataset->ForEachImage([&](const ImageRecord& im, const std::vector<InstanceRecord>&) {
    EXPECT_EQ(im.image_id, walked++);
    return Status::Ok();
  }));
  EXPECT_EQ(walked, options.images);
  EXPECT_EQ(dataset->ReadImage(99).status().code(), StatusCode::kNotFound);
}

TEST(Dataset, LookupsByModelAgreeWithAndWithoutTheIndex) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 12;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  for (int model = 0; model < options.models; ++model) {
    std::string key = "fixture/model-0" + std::to_string(model);
    auto with_index = Dataset::Open(dir.path());
    ASSERT_OK(with_index.status());
    auto indexed = with_index->OccurrencesOfModel(key);
    ASSERT_OK(indexed.status());
    fs::rename(DatasetPaths(dir.path()).index(), dir.path() / "index.bak");
    auto without_index = Dataset::Open(dir.path());
    ASSERT_OK(without_index.status());
    auto scanned = without_index->OccurrencesOfModel(key);
    ASSERT_OK(scanned.status());
    fs::rename(dir.path() / "index.bak", DatasetPaths(dir.path()).index());
    ASSERT_EQ(indexed->size(), scanned->size()) << key;
    int64_t total = 0;
    for (size_t i = 0; i < indexed->size(); ++i) {
      EXPECT_EQ((*indexed)[i].image_id, (*scanned)[i].image_id);
      EXPECT_EQ((*indexed)[i].shard_index, (*scanned)[i].shard_index);
      EXPECT_EQ((*indexed)[i].instances, (*scanned)[i].instances);
      total += (*indexed)[i].instances;
    }
    auto instances = with_index->InstancesOfModel(key);
    ASSERT_OK(instances.status());
    EXPECT_EQ(static_cast<int64_t>(instances->size()), total);
    for (const auto& in : *instances) EXPECT_EQ(in.model_key, key);
    auto views = with_index->QueryViews(key);
    ASSERT_OK(views.status());
    EXPECT_EQ(views->size(), 8u);
  }
}

// Image i depends only on (seed, i): the shard size changes nothing in its bytes.
TEST(Dataset, ImageBytesDoNotDependOnShardSize) {
  TempDir a, b;
  LayeredDatasetOptions options;
  options.images = 7;
  options.shard_size = 2;
  ASSERT_OK(fixtures::WriteLayeredDataset(a.path(), options));
  options.shard_size = 5;
  ASSERT_OK(fixtures::WriteLayeredDataset(b.path(), options));
  auto da = Dataset::Open(a.path());
  auto db = Dataset::Open(b.path());
  ASSERT_OK(da.status());
  ASSERT_OK(db.status());
  for (int64_t id = 0; id < options.images; ++id) {
    auto ia = da->ReadImage(id);
    auto ib = db->ReadImage(id);
    ASSERT_OK(ia.status());
    ASSERT_OK(ib.status());
    EXPECT_EQ(ia->image, ib->image);
    EXPECT_EQ(ia->seed, ib->seed);
  }
}

TEST(Index, IsRebuiltFromShardsAndStaleIndexIsReported) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 8;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  auto report = BuildIndex(dir.path());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->shards, 2);
  EXPECT_EQ(report->images, 8);
  EXPECT_EQ(report->models, options.models);
  EXPECT_TRUE(report->skipped.empty());
  EXPECT_EQ(report->metrics.images, 8);
  auto diffs = CompareIndex(dir.path());
  ASSERT_OK(diffs.status());
  EXPECT_TRUE(diffs->empty());

  // A shard removed after indexing: the index no longer agrees.
  fs::remove(DatasetPaths(dir.path()).shard(1));
  diffs = CompareIndex(dir.path());
  ASSERT_OK(diffs.status());
  ASSERT_FALSE(diffs->empty());
  ValidationReport validation = ValidateDataset(dir.path());
  EXPECT_FALSE(validation.ok());
  ASSERT_OK(BuildIndex(dir.path()).status());
  EXPECT_TRUE(ValidateDataset(dir.path()).ok());
}

// Shards not published yet (a render under way): the index covers the others, names the
// missing ones as ranges, and ignores writers' temporaries and lock files.
TEST(Index, NamesMissingShardsAndIgnoresTemporariesAndLocks) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 14;
  options.shard_size = 2;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  const DatasetPaths paths(dir.path());
  for (int k : {0, 3, 4, 6}) {
    fs::rename(paths.shard(k), files::TempPathFor(paths.shard(k)));
  }
  { std::ofstream(files::LockPathFor(paths.shard(3))) << ""; }
  auto report = BuildIndex(dir.path());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->shards, 3);
  EXPECT_EQ(report->images, 6);
  EXPECT_TRUE(report->skipped.empty());
  const std::vector<std::pair<int64_t, int64_t>> missing = {{0, 0}, {3, 4}, {6, 6}};
  EXPECT_EQ(report->missing_shards, missing);
}

TEST(Index, MetricsMatchAFreshAccumulation) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 9;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  MetricsAccumulator expected;
  for (int64_t id = 0; id < options.images; ++id) {
    auto image = fixtures::MakeLayeredImage(options, id);
    ASSERT_OK(image.status());
    expected.AddImage(image->instances);
  }
  ProxyMetrics want = expected.Finish();
  auto report = BuildIndex(dir.path());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->metrics.visible_instances, want.visible_instances);
  EXPECT_NEAR(report->metrics.objects_per_image.mean, want.objects_per_image.mean, 1e-12);
  EXPECT_NEAR(report->metrics.occlusion.mean, want.occlusion.mean, 1e-12);
  EXPECT_NEAR(report->metrics.small.mean + report->metrics.medium.mean + report->metrics.large.mean, 1.0, 1e-12);
  auto inspection = Inspect({dir.path()});
  ASSERT_OK(inspection.status());
  EXPECT_EQ(inspection->summary["totals"]["images"], 9);
  EXPECT_NEAR(inspection->summary["metrics"]["occlusion"]["mean"].get<double>(), want.occlusion.mean, 1e-12);
  std::string text = inspection->ToText();
  EXPECT_NE(text.find("objects per image"), std::string::npos) << text;
}

TEST(Validate, FindsInconsistentFieldsWithTheirLocation) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 4;
  Manifest manifest = fixtures::LayeredManifest(options);
  ASSERT_OK(CreateDataset(dir.path(), manifest));
  auto image = fixtures::MakeLayeredImage(options, 2);
  ASSERT_OK(image.status());
  {
    auto writer = ShardWriter::Create(DatasetPaths(dir.path()).shard(0));
    ASSERT_OK(writer.status());
    ASSERT_OK(WriteProvenance(*writer, manifest, 0));
    ASSERT_OK(writer->AddImage(image->image));
    // Well-formed rows whose values disagree with their masks.
    InstanceRecord bad_box = image->instances[0];
    bad_box.visible_box.w += 1;
    InstanceRecord bad_occlusion = image->instances[0];
    bad_occlusion.ordinal = 1;
    bad_occlusion.occlusion = 0.5 * bad_occlusion.occlusion.value_or(0) + 0.25;
    InstanceRecord bad_rle = image->instances[0];
    bad_rle.ordinal = 2;
    bad_rle.full_rle = "0" + bad_rle.full_rle;
    InstanceRecord not_contained = image->instances[0];
    not_contained.ordinal = 3;
    std::swap(not_contained.visible_rle, not_contained.full_rle);
    std::swap(not_contained.visible_area, not_contained.full_area);
    std::swap(not_contained.visible_box, not_contained.full_box);
    for (const auto* in : {&bad_box, &bad_occlusion, &bad_rle, &not_contained}) ASSERT_OK(writer->AddInstance(*in));
    ASSERT_OK(writer->Commit());
  }
  ASSERT_OK(BuildIndex(dir.path()).status());
  ValidationReport report = ValidateDataset(dir.path());
  ASSERT_FALSE(report.ok());
  auto has = [&](std::string_view location_part, std::string_view message_part) {
    for (const auto& p : report.problems) {
      if (p.location.find(location_part) != std::string::npos && p.message.find(message_part) != std::string::npos) {
        return true;
      }
    }
    return false;
  };
  EXPECT_TRUE(has("shard-000000.sqlite: instances (image 2 #0): visible_box", "the mask gives"));
  EXPECT_TRUE(has("(image 2 #1): occlusion", "(full - visible) / full"));
  EXPECT_TRUE(has("(image 2 #2): full_rle", ""));
  if (image->instances[0].visible_area != image->instances[0].full_area) {
    EXPECT_TRUE(has("(image 2 #3): full_rle", "does not contain"));
  }
  nlohmann::json j = report.ToJson();
  EXPECT_FALSE(j["ok"].get<bool>());
}

TEST(Validate, ReportsMissingIndexAndStrayFiles) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.images = 4;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  fs::remove(DatasetPaths(dir.path()).index());
  { std::ofstream(DatasetPaths(dir.path()).shards_dir() / "notes.txt") << "x"; }
  ValidationReport report = ValidateDataset(dir.path());
  ASSERT_EQ(report.problems.size(), 2u);
  EXPECT_NE(report.problems[0].location.find("notes.txt"), std::string::npos);
  EXPECT_NE(report.problems[1].message.find("BuildIndex builds it"), std::string::npos);
}

}  // namespace
}  // namespace solid
