// Issue 23, render side: a resume trusts a present shard only when its provenance is the
// dataset's, `--repair` re-renders whatever validate rejects and leaves good shards'
// bytes alone, and a directory without a manifest is adopted only on request.
#include <gtest/gtest.h>

#include <fstream>

#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/index.h"
#include "solid/formats/validate.h"
#include "solid/render/render_dataset.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

const LayoutSampler& Sampler() {
  static const std::unique_ptr<LayoutSampler> sampler = [] {
    LayoutParams params = LoadPreset("random-placement").value();
    params.width = 64;
    params.height = 48;
    return LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
  }();
  return *sampler;
}

// 4 images in shards of 2 at 64 x 48, one sample per pixel.
RenderOptions Tiny(const fs::path& out, uint64_t seed, bool queries = false) {
  RenderOptions o;
  o.out = out;
  o.seed = seed;
  o.images = 4;
  o.shard_size = 2;
  o.jobs = 2;
  o.shading.samples_per_pixel = 1;
  o.queries = queries;
  o.query_views.views = 2;
  o.query_views.long_side = 24;
  o.query_views.render_size = 41;
  o.query_views.samples_per_pixel = 1;
  o.query_shard_models = 8;
  return o;
}

std::vector<uint8_t> Bytes(const fs::path& p) { return files::ReadFile(p, 1 << 30).value(); }

bool Says(const Status& s, std::string_view a, std::string_view b = "") {
  return s.message().find(a) != std::string::npos && s.message().find(b) != std::string::npos;
}

class Provenance : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK(RenderDataset(Sampler(), Tiny(ours_, 3, true)).status());
    reference_ = testing::DigestDataset(ours_).value();
  }

  void ExpectTheReference() {
    ASSERT_TRUE(ValidateDataset(ours_).ok()) << ValidateDataset(ours_).ToJson().dump(2);
    EXPECT_EQ(testing::DigestDataset(ours_).value(), reference_);
  }

  TempDir dir_;
  const fs::path ours_ = dir_.path() / "ours";
  testing::DatasetDigest reference_;
};

// The F1: with manifest.json lost, a render with another seed adopted every shard
// ("6 already present"), wrote its own manifest and index, and exited 0.
TEST_F(Provenance, F1_ShardsWithoutAManifestAreRefusedUnlessAdopted) {
  fs::remove(DatasetPaths(ours_).manifest());
  const auto refused = RenderDataset(Sampler(), Tiny(ours_, 4, true));
  EXPECT_EQ(refused.status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(Says(refused.status(), "no manifest.json, but", "RenderOptions::adopt rebuilds the manifest"))
      << refused.status().message();
  EXPECT_FALSE(fs::exists(DatasetPaths(ours_).manifest()));

  RenderOptions adopt = Tiny(ours_, 4, true);
  adopt.adopt = true;
  std::vector<std::string> notes;
  adopt.on_note = [&](const std::string& line) { notes.push_back(line); };
  const auto other_seed = RenderDataset(Sampler(), adopt);
  EXPECT_EQ(other_seed.status().code(), StatusCode::kAlreadyExists);
  EXPECT_TRUE(Says(other_seed.status(), "seed 0x0000000000000003 vs 0x0000000000000004")) << other_seed.status().message();
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("adopted the provenance of 2 shard(s) and"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("seed 0x0000000000000003, 4 images in shards of 2"), std::string::npos) << notes[0];

  fs::remove(DatasetPaths(ours_).manifest());
  adopt.seed = 3;
  const auto same_seed = RenderDataset(Sampler(), adopt);
  ASSERT_OK(same_seed.status());
  EXPECT_TRUE(same_seed->adopted);
  EXPECT_EQ(same_seed->shards_rendered, 0);
  EXPECT_EQ(same_seed->shards_present, 2);
  ExpectTheReference();
}

// The F1 (resume): a shard and a query shard of a seed-4 dataset in a seed-3 one.
TEST_F(Provenance, F1_AShardOfAnotherDatasetIsRefusedAndRepaired) {
  const fs::path theirs = dir_.path() / "theirs";
  ASSERT_OK(RenderDataset(Sampler(), Tiny(theirs, 4, true)).status());
  const DatasetPaths ours(ours_), other(theirs);
  fs::copy_file(other.shard(1), ours.shard(1), fs::copy_options::overwrite_existing);
  const std::vector<uint8_t> good = Bytes(ours.shard(0));

  const auto refused = RenderDataset(Sampler(), Tiny(ours_, 3, true));
  EXPECT_EQ(refused.status().code(), StatusCode::kCorrupt);
  EXPECT_TRUE(Says(refused.status(), "shard-000001.sqlite: not this dataset's shard",
                   "seed 0x0000000000000004 in the shard, 0x0000000000000003 in the manifest"))
      << refused.status().message();
  EXPECT_TRUE(Says(refused.status(), "RenderOptions::repair re-renders it")) << refused.status().message();

  RenderOptions repair = Tiny(ours_, 3, true);
  repair.repair = true;
  const auto repaired = RenderDataset(Sampler(), repair);
  ASSERT_OK(repaired.status());
  EXPECT_EQ(repaired->shards_repaired, 1);
  EXPECT_EQ(Bytes(ours.shard(0)), good) << "a good shard keeps its bytes";
  ExpectTheReference();

  const ShardListing queries_there = ListShards(theirs).value();
  ASSERT_FALSE(queries_there.queries.empty());
  const int64_t q = queries_there.queries.front().index;
  ASSERT_TRUE(fs::exists(ours.query_shard(q))) << "both datasets use the same models";
  fs::copy_file(other.query_shard(q), ours.query_shard(q), fs::copy_options::overwrite_existing);
  EXPECT_EQ(RenderDataset(Sampler(), Tiny(ours_, 3, true)).status().code(), StatusCode::kCorrupt);
  const auto queries = RenderDataset(Sampler(), repair);
  ASSERT_OK(queries.status());
  EXPECT_EQ(queries->query_shards_repaired, 1);
  EXPECT_EQ(queries->shards_repaired, 0);
  ExpectTheReference();
}

// The F2: shard 1's file saved as shard 0; --repair and index failed on a UNIQUE
// constraint ("bad flags") and re-rendered nothing.
TEST_F(Provenance, F2_AShardHoldingAnotherShardsRowsIsRepaired) {
  const DatasetPaths ours(ours_);
  fs::copy_file(ours.shard(1), ours.shard(0), fs::copy_options::overwrite_existing);
  fs::remove(ours.index());
  const Result<IndexReport> index = BuildIndex(ours_);
  ASSERT_OK(index.status());
  ASSERT_EQ(index->skipped.size(), 1u);
  EXPECT_TRUE(Says(index->skipped[0], "shard-000000.sqlite", "shard_index 1 in the shard, 0 by its file name"))
      << index->skipped[0].message();

  RenderOptions repair = Tiny(ours_, 3, true);
  repair.repair = true;
  const auto repaired = RenderDataset(Sampler(), repair);
  ASSERT_OK(repaired.status());
  EXPECT_EQ(repaired->shards_repaired, 1);
  EXPECT_TRUE(repaired->index_built);
  ExpectTheReference();
}

// The F4: a directory named shards/shard-000001.sqlite counted as a present shard
// (exit 0), and --repair failed to rename over it.
TEST_F(Provenance, F4_ADirectoryInPlaceOfAShardIsRefusedAndReplaced) {
  const DatasetPaths ours(ours_);
  fs::remove(ours.shard(1));
  fs::create_directories(ours.shard(1));
  { std::ofstream(ours.shard(1) / "x") << "x"; }
  const auto refused = RenderDataset(Sampler(), Tiny(ours_, 3, true));
  EXPECT_EQ(refused.status().code(), StatusCode::kCorrupt);
  EXPECT_TRUE(Says(refused.status(), "shard-000001.sqlite: not this dataset's shard: not a regular file"))
      << refused.status().message();
  EXPECT_NE(ValidateDataset(ours_).ToJson().dump().find("named as a shard, but not a regular file"),
            std::string::npos);
  const Result<IndexReport> index = BuildIndex(ours_);
  ASSERT_OK(index.status());
  ASSERT_EQ(index->skipped.size(), 1u);
  EXPECT_TRUE(Says(index->skipped[0], "shard-000001.sqlite: named as a shard, but not a regular file"));

  RenderOptions repair = Tiny(ours_, 3, true);
  repair.repair = true;
  const auto repaired = RenderDataset(Sampler(), repair);
  ASSERT_OK(repaired.status());
  EXPECT_EQ(repaired->shards_repaired, 1);
  EXPECT_TRUE(fs::is_regular_file(ours.shard(1)));
  ExpectTheReference();
}

}  // namespace
}  // namespace solid::render
