// Hostile input reaching the renderer (issue 8, docs/limits.md): catalog rows that point
// out of their assets directory, textures whose header claims a decompression bomb,
// oversized params, and the asset cache's memory cap.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <optional>
#include <fstream>
#include <random>
#include <thread>

#include "fixtures/crafted_images.h"
#include "formats/test_util.h"
#include "render/test_assets.h"
#include "solid/formats/catalog.h"
#include "solid/formats/glb.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/records.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using solid::testing::TempDir;

// A copy of the procedural assets whose catalog row of the first model names `file`
// (or keeps its own).
struct CraftedAssets {
  TempDir dir;
  fs::path assets = dir.path() / "assets";
  std::string key;

  explicit CraftedAssets(const std::optional<std::string>& file) {
    fs::copy(testing::ProceduralAssetsDir(), assets, fs::copy_options::recursive);
    Catalog catalog = Catalog::OpenForWriting(assets / "catalog.sqlite").value();
    std::vector<CatalogEntry> rows = catalog.All().value();
    auto model = std::find_if(rows.begin(), rows.end(), [](const CatalogEntry& e) { return e.kind == "model"; });
    key = model->key;
    if (file) model->file = *file;
    EXPECT_OK(catalog.Put(*model));
  }
};

TEST(AssetLibraryHostile, CatalogRowsThatLeaveTheAssetsDirectoryAreRefused) {
  TempDir outside;
  std::ofstream(outside.path() / "elsewhere.glb") << "not ours";
  const std::pair<std::string, std::string> cases[] = {
      {(outside.path() / "elsewhere.glb").string(), "is absolute"},
      {"../../elsewhere.glb", "leaves"},
      {"models/../../elsewhere.glb", "leaves"},
      {"models/link.glb", "through a symbolic link"},
  };
  for (const auto& [file, why] : cases) {
    CraftedAssets crafted(file);
    fs::create_symlink(outside.path() / "elsewhere.glb", crafted.assets / "models" / "link.glb");
    auto library = AssetLibrary::Open(crafted.assets, crafted.assets);
    ASSERT_FALSE(library.ok()) << file;
    EXPECT_EQ(library.status().code(), StatusCode::kCorrupt) << library.status().ToString();
    EXPECT_THAT(library.status().message(),
                HasSubstr(fmt::format("{}: row '{}': path '{}' ", (crafted.assets / "catalog.sqlite").string(),
                                      crafted.key, file)));
    EXPECT_THAT(library.status().message(), HasSubstr(why));
  }
  // A copy whose rows are left alone opens.
  CraftedAssets honest(std::nullopt);
  EXPECT_OK(AssetLibrary::Open(honest.assets, honest.assets).status());
}

TEST(TextureLimits, GlbTextureClaiming100000x100000IsRefusedBeforeDecoding) {
  gltf::Asset asset;
  gltf::Primitive triangle;
  triangle.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  triangle.uvs = {0, 0, 1, 0, 0, 1};
  triangle.indices = {0, 1, 2};
  triangle.material = 0;
  asset.nodes.push_back({"bomb", {triangle}, nlohmann::json::object()});
  asset.materials.push_back({.name = "textured", .base_color_texture = 0});
  asset.textures.push_back({"bomb.png", "image/png", fixtures::PngClaimingSize(100000, 100000)});
  // Through the glb the renderer reads, and its texture cache.
  const std::vector<uint8_t> glb = gltf::WriteGlb(asset).value();
  const gltf::Asset read = gltf::ReadGlb(glb, "bomb.glb").value();
  auto device = Device::Create().value();
  auto loaded = LoadedAsset::Build(device, "bomb", read, /*centre=*/true).value();
  TextureCache cache;
  auto textures = cache.Get(loaded->textures(), loaded, "bomb.glb");
  ASSERT_FALSE(textures.ok());
  EXPECT_EQ(textures.status().code(), StatusCode::kLimitExceeded) << textures.status().ToString();
  EXPECT_THAT(textures.status().message(), HasSubstr("bomb.glb: texture 0 (bomb.png)"));
  EXPECT_THAT(textures.status().message(), HasSubstr("100000x100000"));
  EXPECT_THAT(textures.status().message(), HasSubstr("8192 per side"));
  EXPECT_EQ(cache.bytes(), 0u);
}

TEST(ParamsLimits, LongStringsAndTooManyInstancesAreRefused) {
  TempDir dir;
  const fs::path path = dir.path() / "params.json";
  std::ofstream(path) << R"({"preset": "occlusion", "$comment": ")" << std::string(json::kMaxConfigStringBytes + 1, 'x')
                      << "\"}";
  auto params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kLimitExceeded) << params.status().ToString();
  EXPECT_THAT(params.status().message(), HasSubstr(path.string() + ":1:"));
  EXPECT_THAT(params.status().message(), HasSubstr("limit of 4096 bytes"));

  // Each attempt places at most one object: attempts bound the instances per image.
  std::ofstream(path, std::ios::trunc) << R"({"preset": "occlusion", "objects": {"attempts": [9, )"
                                       << kMaxInstancesPerImage + 1 << "]}}";
  params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr("/objects/attempts/1"));
  EXPECT_THAT(params.status().message(), HasSubstr("10000"));
}

// The cache's accounted bytes stay within its cap whatever the load order and thread
// count (an asset larger than the cap is the one exception: it stays alone).
TEST(AssetCache, AccountedBytesNeverExceedTheCap) {
  auto uncapped = AssetLibrary::Open(testing::ProceduralAssetsDir(), testing::ProceduralAssetsDir()).value();
  const size_t models = uncapped->models().size();
  uint64_t total = 0, largest = 0;
  for (size_t i = 0; i < models; ++i) {
    const uint64_t bytes = uncapped->Model(i).value()->memory_bytes();
    total += bytes;
    largest = std::max(largest, bytes);
  }
  ASSERT_EQ(uncapped->cache_stats().bytes, total);
  const uint64_t cap = std::max(total / 4, largest);

  AssetLibraryOptions options;
  options.cache_bytes = cap;
  auto library = AssetLibrary::Open(testing::ProceduralAssetsDir(), testing::ProceduralAssetsDir(), options).value();
  std::atomic<uint64_t> over{0}, peak{0};
  auto worker = [&](uint64_t seed) {
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 20; ++k) {
      auto asset = library->Model(rng() % models);
      if (!asset.ok() || (*asset)->mesh().TriangleCount() == 0) ++over;
      const uint64_t bytes = library->cache_stats().bytes;
      if (bytes > cap) ++over;
      uint64_t seen = peak.load();
      while (bytes > seen && !peak.compare_exchange_weak(seen, bytes)) {
      }
    }
  };
  std::vector<std::thread> threads;
  for (uint64_t t = 0; t < 3; ++t) threads.emplace_back(worker, t + 1);
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(over.load(), 0u);
  const AssetLibrary::CacheStats stats = library->cache_stats();
  EXPECT_GT(stats.evictions, 0u);
  EXPECT_LT(stats.entries, models);
  EXPECT_LE(peak.load(), cap);

  // A cap smaller than any asset keeps exactly one, the last loaded.
  options.cache_bytes = 1;
  auto tiny = AssetLibrary::Open(testing::ProceduralAssetsDir(), testing::ProceduralAssetsDir(), options).value();
  for (size_t i = 0; i < models; ++i) {
    ASSERT_OK(tiny->Model(i).status());
    EXPECT_EQ(tiny->cache_stats().entries, 1u);
    EXPECT_LE(tiny->cache_stats().bytes, largest);
  }
}

// Sampling through a cache far smaller than the model set evicts and reloads, and the
// layouts and their metrics are exactly those of an uncapped cache.
TEST(AssetCache, SamplingWithASmallCapGivesTheSameReport) {
  auto uncapped = AssetLibrary::Open(testing::ProceduralAssetsDir(), testing::ProceduralAssetsDir()).value();
  AssetLibraryOptions options;
  options.cache_bytes = 1;
  auto capped = AssetLibrary::Open(testing::ProceduralAssetsDir(), testing::ProceduralAssetsDir(), options).value();
  SampleOptions sample;
  sample.seed = 5;
  sample.layouts = 12;
  sample.jobs = 2;
  LayoutParams params = LoadPreset("occlusion").value();
  params.width = 64;
  params.height = 48;
  nlohmann::json a = RunSample(*LayoutSampler::Create(params, uncapped).value(), sample).value().ToJson();
  nlohmann::json b = RunSample(*LayoutSampler::Create(params, capped).value(), sample).value().ToJson();
  for (auto* j : {&a, &b}) {
    for (const char* timing : {"seconds", "sample_ms_per_layout", "mask_ms_per_layout"}) j->erase(timing);
  }
  EXPECT_EQ(a, b);
  EXPECT_GT(capped->cache_stats().evictions, 0u);
  EXPECT_EQ(capped->cache_stats().entries, 1u);  // the last asset loaded
}

}  // namespace
}  // namespace solid::render
