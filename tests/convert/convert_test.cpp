// End to end: `solid convert` over the fixture trees of docs "input-formats" section 5.
#include "solid/convert/convert.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "fixtures/input_trees.h"
#include "formats/test_util.h"
#include "solid/formats/glb.h"
#include "solid/formats/catalog.h"
#include "solid/formats/files.h"
#include "solid/formats/inspect.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

std::map<std::string, CatalogEntry> CatalogRows(const fs::path& out) {
  auto catalog = Catalog::OpenReadOnly(out / "catalog.sqlite");
  EXPECT_TRUE(catalog.ok()) << catalog.status().ToString();
  std::map<std::string, CatalogEntry> rows;
  if (!catalog.ok()) return rows;
  auto all = catalog->All();
  EXPECT_TRUE(all.ok());
  if (!all.ok()) return rows;
  for (auto& e : *all) rows.emplace(e.key, std::move(e));
  return rows;
}

Asset ReadAsset(const fs::path& path) {
  auto bytes = files::ReadFile(path, 64 << 20);
  EXPECT_TRUE(bytes.ok()) << bytes.status().ToString();
  if (!bytes.ok()) return {};
  auto asset = ReadGlb(*bytes, path.string());
  EXPECT_TRUE(asset.ok()) << asset.status().ToString();
  return asset.ok() ? std::move(asset).value() : Asset{};
}

bool HasWarning(const CatalogEntry& e, std::string_view code) {
  for (const auto& w : e.warnings) {
    if (w["code"] == code) return true;
  }
  return false;
}

ConvertOptions TwoJobs() {
  ConvertOptions o;
  o.jobs = 2;
  return o;
}

TEST(ConvertShapeNet, V2TreeGivesFiveModelsAndTwoFailures) {
  TempDir dir;
  fs::path root = dir.path() / "ShapeNetCore.v2", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteShapeNetV2Tree(root));
  auto report = ConvertShapeNet(root, out, TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->assets, 7);
  EXPECT_EQ(report->ok + report->ok_with_warnings, 5);
  EXPECT_EQ(report->failed, 2);
  EXPECT_EQ(report->failure_codes["missing_obj"], 2);

  auto rows = CatalogRows(out);
  ASSERT_EQ(rows.size(), 7u);
  const std::string sink = "02691156/0123456789abcdef0123456789abcdef";
  ASSERT_TRUE(rows.count(sink));
  const CatalogEntry& e = rows[sink];
  EXPECT_EQ(e.source, "shapenet_v2");
  EXPECT_EQ(e.status, AssetStatus::kOkWithWarnings);
  EXPECT_TRUE(HasWarning(e, "missing_texture")) << e.warnings.dump();
  EXPECT_EQ(*e.file, "models/02691156/0123456789abcdef0123456789abcdef.glb");
  EXPECT_EQ(e.extras["synset_name"], "airplane,aeroplane,plane");
  // 12 cube triangles + 12 reversed twins; 2 same-winding duplicates and 1 degenerate removed;
  // 2 + 1 + 1 textured triangles; the line-only group dropped.
  EXPECT_EQ(e.triangles, 28);
  EXPECT_EQ(e.counts["reversed_twins"], 12);
  EXPECT_EQ(e.counts["duplicates_removed"], 2);
  EXPECT_EQ(e.counts["degenerates_removed"], 1);

  Asset asset = ReadAsset(out / *e.file);
  ASSERT_EQ(asset.nodes.size(), 1u);
  EXPECT_EQ(asset.nodes[0].name, sink);
  std::map<std::string, const Material*> materials;
  for (const auto& m : asset.materials) materials[m.name] = &m;
  EXPECT_FALSE(materials.count("material_1_0")) << "a material used only by lines must be dropped";
  ASSERT_TRUE(materials.count("material_0_24"));
  EXPECT_TRUE(materials["material_0_24"]->blend);
  ASSERT_TRUE(materials.count("material_5_1_8"));
  EXPECT_TRUE(materials["material_5_1_8"]->base_color_texture.has_value());
  ASSERT_TRUE(materials.count("material_9_2_8"));
  EXPECT_TRUE(materials["material_9_2_8"]->base_color_texture.has_value()) << "PNG bytes behind a .JPG name";
  ASSERT_TRUE(materials.count("material_12_4_8"));
  EXPECT_FALSE(materials["material_12_4_8"]->base_color_texture.has_value());
  EXPECT_EQ(asset.textures.size(), 2u);
  EXPECT_TRUE(asset.extras.contains("source_centroid"));

  // The same model id in two synsets gives two assets.
  EXPECT_TRUE(fs::exists(out / "models/02992529/fedcba9876543210fedcba9876543210.glb"));
  EXPECT_TRUE(fs::exists(out / "models/04401088/fedcba9876543210fedcba9876543210.glb"));
  EXPECT_TRUE(HasWarning(rows["02691156/0123456789abcdef0123456789abc"], "unexpected_model_id") == false)
      << "29-character ids are valid ShapeNet ids";
  EXPECT_EQ(rows["02958343/00000000000000000000000000000002"].error_code, std::optional<std::string>("missing_obj"));
  EXPECT_FALSE(rows["02958343/00000000000000000000000000000001"].file.has_value());
}

TEST(ConvertShapeNet, RerunConvertsOnlyWhatChanged) {
  TempDir dir;
  fs::path root = dir.path() / "v2", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteShapeNetV2Tree(root));
  ASSERT_OK(ConvertShapeNet(root, out, TwoJobs()).status());
  auto again = ConvertShapeNet(root, out, TwoJobs());
  ASSERT_OK(again.status());
  EXPECT_EQ(again->up_to_date, 7);
  EXPECT_EQ(again->ok + again->ok_with_warnings + again->failed, 0);

  // A changed input, a deleted output and new options each cause a reconversion.
  { std::ofstream(root / "03001627/u01234567-89ab-cdef-0123-456789abcdef/models/model_normalized.mtl", std::ios::app) << "\n"; }
  fs::remove(out / "models/02992529/fedcba9876543210fedcba9876543210.glb");
  auto third = ConvertShapeNet(root, out, TwoJobs());
  ASSERT_OK(third.status());
  EXPECT_EQ(third->up_to_date, 5);
  EXPECT_EQ(third->ok + third->ok_with_warnings, 2);
  ConvertOptions finer = TwoJobs();
  finer.draco.position_bits = 16;
  auto fourth = ConvertShapeNet(root, out, finer);
  ASSERT_OK(fourth.status());
  EXPECT_EQ(fourth->up_to_date, 0) << "new options reconvert everything, failures included";
  EXPECT_EQ(fourth->ok + fourth->ok_with_warnings, 5);
  EXPECT_EQ(fourth->failed, 2);
}

TEST(ConvertShapeNet, LimitAndSynsetFilters) {
  TempDir dir;
  fs::path root = dir.path() / "v2";
  ASSERT_OK(fixtures::WriteShapeNetV2Tree(root));
  ConvertOptions o = TwoJobs();
  o.synsets = {"02992529", "04401088"};
  auto filtered = ConvertShapeNet(root, dir.path() / "a", o);
  ASSERT_OK(filtered.status());
  EXPECT_EQ(filtered->assets, 2);
  o.synsets.clear();
  o.limit = 3;
  auto limited = ConvertShapeNet(root, dir.path() / "b", o);
  ASSERT_OK(limited.status());
  EXPECT_EQ(limited->assets, 3);
  EXPECT_EQ(ConvertShapeNet(dir.path() / "nowhere", dir.path() / "c", o).status().code(), StatusCode::kNotFound);
}

TEST(ConvertShapeNet, V1ModelsAreRotatedToTheV2Frame) {
  TempDir dir;
  fs::path root = dir.path() / "v1", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteShapeNetV1Tree(root));
  auto report = ConvertShapeNet(root, out, TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->failed, 1);
  EXPECT_EQ(report->failure_codes["empty_geometry"], 1);
  auto rows = CatalogRows(out);
  const CatalogEntry& car = rows["02958343/123456789abcdef0123456789abcdef"];
  EXPECT_EQ(car.source, "shapenet_v1");
  ASSERT_TRUE(car.bounds.has_value());
  // Front +X (length 1 along x) becomes front -Z: x' = z in [-0.2, 0.2], z' = -x in [-0.5, 0.5].
  EXPECT_NEAR((*car.bounds)[0], -0.2, 1e-3);
  EXPECT_NEAR((*car.bounds)[3], 0.2, 1e-3);
  EXPECT_NEAR((*car.bounds)[2], -0.5, 1e-3);
  EXPECT_NEAR((*car.bounds)[5], 0.5, 1e-3);
  EXPECT_EQ(car.counts["polygons_triangulated"], 1);
}

TEST(ConvertSceneNet, KeepsOnlyStructureWithNamesVerbatim) {
  TempDir dir;
  fs::path root = dir.path() / "scenenet", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  auto report = ConvertSceneNet(root, out, TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->assets, 5);
  EXPECT_EQ(report->failed, 1);
  EXPECT_EQ(report->failure_codes["suspect_units"], 1);
  auto rows = CatalogRows(out);
  const CatalogEntry& bedroom = rows["SceneNetData/1Bedroom/fixture_bedroom"];
  EXPECT_EQ(*bedroom.file, "rooms/SceneNetData/1Bedroom/fixture_bedroom.glb");
  Asset asset = ReadAsset(out / *bedroom.file);
  std::vector<std::string> names;
  for (const auto& n : asset.nodes) names.push_back(n.name);
  EXPECT_EQ(names, (std::vector<std::string>{"wall.034", "Walls.132", "Wall.242333", "room_skeleton",
                                             "walls1_line01_12", "floor_enclose_1", "Floor1", "floor.004",
                                             "floor_enclose", "ground", "floor-mat", "ceiling_enclose",
                                             "Ceiling.1231", "ceiling", "ceilingwall", "Wall.242333.001"}));
  for (const auto& n : asset.nodes) {
    EXPECT_TRUE(n.extras.contains("category")) << n.name;
    EXPECT_NE(n.extras.value("structure", ""), "") << n.name;
    for (const auto& p : n.primitives) EXPECT_FALSE(p.uvs.empty()) << n.name << ": UVs are kept";
  }
  EXPECT_TRUE(asset.textures.empty()) << "SceneNet textures are chosen at render time";
  EXPECT_EQ(bedroom.extras["dropped_objects"].size(), 12u);
  EXPECT_NEAR(bedroom.extras["height_m"].get<double>(), 2.9, 1e-4);

  const CatalogEntry& skeleton = rows["SceneNetData/1Living-room/fixture_skeleton"];
  Asset sk = ReadAsset(out / *skeleton.file);
  std::vector<std::string> sk_names;
  for (const auto& n : sk.nodes) sk_names.push_back(n.name);
  EXPECT_EQ(sk_names, (std::vector<std::string>{"room_skeleton", "floor_enclose_1", "ceiling_enclose"}))
      << "zero-face objects are absent";
  EXPECT_NEAR(skeleton.extras["floor_area_m2"].get<double>(), 20.0, 1e-3);

  const CatalogEntry& layout = rows["layouts/bedroom/bedroom1_layout"];
  EXPECT_NE(layout.status, AssetStatus::kFailed) << layout.error.value_or("");
  EXPECT_TRUE(rows["SceneNetData/1Bedroom/fixture_nomtllib"].file.has_value());
  EXPECT_EQ(rows["SceneNetData/1Office/fixture_mm"].error_code, std::optional<std::string>("suspect_units"));
}

TEST(ConvertProcedural, IsDeterministicAndInspectable) {
  TempDir dir;
  ProceduralSet set;
  set.models = 6;
  set.rooms = 2;
  set.seed = 7;
  ConvertOptions one;
  one.jobs = 1;
  auto a = ConvertProcedural(set, dir.path() / "a", one);
  auto b = ConvertProcedural(set, dir.path() / "b", TwoJobs());
  ASSERT_OK(a.status());
  ASSERT_OK(b.status());
  EXPECT_EQ(a->ok, 8);
  for (const char* file : {"models/procedural/shape-000000.glb", "models/procedural/shape-000005.glb",
                           "rooms/procedural/room-000001.glb"}) {
    auto x = files::ReadFile(dir.path() / "a" / file, 64 << 20);
    auto y = files::ReadFile(dir.path() / "b" / file, 64 << 20);
    ASSERT_OK(x.status());
    ASSERT_OK(y.status());
    EXPECT_EQ(*x, *y) << file << " differs between --jobs 1 and --jobs 2";
  }
  auto inspection = Inspect(dir.path() / "a");
  ASSERT_OK(inspection.status());
  EXPECT_EQ((*inspection)["kind"], "assets");
  EXPECT_EQ((*inspection)["assets"], 8);
  EXPECT_EQ((*inspection)["rooms"], 2);
  EXPECT_GT((*inspection)["bytes_out"].get<int64_t>(), 0);
  EXPECT_NE(FormatInspection(*inspection).find("procedural"), std::string::npos);
}

}  // namespace
}  // namespace solid::convert
