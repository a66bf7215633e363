// Hostile input (issue 8, "Limits and hostile input"): documented limits refuse oversized
// input with kLimitExceeded naming the input and the limit, and paths read from data
// stay inside the directory they belong to (docs/limits.md).
#include <gtest/gtest.h>

#include <sqlite3.h>

#include <fstream>
#include <string>

#include "fixtures/crafted_images.h"
#include "fixtures/layered_dataset.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/shard.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

bool Contains(const Status& s, std::string_view part) { return s.message().find(part) != std::string::npos; }

void Touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "x";
}

// --- paths from data ------------------------------------------------------------------

TEST(ResolveInside, AcceptsPathsBelowTheRoot) {
  TempDir dir;
  Touch(dir.path() / "models" / "a.glb");
  auto r = files::ResolveInside(dir.path(), "models/./x/../a.glb");
  ASSERT_OK(r.status());
  EXPECT_EQ(*r, (dir.path() / "models" / "a.glb").lexically_normal());
  // Not there yet: judged on its lexical form (its reader reports it missing).
  EXPECT_OK(files::ResolveInside(dir.path(), "models/b.glb").status());
  // A link that stays inside is fine.
  fs::create_symlink("a.glb", dir.path() / "models" / "alias.glb");
  EXPECT_OK(files::ResolveInside(dir.path(), "models/alias.glb").status());
}

TEST(ResolveInside, RefusesAbsoluteDotDotAndEscapingLinks) {
  TempDir dir;
  const fs::path root = dir.path() / "assets";
  Touch(root / "models" / "a.glb");
  Touch(dir.path() / "secret.txt");
  fs::create_symlink(dir.path() / "secret.txt", root / "models" / "leak.glb");
  fs::create_symlink(dir.path(), root / "up");
  fs::create_symlink(dir.path() / "nowhere", root / "models" / "dangling.glb");
  const std::pair<std::string, std::string> cases[] = {
      {(dir.path() / "secret.txt").string(), "is absolute"},
      {"../secret.txt", "leaves"},
      {"models/../../secret.txt", "leaves"},
      {"", "is empty"},
      {".", "itself"},
      {"models/leak.glb", "through a symbolic link"},
      {"up/secret.txt", "through a symbolic link"},
      {"models/dangling.glb", "dangling symbolic link"},
      {std::string("models/a.glb\0/x", 15), "NUL"},
  };
  for (const auto& [relative, why] : cases) {
    auto r = files::ResolveInside(root, relative);
    ASSERT_FALSE(r.ok()) << relative;
    EXPECT_EQ(r.status().code(), StatusCode::kCorrupt) << r.status().ToString();
    EXPECT_TRUE(Contains(r.status(), why)) << r.status().ToString();
  }
}

TEST(ListShards, ShardLinksLeadingOutOfTheDatasetAreNeverOpened) {
  TempDir dir;
  fixtures::LayeredDatasetOptions options;
  options.images = 4;
  options.shard_size = 2;
  options.queries = false;
  const fs::path root = dir.path() / "ds";
  ASSERT_OK(fixtures::WriteLayeredDataset(root, options));
  // Shard 1 moves out of the dataset and a link takes its place; shard 0 is linked
  // to a copy inside the dataset, which is allowed.
  fs::rename(DatasetPaths(root).shard(1), dir.path() / "outside.sqlite");
  fs::create_symlink(dir.path() / "outside.sqlite", DatasetPaths(root).shard(1));
  fs::rename(DatasetPaths(root).shard(0), root / "kept.sqlite");
  fs::create_symlink("../kept.sqlite", DatasetPaths(root).shard(0));
  auto listing = ListShards(root);
  ASSERT_OK(listing.status());
  ASSERT_EQ(listing->targets.size(), 1u);
  EXPECT_EQ(listing->targets[0].index, 0);
  ASSERT_EQ(listing->unexpected.size(), 1u);
  EXPECT_EQ(listing->unexpected[0], DatasetPaths(root).shard(1));
}

// --- limits ---------------------------------------------------------------------------

TEST(ImageLimits, HeaderClaiming100000x100000IsRefusedBeforeDecoding) {
  const std::vector<uint8_t> bomb = fixtures::PngClaimingSize(100000, 100000);
  for (const ImageLimits& limits : {ImageLimits{}, kTextureLimits}) {
    auto header = ReadImageHeader(bomb, ImageFormat::kPng, limits);
    ASSERT_FALSE(header.ok());
    EXPECT_EQ(header.status().code(), StatusCode::kLimitExceeded);
    EXPECT_TRUE(Contains(header.status(), "100000x100000")) << header.status().ToString();
    EXPECT_TRUE(Contains(header.status(), std::to_string(limits.max_side) + " per side")) << header.status().ToString();
    EXPECT_EQ(DecodeImage(bomb, ImageFormat::kPng, limits).status().code(), StatusCode::kLimitExceeded);
  }
  // Within the dataset limits, over the texture limits: 9000 per side.
  const std::vector<uint8_t> wide = fixtures::PngClaimingSize(9000, 16);
  EXPECT_EQ(ReadImageHeader(wide, ImageFormat::kPng, kTextureLimits).status().code(), StatusCode::kLimitExceeded);
  auto header = ReadImageHeader(wide, ImageFormat::kPng);
  ASSERT_OK(header.status());
  EXPECT_EQ(header->width, 9000u);
  EXPECT_EQ(header->height, 16u);
  EXPECT_EQ(header->channels, 3u);
}

TEST(JsonLimits, ManifestStringsLongerThanTheLimitAreRefused) {
  nlohmann::json j = fixtures::LayeredManifest({}).ToJson();
  j["generator"]["name"] = std::string(json::kMaxConfigStringBytes + 1, 'x');
  auto parsed = Manifest::Parse(j.dump(2), "manifest.json");
  ASSERT_FALSE(parsed.ok());
  EXPECT_EQ(parsed.status().code(), StatusCode::kLimitExceeded) << parsed.status().ToString();
  EXPECT_TRUE(parsed.status().message().starts_with("manifest.json:")) << parsed.status().ToString();
  EXPECT_TRUE(Contains(parsed.status(), "limit of 4096 bytes")) << parsed.status().ToString();
  j["generator"]["name"] = std::string(json::kMaxConfigStringBytes, 'x');
  // At the limit the parser accepts it and the schema's maxLength (64) speaks.
  EXPECT_EQ(Manifest::Parse(j.dump(2), "manifest.json").status().code(), StatusCode::kParseError);
}

TEST(InstanceLimits, WriterRefusesMoreInstancesPerImageThanTheLimit) {
  TempDir dir;
  fixtures::LayeredDatasetOptions options;
  auto image = fixtures::MakeLayeredImage(options, 0);
  ASSERT_OK(image.status());
  ASSERT_FALSE(image->instances.empty());
  auto writer = ShardWriter::Create(dir.path() / "shard-000000.sqlite");
  ASSERT_OK(writer.status());
  ASSERT_OK(writer->AddImage(image->image));
  InstanceRecord instance = image->instances[0];
  instance.ordinal = kMaxInstancesPerImage - 1;
  EXPECT_OK(writer->AddInstance(instance));
  instance.ordinal = kMaxInstancesPerImage;
  const Status s = writer->AddInstance(instance);
  EXPECT_EQ(s.code(), StatusCode::kLimitExceeded) << s.ToString();
  EXPECT_TRUE(Contains(s, "image 0 instance 10000")) << s.ToString();
  EXPECT_TRUE(Contains(s, "10000 instances per image")) << s.ToString();
}

TEST(InstanceLimits, ReaderRefusesAnOrdinalPastTheLimit) {
  TempDir dir;
  fixtures::LayeredDatasetOptions options;
  options.images = 2;
  options.shard_size = 2;
  options.queries = false;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), options));
  const fs::path shard = DatasetPaths(dir.path()).shard(0);
  int64_t image_id = -1;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(shard.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT image_id FROM instances ORDER BY instance_id LIMIT 1", -1, &stmt, nullptr),
              SQLITE_OK);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
    image_id = sqlite3_column_int64(stmt, 0);
    sqlite3_finalize(stmt);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE instances SET ordinal = 10000 WHERE instance_id = (SELECT MIN(instance_id) FROM instances)",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  auto reader = ShardReader::Open(shard);
  ASSERT_OK(reader.status());
  auto instances = reader->InstancesOfImage(image_id);
  ASSERT_FALSE(instances.ok());
  EXPECT_EQ(instances.status().code(), StatusCode::kLimitExceeded) << instances.status().ToString();
  EXPECT_TRUE(Contains(instances.status(), shard.string())) << instances.status().ToString();
  EXPECT_TRUE(Contains(instances.status(), "ordinal 10000")) << instances.status().ToString();
}

}  // namespace
}  // namespace solid
