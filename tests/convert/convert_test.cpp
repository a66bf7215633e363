// End to end: `solid convert` over the fixture trees of docs "input-formats" section 5.
#include "solid/convert/convert.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>

#include "fixtures/gltf_validator.h"
#include "fixtures/input_trees.h"
#include "fixtures/shared_testdata.h"
#include "fixtures/triangle_match.h"
#include "formats/test_util.h"
#include "obj.h"
#include "obj_to_asset.h"
#include "solid/convert/procedural.h"
#include "scenenet.h"
#include "solid/formats/glb.h"
#include "solid/formats/catalog.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
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

// Convert of each source kind, with `o`'s other options.
Result<ConvertReport> ShapeNet(const fs::path& root, const fs::path& out, ConvertOptions o) {
  o.source = Source::kShapeNet;
  o.root = root;
  o.out = out;
  return Convert(o);
}
Result<ConvertReport> SceneNet(const fs::path& root, const fs::path& out, ConvertOptions o) {
  o.source = Source::kSceneNet;
  o.root = root;
  o.out = out;
  return Convert(o);
}
Result<ConvertReport> Procedural(const ProceduralSet& set, const fs::path& out, ConvertOptions o) {
  o.source = Source::kProcedural;
  o.procedural = set;
  o.out = out;
  return Convert(o);
}

TEST(ConvertShapeNet, V2TreeGivesFiveModelsAndTwoFailures) {
  TempDir dir;
  fs::path root = dir.path() / "ShapeNetCore.v2", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteShapeNetV2Tree(root));
  auto report = ShapeNet(root, out, TwoJobs());
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
  ASSERT_OK(ShapeNet(root, out, TwoJobs()).status());
  auto again = ShapeNet(root, out, TwoJobs());
  ASSERT_OK(again.status());
  EXPECT_EQ(again->up_to_date, 7);
  EXPECT_EQ(again->ok + again->ok_with_warnings + again->failed, 0);

  // A changed input, a deleted output and new options each cause a reconversion.
  { std::ofstream(root / "03001627/u01234567-89ab-cdef-0123-456789abcdef/models/model_normalized.mtl", std::ios::app) << "\n"; }
  fs::remove(out / "models/02992529/fedcba9876543210fedcba9876543210.glb");
  auto third = ShapeNet(root, out, TwoJobs());
  ASSERT_OK(third.status());
  EXPECT_EQ(third->up_to_date, 5);
  EXPECT_EQ(third->ok + third->ok_with_warnings, 2);
  ConvertOptions finer = TwoJobs();
  finer.draco.position_bits = 16;
  auto fourth = ShapeNet(root, out, finer);
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
  auto filtered = ShapeNet(root, dir.path() / "a", o);
  ASSERT_OK(filtered.status());
  EXPECT_EQ(filtered->assets, 2);
  o.synsets.clear();
  o.limit = 3;
  auto limited = ShapeNet(root, dir.path() / "b", o);
  ASSERT_OK(limited.status());
  EXPECT_EQ(limited->assets, 3);
  EXPECT_EQ(ShapeNet(dir.path() / "nowhere", dir.path() / "c", o).status().code(), StatusCode::kNotFound);
}

TEST(ConvertShapeNet, V1ModelsAreRotatedToTheV2Frame) {
  TempDir dir;
  fs::path root = dir.path() / "v1", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteShapeNetV1Tree(root));
  auto report = ShapeNet(root, out, TwoJobs());
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
  auto report = SceneNet(root, out, TwoJobs());
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

TEST(Convert, WrongOptionsNameTheirField) {
  TempDir dir;
  ConvertOptions o = TwoJobs();
  EXPECT_EQ(Convert(o).status().option(), "out");
  o.out = dir.path() / "assets";
  o.source = Source::kShapeNet;
  EXPECT_EQ(Convert(o).status().option(), "root");
  o.source = Source::kSceneNet;
  EXPECT_EQ(Convert(o).status().option(), "root");
  o.source = Source::kProcedural;
  o.procedural.models = -1;
  const Status models = Convert(o).status();
  EXPECT_EQ(models.option(), "procedural.models");
  EXPECT_EQ(models.message(), "procedural.models: must not be negative");
  o.procedural.models = 1;
  o.procedural.rooms = -1;
  EXPECT_EQ(Convert(o).status().option(), "procedural.rooms");
  EXPECT_FALSE(fs::exists(o.out)) << "a refused option writes nothing";
}

TEST(ConvertProcedural, IsDeterministicAndInspectable) {
  TempDir dir;
  ProceduralSet set;
  set.models = 6;
  set.rooms = 2;
  set.seed = 7;
  ConvertOptions one;
  one.jobs = 1;
  auto a = Procedural(set, dir.path() / "a", one);
  auto b = Procedural(set, dir.path() / "b", TwoJobs());
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
  auto inspection = Inspect({dir.path() / "a"});
  ASSERT_OK(inspection.status());
  EXPECT_EQ(inspection->summary["kind"], "assets");
  EXPECT_EQ(inspection->summary["assets"], 8);
  EXPECT_EQ(inspection->summary["rooms"], 2);
  EXPECT_GT(inspection->summary["bytes_out"].get<int64_t>(), 0);
  EXPECT_NE(inspection->ToText().find("procedural"), std::string::npos);
}

// Text in warnings comes from the input: an undefined Latin-1 usemtl name went verbatim into
// the catalog's warnings JSON, whose serialisation threw and ended the whole batch.
TEST(ConvertShapeNet, NonUtf8TextInWarningsDoesNotStopTheBatch) {
  TempDir dir;
  const fs::path model = dir.path() / "v1/02958343/00000000000000000000000000000004";
  fs::create_directories(model);
  std::ofstream(model / "model.obj", std::ios::binary) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl Terr\xe6n\nf 1 2 3\n";
  auto report = ShapeNet(dir.path() / "v1", dir.path() / "out", TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->ok_with_warnings, 1);
  auto rows = CatalogRows(dir.path() / "out");
  const CatalogEntry& e = rows["02958343/00000000000000000000000000000004"];
  EXPECT_TRUE(HasWarning(e, "undefined_material")) << e.warnings.dump();
  EXPECT_TRUE(HasWarning(e, "name_not_utf8")) << e.warnings.dump();
}

// ---------------------------------------------------------------------------
// The SceneNet texture-library step (input-formats 3.3 and 4, "Optional texture-library step")

std::map<std::string, std::string> UnmatchedOfRow(const CatalogEntry& e) {
  std::map<std::string, std::string> out;
  if (!e.extras.contains("unmatched_texture_folders")) return out;
  for (const auto& u : e.extras["unmatched_texture_folders"]) out[u["material"]] = u["folder"];
  return out;
}

TEST(ConvertSceneNet, TextureLibrary_Walls132AndMetalPlasticAreUnmatchedAndUnknownIsCreated) {
  TempDir dir;
  fs::path root = dir.path() / "scenenet", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  ASSERT_FALSE(fs::exists(root / "texture_library/unknown")) << "the download has no unknown/";
  ConvertOptions o = TwoJobs();
  o.texture_library = true;
  o.keep_all_room_objects = true;  // the metal_plastic.001 material is only on props
  auto report = SceneNet(root, out, o);
  ASSERT_OK(report.status());
  ASSERT_TRUE(report->textures.has_value());
  const TextureLibraryReport& t = *report->textures;
  EXPECT_EQ(t.categories, (std::vector<std::string>{"ceiling", "floor", "metal_plastic", "painting", "wall", "wood"}));
  EXPECT_EQ(t.files_copied, 6);
  EXPECT_EQ(t.files_up_to_date, 0);
  EXPECT_TRUE(t.unknown_created);
  for (const auto& entry : fs::directory_iterator(root / "texture_library/wall")) {
    auto a = files::ReadFile(entry.path(), 1 << 20);
    auto b = files::ReadFile(out / "textures/wall" / entry.path().filename(), 1 << 20);
    ASSERT_OK(a.status());
    ASSERT_OK(b.status());
    EXPECT_EQ(*a, *b);
  }
  auto placeholder = files::ReadFile(out / "textures/unknown/placeholder_grey.png", 1 << 20);
  ASSERT_OK(placeholder.status());
  auto grey = DecodeImage(*placeholder, ImageFormat::kPng);
  ASSERT_OK(grey.status());
  EXPECT_GT(grey->width, 0u);

  // Case-sensitive, '_' and digits deleted: "Walls" and "metalplastic" are not library folders.
  EXPECT_EQ(t.unmatched.at("Walls.132"), "Walls");
  EXPECT_EQ(t.unmatched.at("metal_plastic.001"), "metalplastic");
  EXPECT_EQ(t.unmatched.at("Wall.242333"), "Wall");
  EXPECT_FALSE(t.unmatched.count("wall.000"));
  EXPECT_FALSE(t.unmatched.count("floor.001"));
  EXPECT_FALSE(t.unmatched.count("ceiling.000"));
  auto rows = CatalogRows(out);
  std::map<std::string, std::string> bedroom = UnmatchedOfRow(rows["SceneNetData/1Bedroom/fixture_bedroom"]);
  EXPECT_EQ(bedroom["Walls.132"], "Walls");
  EXPECT_EQ(bedroom["metal_plastic.001"], "metalplastic");
  EXPECT_FALSE(bedroom.count("wall.000"));
  // The layout's materials: Walls.001 -> Walls (unmatched), cupboard.000 -> cupboard (unmatched:
  // the MTL says wood, but the loader goes by the name), Floor.1001 -> Floor (case-sensitive).
  std::map<std::string, std::string> layout = UnmatchedOfRow(rows["layouts/bedroom/bedroom1_layout"]);
  EXPECT_EQ(layout, (std::map<std::string, std::string>{
                        {"Floor.1001", "Floor"}, {"Walls.001", "Walls"}, {"cupboard.000", "cupboard"}}));

  // A rerun changes nothing and still reports, from the catalog.
  auto again = SceneNet(root, out, o);
  ASSERT_OK(again.status());
  EXPECT_EQ(again->up_to_date, again->assets);
  EXPECT_EQ(again->textures->files_copied, 0);
  EXPECT_EQ(again->textures->files_up_to_date, 6);
  EXPECT_FALSE(again->textures->unknown_created);
  EXPECT_EQ(again->textures->unmatched, t.unmatched);

  // A damaged copy is replaced; a new library folder reconverts the rooms.
  for (const auto& entry : fs::directory_iterator(out / "textures/floor")) {
    std::ofstream(entry.path(), std::ios::trunc) << "torn";
  }
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  fs::copy(root / "texture_library/wall", root / "texture_library/Walls");
  auto third = SceneNet(root, out, o);
  ASSERT_OK(third.status());
  EXPECT_EQ(third->textures->files_copied, 2) << "the torn floor image and the new Walls/ image";
  EXPECT_EQ(third->up_to_date, 0);
  EXPECT_FALSE(third->textures->unmatched.count("Walls.132"));
  EXPECT_EQ(third->textures->unmatched.count("metal_plastic.001"), 1u);
}

TEST(ConvertSceneNet, TextureLibrary_DefaultRunReportsOnlyMaterialsOfKeptObjects) {
  TempDir dir;
  fs::path root = dir.path() / "scenenet";
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  ConvertOptions o = TwoJobs();
  o.texture_library = true;
  auto report = SceneNet(root, dir.path() / "assets", o);
  ASSERT_OK(report.status());
  EXPECT_EQ(report->textures->unmatched.count("Walls.132"), 1u);
  EXPECT_EQ(report->textures->unmatched.count("metal_plastic.001"), 0u) << "only props use it, and they are dropped";

  auto without = SceneNet(root, dir.path() / "plain", TwoJobs());
  ASSERT_OK(without.status());
  EXPECT_FALSE(without->textures.has_value());
  EXPECT_FALSE(fs::exists(dir.path() / "plain/textures"));

  fs::remove_all(root / "texture_library");
  EXPECT_EQ(SceneNet(root, dir.path() / "again", o).status().code(), StatusCode::kNotFound);
}

// ---------------------------------------------------------------------------
// End to end over every fixture tree: the Khronos validator and geometric fidelity

struct FixtureOutputs {
  fs::path shapenet_v1, shapenet_v2, scenenet, procedural;
};

constexpr uint64_t kProceduralSeed = 3;

// The fixture trees of input-formats 5 and a procedural set covering every shape family,
// converted with the library's batch entry points.
FixtureOutputs ConvertEveryFixture(const fs::path& dir) {
  FixtureOutputs o{dir / "out-v1", dir / "out-v2", dir / "out-scenenet", dir / "out-procedural"};
  EXPECT_OK(fixtures::WriteShapeNetV1Tree(dir / "v1"));
  EXPECT_OK(fixtures::WriteShapeNetV2Tree(dir / "v2"));
  EXPECT_OK(fixtures::WriteSceneNetTree(dir / "scenenet"));
  EXPECT_OK(ShapeNet(dir / "v1", o.shapenet_v1, TwoJobs()).status());
  EXPECT_OK(ShapeNet(dir / "v2", o.shapenet_v2, TwoJobs()).status());
  ConvertOptions all = TwoJobs();
  all.keep_all_room_objects = true;
  EXPECT_OK(SceneNet(dir / "scenenet", o.scenenet, all).status());
  ProceduralSet set;
  set.models = kShapeFamilyCount;
  set.rooms = 2;
  set.seed = kProceduralSeed;
  EXPECT_OK(Procedural(set, o.procedural, TwoJobs()).status());
  return o;
}

std::vector<fs::path> GlbsBelow(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ".glb") out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ConvertEndToEnd, KhronosValidatorReportsNoErrorsOnEveryOutput) {
  if (auto why = fixtures::GltfValidatorUnavailable()) GTEST_SKIP() << *why;
  TempDir dir;
  const FixtureOutputs o = ConvertEveryFixture(dir.path());
  std::vector<fs::path> files;
  size_t per_tree[4] = {};
  size_t k = 0;
  for (const fs::path& out : {o.shapenet_v1, o.shapenet_v2, o.scenenet, o.procedural}) {
    for (const fs::path& glb : GlbsBelow(out)) {
      files.push_back(glb);
      ++per_tree[k];
    }
    ++k;
  }
  // 1 v1 model, 5 v2 models, 4 rooms (the millimetre room fails), 6 shapes + 2 rooms.
  EXPECT_EQ(per_tree[0], 1u);
  EXPECT_EQ(per_tree[1], 5u);
  EXPECT_EQ(per_tree[2], 4u);
  EXPECT_EQ(per_tree[3], static_cast<size_t>(kShapeFamilyCount) + 2);
  // The validator skips Draco data: it also checks a copy holding the decoded geometry.
  const fs::path plain_dir = dir.path() / "decompressed";
  fs::create_directories(plain_dir);
  const size_t compressed = files.size();
  for (size_t i = 0; i < compressed; ++i) {
    auto bytes = files::ReadFile(files[i], 64 << 20);
    ASSERT_OK(bytes.status());
    auto plain = fixtures::DecompressDraco(*bytes, files[i].string());
    ASSERT_OK(plain.status());
    const fs::path path = plain_dir / fmt::format("{:03d}-{}", i, files[i].filename().string());
    ASSERT_OK(files::WriteFileAtomically(path, *plain));
    files.push_back(path);
  }
  const fixtures::GltfValidatorRun run = fixtures::RunGltfValidator(files);
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.files_reported, files.size()) << run.report;
  std::printf("glTF-Validator: %zu outputs + %zu decoded copies, exit %d\n", compressed, compressed, run.exit_status);
}

// The cleaned input of each asset, rebuilt through the library's own steps.
Asset CleanedShapeNetV2(const fs::path& model_dir, const std::string& key) {
  const fs::path obj_path = model_dir / "models/model_normalized.obj", mtl_path = model_dir / "models/model_normalized.mtl";
  auto obj_bytes = files::ReadFile(obj_path, 64 << 20);
  auto mtl_bytes = files::ReadFile(mtl_path, 64 << 20);
  EXPECT_TRUE(obj_bytes.ok() && mtl_bytes.ok());
  if (!obj_bytes.ok() || !mtl_bytes.ok()) return {};
  auto obj = ReadObj(*obj_bytes, obj_path.string());
  auto mtl = ReadMtl(*mtl_bytes, mtl_path.string());
  EXPECT_TRUE(obj.ok() && mtl.ok());
  if (!obj.ok() || !mtl.ok()) return {};
  ObjAssetOptions options;
  options.node_name = key;
  options.mtl_dir = mtl_path.parent_path();
  options.confine_root = model_dir;
  auto built = BuildAssetFromObj(*obj, &*mtl, options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return built.ok() ? std::move(built->asset) : Asset{};
}

Asset CleanedSceneNetRoom(const fs::path& root, const fs::path& obj_path) {
  auto obj_bytes = files::ReadFile(obj_path, 64 << 20);
  EXPECT_TRUE(obj_bytes.ok());
  if (!obj_bytes.ok()) return {};
  auto obj = ReadObj(*obj_bytes, obj_path.string());
  EXPECT_TRUE(obj.ok());
  if (!obj.ok()) return {};
  std::optional<MtlData> mtl;
  const fs::path mtl_path = fs::path(obj_path).replace_extension(".mtl");
  if (fs::exists(mtl_path)) {
    auto mtl_bytes = files::ReadFile(mtl_path, 64 << 20);
    EXPECT_TRUE(mtl_bytes.ok());
    if (mtl_bytes.ok()) {
      auto parsed = ReadMtl(*mtl_bytes, mtl_path.string());
      EXPECT_TRUE(parsed.ok());
      if (parsed.ok()) mtl = std::move(parsed).value();
    }
  }
  ObjAssetOptions options;
  options.grouping = NodeGrouping::kPerObject;
  options.textures = TextureMode::kValidateOnly;
  options.mtl_dir = obj_path.parent_path();
  options.confine_root = root;
  auto built = BuildAssetFromObj(*obj, mtl ? &*mtl : nullptr, options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return built.ok() ? std::move(built->asset) : Asset{};
}

struct FidelitySummary {
  size_t triangles = 0, unmatched = 0;
  double max_relative_error = 0;  // largest position error / the primitive's bounding-box diagonal
  double max_error = 0;
};

void Accumulate(const Asset& cleaned, const fs::path& glb, FidelitySummary* sum) {
  const Asset decoded = ReadAsset(glb);
  ASSERT_EQ(cleaned.nodes.size(), decoded.nodes.size()) << glb;
  for (size_t i = 0; i < cleaned.nodes.size(); ++i) {
    ASSERT_EQ(cleaned.nodes[i].primitives.size(), decoded.nodes[i].primitives.size()) << glb << " " << cleaned.nodes[i].name;
    for (size_t j = 0; j < cleaned.nodes[i].primitives.size(); ++j) {
      const Primitive& in = cleaned.nodes[i].primitives[j];
      const fixtures::Fidelity f = fixtures::MatchTriangles(in, decoded.nodes[i].primitives[j], DracoOptions{});
      EXPECT_EQ(f.unmatched, 0u) << glb << ": node " << cleaned.nodes[i].name << " primitive " << j;
      EXPECT_EQ(in.indices.size(), decoded.nodes[i].primitives[j].indices.size()) << glb;
      sum->triangles += in.indices.size() / 3;
      sum->unmatched += f.unmatched;
      sum->max_error = std::max(sum->max_error, f.max_error);
      if (f.diagonal > 0) sum->max_relative_error = std::max(sum->max_relative_error, f.max_error / f.diagonal);
    }
  }
}

TEST(ConvertEndToEnd, DecodedOutputHoldsEveryCleanedTriangleWithinOneQuantizationStep) {
  TempDir dir;
  const FixtureOutputs o = ConvertEveryFixture(dir.path());
  FidelitySummary sum;
  size_t assets = 0;
  for (const auto& [key, row] : CatalogRows(o.shapenet_v2)) {
    if (!row.file) continue;
    Accumulate(CleanedShapeNetV2(dir.path() / "v2" / key, key), o.shapenet_v2 / *row.file, &sum);
    ++assets;
  }
  for (const auto& [key, row] : CatalogRows(o.scenenet)) {
    if (!row.file) continue;
    Accumulate(CleanedSceneNetRoom(dir.path() / "scenenet", dir.path() / "scenenet" / (key + ".obj")),
               o.scenenet / *row.file, &sum);
    ++assets;
  }
  for (int i = 0; i < kShapeFamilyCount; ++i) {
    const std::string key = fmt::format("procedural/shape-{:06d}", i);
    auto shape = MakeProceduralShape(kProceduralSeed, i, key);
    ASSERT_OK(shape.status());
    Accumulate(*shape, o.procedural / ("models/" + key + ".glb"), &sum);
    ++assets;
  }
  for (int i = 0; i < 2; ++i) {
    const std::string key = fmt::format("procedural/room-{:06d}", i);
    auto room = MakeProceduralRoom(kProceduralSeed, i, key);
    ASSERT_OK(room.status());
    Accumulate(*room, o.procedural / ("rooms/" + key + ".glb"), &sum);
    ++assets;
  }
  EXPECT_EQ(assets, 5u + 4u + kShapeFamilyCount + 2u);
  EXPECT_EQ(sum.unmatched, 0u);
  // 14 position bits: rounding leaves at most half a step, extent / (2^14 - 1) / 2, per axis.
  EXPECT_LE(sum.max_relative_error, 0.5 / ((1 << 14) - 1) + 1e-6);
  std::printf("fidelity: %zu assets, %zu triangles, 0 missing; max position error %.3g "
              "(%.3g of the bounding-box diagonal)\n",
              assets, sum.triangles, sum.max_error, sum.max_relative_error);
}

// ---------------------------------------------------------------------------
// A real generic-OBJ corpus (Debian assimp-testmodels, input-formats 5.6)

constexpr const char* kAssimpModels = "/usr/share/assimp/models";

TEST(ConvertCorpus, AssimpTestModelsConvertOrFailWithAReason) {
  if (!fs::is_directory(kAssimpModels)) {
    GTEST_SKIP() << kAssimpModels << " absent: install Debian package assimp-testmodels to run this test";
  }
  // Each OBJ becomes the model.obj of a ShapeNet v1 model folder holding a copy of its own
  // folder, so that its MTL and textures resolve as they do beside it.
  TempDir dir;
  const fs::path root = dir.path() / "corpus";
  std::vector<fs::path> objs;
  for (const auto& entry : fs::recursive_directory_iterator(kAssimpModels)) {
    if (entry.is_regular_file() && entry.path().extension() == ".obj") objs.push_back(entry.path());
  }
  std::sort(objs.begin(), objs.end());
  ASSERT_FALSE(objs.empty());
  std::map<std::string, fs::path> source_of;
  for (size_t i = 0; i < objs.size(); ++i) {
    const std::string model = fmt::format("{:032x}", i);
    const fs::path model_dir = root / "00000000" / model;
    fs::create_directories(model_dir);
    for (const auto& sibling : fs::directory_iterator(objs[i].parent_path())) {
      if (sibling.is_regular_file()) fs::copy_file(sibling.path(), model_dir / sibling.path().filename());
    }
    fs::copy_file(objs[i], model_dir / "model.obj");
    source_of["00000000/" + model] = objs[i];
  }
  ConvertOptions options = TwoJobs();
  options.shapenet_version = 1;
  auto report = ShapeNet(root, dir.path() / "out", options);
  ASSERT_OK(report.status());
  EXPECT_EQ(report->assets, static_cast<int64_t>(objs.size()));
  int converted = 0, failed = 0;
  for (const auto& [key, row] : CatalogRows(dir.path() / "out")) {
    const std::string name = fs::relative(source_of[key], kAssimpModels).string();
    if (row.status == AssetStatus::kFailed) {
      ++failed;
      EXPECT_FALSE(row.file.has_value()) << name;
      EXPECT_FALSE(row.error_code.value_or("").empty()) << name;
      EXPECT_FALSE(row.error.value_or("").empty()) << name;
      std::printf("  failed %-40s %s: %s\n", name.c_str(), row.error_code.value_or("").c_str(),
                  row.error.value_or("").c_str());
      continue;
    }
    ++converted;
    ASSERT_TRUE(row.file.has_value()) << name;
    const Asset asset = ReadAsset(dir.path() / "out" / *row.file);
    EXPECT_EQ(static_cast<int64_t>(TriangleCount(asset)), row.triangles) << name;
    EXPECT_GT(row.triangles, 0) << name;
  }
  std::printf("assimp-testmodels: %zu OBJ files, %d converted, %d failed\n", objs.size(), converted, failed);
  EXPECT_EQ(converted + failed, static_cast<int>(objs.size()));
  EXPECT_GT(converted, 0);
}

// The team's six real ShapeNetCore.v2 models and SceneNet RGB-D layout (shared/testdata/real,
// README there): real files exercise what the fixture trees imitate. Optional: they may not
// be redistributed, so a user's clone skips these.
TEST(ConvertOnSharedData, RealShapeNetModelsConvertWithTheirMaterialsAndTexture) {
  SOLID_SHARED_TESTDATA_OR_SKIP(root, "real/shapenet");
  TempDir dir;
  auto report = ShapeNet(root, dir.path() / "out", TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->assets, 6);
  EXPECT_EQ(report->failed, 0);
  const auto rows = CatalogRows(dir.path() / "out");
  ASSERT_EQ(rows.size(), 6u);
  for (const auto& [key, row] : rows) {
    SCOPED_TRACE(key);
    EXPECT_EQ(row.source, "shapenet_v2");
    ASSERT_TRUE(row.file.has_value());
    const Asset asset = ReadAsset(dir.path() / "out" / *row.file);
    EXPECT_EQ(static_cast<int64_t>(TriangleCount(asset)), row.triangles);
    ASSERT_TRUE(row.bounds.has_value());
    // ShapeNet v2 normalises each model to a unit bounding-box diagonal, centred.
    const auto& b = *row.bounds;
    const double diagonal = std::hypot(b[3] - b[0], b[4] - b[1], b[5] - b[2]);
    EXPECT_NEAR(diagonal, 1.0, 0.02);
  }
  EXPECT_EQ(rows.at("04379243/142060f848466cad97ef9a13efb5e3f7").textures, 1) << "the table's texture0.jpg";
  EXPECT_GE(rows.at("02958343/2cbe6850de4fa5a34a6a7ab072f22d7d").materials, 2) << "the car's materials";
}

TEST(ConvertOnSharedData, SceneNetRgbdLayoutKeepsWallsFloorAndCeiling) {
  SOLID_SHARED_TESTDATA_OR_SKIP(root, "real/scenenet-rgbd");
  TempDir dir;
  auto report = SceneNet(root, dir.path() / "out", TwoJobs());
  ASSERT_OK(report.status());
  EXPECT_EQ(report->assets, 1);
  EXPECT_EQ(report->failed, 0);
  const auto rows = CatalogRows(dir.path() / "out");
  ASSERT_EQ(rows.count("bathroom11_layout"), 1u);
  const CatalogEntry& room = rows.at("bathroom11_layout");
  ASSERT_TRUE(room.file.has_value());
  std::set<std::string> structure;
  for (const auto& n : ReadAsset(dir.path() / "out" / *room.file).nodes) {
    structure.insert(n.extras.value("structure", ""));
  }
  for (const char* kind : {"wall", "floor", "ceiling"}) EXPECT_EQ(structure.count(kind), 1u) << kind;
  EXPECT_GT(room.extras["height_m"].get<double>(), 2.0);
}

}  // namespace
}  // namespace solid::convert
