// BuildAssetFromObj against the single-quirk fixtures of input-formats section 5.3,
// built as ObjData/MtlData in code so that they test the cleaning rules, not ReadObj.
#include "obj_to_asset.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "fixtures/crafted_images.h"
#include "formats/test_util.h"
#include "solid/formats/glb.h"
#include "solid/formats/image_codec.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace {

namespace fs = std::filesystem;
using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::FloatEq;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

ObjCorner C(int64_t v, int64_t vt = -1, int64_t vn = -1) { return {.v = v, .vt = vt, .vn = vn}; }

// An OBJ under construction; triangles get consecutive source lines from 10 on.
struct ObjFixture {
  int64_t V(double x, double y, double z) {
    obj.positions.push_back({x, y, z});
    return static_cast<int64_t>(obj.positions.size()) - 1;
  }
  int64_t Vt(double u, double v) {
    obj.uvs.push_back({u, v});
    return static_cast<int64_t>(obj.uvs.size()) - 1;
  }
  int64_t Vn(double x, double y, double z) {
    obj.normals.push_back({x, y, z});
    return static_cast<int64_t>(obj.normals.size()) - 1;
  }
  void Block(std::string material, std::string object = "", std::string group = "") {
    obj.blocks.push_back({.object = std::move(object), .group = std::move(group), .material = std::move(material)});
  }
  void Tri(ObjCorner a, ObjCorner b, ObjCorner c) {
    obj.blocks.back().triangles.push_back({.corners = {a, b, c}, .line = next_line++});
  }
  // A unit triangle in the z = z0 plane, counter-clockwise seen from +Z.
  void FlatTri(double z0 = 0) { Tri(C(V(0, 0, z0)), C(V(1, 0, z0)), C(V(0, 1, z0))); }

  ObjData obj;
  uint32_t next_line = 10;
};

// The corners of the unit cube's 12 outward triangles, positions x + 2y + 4z, with the
// normal indices of `outward[face]`.
void AddCube(ObjFixture* f, const std::array<int64_t, 6>& outward, bool reversed_twins,
             const std::array<int64_t, 6>& inward = {}) {
  for (int i = 0; i < 8; ++i) f->V(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const int64_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (size_t face = 0; face < 6; ++face) {
    const int64_t* q = quads[face];
    for (const auto& [a, b, c] : {std::tuple{q[0], q[1], q[2]}, std::tuple{q[0], q[2], q[3]}}) {
      f->Tri(C(a, -1, outward[face]), C(b, -1, outward[face]), C(c, -1, outward[face]));
      if (reversed_twins) f->Tri(C(a, -1, inward[face]), C(c, -1, inward[face]), C(b, -1, inward[face]));
    }
  }
}

const std::array<std::array<double, 3>, 6> kCubeNormals = {
    {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

std::array<int64_t, 6> AddCubeNormals(ObjFixture* f, double sign) {
  std::array<int64_t, 6> indices;
  for (size_t i = 0; i < 6; ++i) {
    indices[i] = f->Vn(sign * kCubeNormals[i][0], sign * kCubeNormals[i][1], sign * kCubeNormals[i][2]);
  }
  return indices;
}

ObjAssetOptions Options() {
  ObjAssetOptions options;
  options.node_name = "02691156/0123456789abcdef0123456789abcdef";
  options.obj_name = "model.obj";
  options.mtl_name = "model.mtl";
  return options;
}

MtlMaterial Mtl(std::string name, std::array<double, 3> kd = {0.8, 0.8, 0.8}, double d = 1.0) {
  return {.name = std::move(name), .kd = kd, .d = d, .line = 3};
}

std::vector<std::string> WarningCodes(const ObjAsset& a) {
  std::vector<std::string> codes;
  for (const ConvertWarning& w : a.warnings) codes.push_back(w.code);
  return codes;
}

std::array<float, 3> NormalOf(const Primitive& p, uint32_t vertex) {
  return {p.normals[3 * vertex], p.normals[3 * vertex + 1], p.normals[3 * vertex + 2]};
}

float LengthOf(const std::array<float, 3>& n) { return std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]); }

#define ASSERT_BUILT(result) ASSERT_TRUE((result).ok()) << (result).status().ToString()

TEST(ObjToAsset, ReversedTwinsAreKept) {
  ObjFixture f;
  f.Block("material_0_24");
  const auto outward = AddCubeNormals(&f, 1), inward = AddCubeNormals(&f, -1);
  AddCube(&f, outward, /*reversed_twins=*/true, inward);
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->counts.triangles_in, 24u);
  EXPECT_EQ(r->counts.triangles_out, 24u);
  EXPECT_EQ(r->counts.reversed_twins, 12u);
  EXPECT_EQ(r->counts.duplicates_removed, 0u);
  EXPECT_EQ(TriangleCount(r->asset), 24u);
  ASSERT_EQ(r->asset.nodes.size(), 1u);
  const Primitive& p = r->asset.nodes[0].primitives.at(0);
  EXPECT_EQ(p.positions.size() / 3, 48u);  // 4 corners per side, outward and inward
  // Every twin faces away from its partner: its normal is the partner's, negated.
  for (size_t t = 0; t < p.indices.size(); t += 6) {
    const auto front = NormalOf(p, p.indices[t]), back = NormalOf(p, p.indices[t + 3]);
    for (size_t k = 0; k < 3; ++k) EXPECT_EQ(front[k], -back[k]) << "triangle " << t / 3;
  }
}

TEST(ObjToAsset, SameWindingDuplicatesAreRemoved) {
  ObjFixture f;
  f.Block("material_0_24");
  AddCube(&f, AddCubeNormals(&f, 1), false);
  const ObjTriangle first = f.obj.blocks[0].triangles[0], second = f.obj.blocks[0].triangles[1];
  const auto& s = second.corners;
  f.Tri(first.corners[0], first.corners[1], first.corners[2]);  // exact
  f.Tri(s[1], s[2], s[0]);                                       // rotated
  f.Tri(C(first.corners[0].v, f.Vt(0, 0), first.corners[0].vn), first.corners[1], first.corners[2]);  // other vt
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->counts.triangles_in, 15u);
  EXPECT_EQ(r->counts.duplicates_removed, 2u);
  EXPECT_EQ(r->counts.triangles_out, 13u);
  EXPECT_EQ(r->counts.reversed_twins, 0u);
}

TEST(ObjToAsset, DegenerateTrianglesAreRemoved) {
  ObjFixture f;
  f.Block("material_0_24");
  f.FlatTri();
  const int64_t a = f.V(0, 0, 1), b = f.V(1, 1, 1), c = f.V(2, 2, 1);
  f.Tri(C(a), C(a), C(b));  // repeated index
  f.Tri(C(a), C(b), C(c));  // collinear: zero cross product
  f.Tri(C(a), C(b), C(f.V(0, 0, 1)));  // distinct indices, equal positions
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->counts.degenerates_removed, 3u);
  EXPECT_EQ(r->counts.triangles_out, 1u);
  EXPECT_EQ(VertexCount(r->asset), 3u);
}

TEST(ObjToAsset, NonUnitNormalsAreRenormalisedAndZeroNormalsTakeTheFaceNormal) {
  ObjFixture f;
  f.Block("material_0_24");
  // ShapeNet's COLLADA unit scale: every vn has length 0.0254 (and tiny components).
  const int64_t scaled = f.Vn(0, 0, 0.0254), tiny = f.Vn(4.19608e-05, 0, 0), zero = f.Vn(0, 0, 0);
  f.Tri(C(f.V(0, 0, 0), -1, scaled), C(f.V(1, 0, 0), -1, scaled), C(f.V(0, 1, 0), -1, tiny));
  // A triangle facing -Y whose last corner has a zero normal.
  f.Tri(C(f.V(0, 0, 5), -1, scaled), C(f.V(1, 0, 5), -1, scaled), C(f.V(0, 0, 6), -1, zero));
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->counts.normals_renormalized, 5u);
  EXPECT_EQ(r->counts.zero_normals, 1u);
  EXPECT_EQ(r->counts.normals_from_geometry, 0u);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  ASSERT_EQ(p.normals.size(), p.positions.size());
  for (uint32_t v = 0; v < p.positions.size() / 3; ++v) EXPECT_NEAR(LengthOf(NormalOf(p, v)), 1.0f, 1e-6f);
  EXPECT_THAT(NormalOf(p, p.indices[0]), ElementsAre(0.0f, 0.0f, 1.0f));
  EXPECT_THAT(NormalOf(p, p.indices[2]), ElementsAre(1.0f, 0.0f, 0.0f));
  EXPECT_THAT(NormalOf(p, p.indices[5]), ElementsAre(0.0f, -1.0f, 0.0f));
}

TEST(ObjToAsset, UvTilingIsKeptAndVIsFlipped) {
  ObjFixture f;
  f.Block("material_5_1_8");
  f.Tri(C(f.V(0, 0, 0), f.Vt(-53.7, 51.0)), C(f.V(1, 0, 0), f.Vt(55.9, -48.1)), C(f.V(0, 1, 0), f.Vt(3.75, -0.0)));
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  EXPECT_THAT(p.uvs, ElementsAre(FloatEq(-53.7f), FloatEq(-50.0f), FloatEq(55.9f), FloatEq(49.1f), FloatEq(3.75f),
                                 FloatEq(1.0f)));
  EXPECT_THAT(p.normals, IsEmpty());
  EXPECT_EQ(r->counts.uvs_filled, 0u);
}

TEST(ObjToAsset, MixedCornersShareOnePrimitiveWithUvAndNormalFill) {
  ObjFixture f;
  f.Block("material_0_24");
  const int64_t vn = f.Vn(0, 0, 1), vt = f.Vt(0.25, 0.75);
  const int64_t a = f.V(0, 0, 0), b = f.V(1, 0, 0), c = f.V(0, 1, 0), d = f.V(1, 1, 0);
  f.Tri(C(a, vt, vn), C(b, vt, vn), C(c, vt, vn));  // v/vt/vn
  f.Tri(C(b, -1, vn), C(d, -1, vn), C(c, -1, vn));  // v//vn
  f.Tri(C(a, vt), C(c, -1), C(f.V(-1, 0, 0), -1));  // v/vt and v: normals from geometry
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  ASSERT_EQ(r->asset.nodes[0].primitives.size(), 1u);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  EXPECT_EQ(r->counts.uvs_filled, 5u);
  EXPECT_EQ(r->counts.normals_from_geometry, 3u);
  // a/vt/vn, b/vt/vn, c/vt/vn, b//vn, d//vn, c//vn, a/vt/-, c/-/-, e/-/-
  EXPECT_EQ(p.positions.size() / 3, 9u);
  EXPECT_EQ(p.uvs.size() / 2, 9u);
  EXPECT_EQ(p.uvs[2 * p.indices[3]], 0.0f);  // OBJ (0, 0) is glTF (0, 1)
  EXPECT_EQ(p.uvs[2 * p.indices[3] + 1], 1.0f);
  EXPECT_FLOAT_EQ(p.uvs[2 * p.indices[0] + 1], 0.25f);
  EXPECT_THAT(NormalOf(p, p.indices[6]), ElementsAre(0.0f, 0.0f, 1.0f));
}

TEST(ObjToAsset, NoUvMeansNoTexcoords) {
  ObjFixture f;
  f.Block("material_0_24");
  const int64_t vn = f.Vn(0, 0, 1);
  f.Tri(C(f.V(0, 0, 0), -1, vn), C(f.V(1, 0, 0), -1, vn), C(f.V(0, 1, 0), -1, vn));
  const MtlData mtl{.materials = {Mtl("material_0_24")}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  EXPECT_THAT(p.uvs, IsEmpty());
  EXPECT_EQ(p.normals.size(), 9u);
  EXPECT_EQ(r->counts.uvs_filled, 0u);
}

TEST(ObjToAsset, LineOnlyGroupIsDroppedAndBoundsComeFromTriangles) {
  ObjFixture f;
  f.Block("material_0_24", "", "mesh1_mesh1-geometry");
  f.FlatTri();
  f.Block("material_1_0", "", "mesh2");
  f.obj.blocks.back().line_records = 2;
  f.V(5, -3, 7);  // line vertices outside the triangles' box
  f.V(-4, 2, 9);
  const MtlData mtl{.materials = {Mtl("material_0_24"), Mtl("material_1_0", {0, 0, 0})}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->counts.empty_blocks_dropped, 1u);
  ASSERT_EQ(r->asset.materials.size(), 1u);
  EXPECT_EQ(r->asset.materials[0].name, "material_0_24");
  EXPECT_EQ(r->asset.nodes[0].primitives.size(), 1u);
  const Bounds bounds = ComputeBounds(r->asset);
  EXPECT_THAT(bounds.min, ElementsAre(0.0, 0.0, 0.0));
  EXPECT_THAT(bounds.max, ElementsAre(1.0, 1.0, 0.0));
}

TEST(ObjToAsset, RepeatedGroupNameKeepsOnePrimitivePerMaterialInFirstUseOrder) {
  ObjFixture f;
  f.Block("material_3_0", "", "mesh1");
  f.FlatTri(0);
  f.Block("material_1_0", "", "mesh2");
  f.FlatTri(1);
  f.Block("material_3_0", "", "mesh1");
  f.FlatTri(2);
  f.Block("material_2_0", "", "mesh1");
  f.FlatTri(3);
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  ASSERT_EQ(r->asset.nodes.size(), 1u);
  const Node& node = r->asset.nodes[0];
  EXPECT_EQ(node.name, "02691156/0123456789abcdef0123456789abcdef");
  ASSERT_EQ(node.primitives.size(), 3u);
  std::vector<std::string> names;
  for (const Primitive& p : node.primitives) names.push_back(r->asset.materials.at(*p.material).name);
  EXPECT_THAT(names, ElementsAre("material_3_0", "material_1_0", "material_2_0"));
  EXPECT_EQ(node.primitives[0].indices.size(), 6u);
}

TEST(ObjToAsset, EmptyGeometryFails) {
  ObjFixture f;
  f.Block("material_1_0");
  f.obj.blocks.back().line_records = 3;
  f.Block("material_0_24");
  const int64_t a = f.V(0, 0, 0);
  f.Tri(C(a), C(a), C(f.V(1, 0, 0)));
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kCorrupt);
  EXPECT_THAT(r.status().message(), HasSubstr("model.obj: empty_geometry"));
  EXPECT_FALSE(BuildAssetFromObj(ObjData{}, nullptr, Options()).ok());
}

TEST(ObjToAsset, IndexOutOfRangeFailsWithTheLine) {
  ObjFixture f;
  f.Block("m");
  f.Tri(C(f.V(0, 0, 0)), C(f.V(1, 0, 0)), C(f.V(0, 1, 0), -1, 0));  // no vn defined
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kCorrupt);
  EXPECT_THAT(r.status().message(), HasSubstr("model.obj:10: index_out_of_range"));
}

TEST(ObjToAsset, TransparentMaterialBlends) {
  ObjFixture f;
  f.Block("material_0_24");
  f.FlatTri(0);
  f.Block("material_2_0");
  f.FlatTri(1);
  const MtlData mtl{.materials = {Mtl("material_0_24", {0.5, 0.25, 1.5}, 0.5), Mtl("material_2_0", {0.1, 0.2, 0.3})}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  ASSERT_EQ(r->asset.materials.size(), 2u);
  const Material& glass = r->asset.materials[0];
  EXPECT_TRUE(glass.blend);
  EXPECT_THAT(glass.base_color, ElementsAre(0.5f, 0.25f, 1.0f, 0.5f));  // Kd clamped to glTF's [0, 1]
  EXPECT_EQ(glass.metallic, 0.0f);
  EXPECT_FALSE(glass.double_sided);
  EXPECT_FALSE(r->asset.materials[1].blend);
  EXPECT_THAT(r->asset.materials[1].base_color, ElementsAre(0.1f, 0.2f, 0.3f, 1.0f));
  EXPECT_THAT(r->warnings, IsEmpty());
}

TEST(ObjToAsset, MissingMtlGivesDefaultMaterialsAndOneWarning) {
  ObjFixture f;
  f.obj.mtllibs = {"model_normalized.mtl"};
  f.Block("material_0_24");
  f.FlatTri(0);
  f.Block("material_1_0");
  f.FlatTri(1);
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("missing_mtl"));
  EXPECT_THAT(r->warnings[0].message, HasSubstr("model_normalized.mtl"));
  ASSERT_EQ(r->asset.materials.size(), 2u);
  EXPECT_EQ(r->asset.materials[1].name, "material_1_0");
  EXPECT_THAT(r->asset.materials[1].base_color, ElementsAre(0.8f, 0.8f, 0.8f, 1.0f));
}

// assimp-testmodels regr01.mtl names a material "Terraind\xe6k" (Latin-1): the writer
// refused it ("materials[8]: name: not valid UTF-8") and the model failed.
TEST(ObjToAsset, Regr01_Latin1NamesAreReadAsLatin1AndWellFormedUtf8IsKept) {
  ObjFixture f;
  f.Block("Terraind\xe6k", "h\xf8j");
  f.FlatTri(0);
  f.Block("\xd1\x81\xd1\x82\xd0\xb5\xd0\xbd\xd0\xb0", "ok");  // "стена"
  f.FlatTri(1);
  f.Block("overlong\xc0\xaf", "cut\xe2\x82");  // an overlong '/' and a truncated sequence
  f.FlatTri(2);
  const MtlData mtl{.materials = {Mtl("Terraind\xe6k"), Mtl("\xd1\x81\xd1\x82\xd0\xb5\xd0\xbd\xd0\xb0"),
                                  Mtl("overlong\xc0\xaf")}};
  ObjAssetOptions options = Options();
  options.grouping = NodeGrouping::kPerObject;
  const auto r = BuildAssetFromObj(f.obj, &mtl, options);
  ASSERT_BUILT(r);
  ASSERT_EQ(r->asset.materials.size(), 3u);
  EXPECT_EQ(r->asset.materials[0].name, "Terraind\xc3\xa6k");
  EXPECT_EQ(r->asset.materials[1].name, "\xd1\x81\xd1\x82\xd0\xb5\xd0\xbd\xd0\xb0");
  EXPECT_EQ(r->asset.materials[2].name, "overlong\xc3\x80\xc2\xaf");
  ASSERT_EQ(r->asset.nodes.size(), 3u);
  EXPECT_EQ(r->asset.nodes[0].name, "h\xc3\xb8j");
  EXPECT_EQ(r->asset.nodes[2].name, "cut\xc3\xa2\xc2\x82");
  EXPECT_THAT(WarningCodes(*r), ElementsAre("name_not_utf8", "name_not_utf8", "name_not_utf8", "name_not_utf8"));
  EXPECT_THAT(r->warnings[0].message, HasSubstr("model.obj: object name 'h\xc3\xb8j' is not UTF-8"));
  EXPECT_OK(WriteGlb(r->asset).status());
}

TEST(ObjToAsset, UndefinedUsemtlGivesADefaultMaterialOfThatName) {
  ObjFixture f;
  f.Block("material_0_24");
  f.FlatTri(0);
  f.Block("Material.001");
  f.FlatTri(1);  // line 11
  f.Block("Material.001");
  f.FlatTri(2);
  const MtlData mtl{.materials = {Mtl("material_0_24", {0, 0, 1})}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("undefined_material"));
  EXPECT_THAT(r->warnings[0].message, HasSubstr("model.obj:11: usemtl 'Material.001'"));
  ASSERT_EQ(r->asset.materials.size(), 2u);
  EXPECT_EQ(r->asset.materials[1].name, "Material.001");
  EXPECT_THAT(r->asset.materials[1].base_color, ElementsAre(0.8f, 0.8f, 0.8f, 1.0f));
  EXPECT_EQ(r->asset.nodes[0].primitives[1].indices.size(), 6u);
}

TEST(ObjToAsset, NoUsemtlWithSeveralMaterialsGetsNoMaterial) {
  ObjFixture f;
  f.Block("");
  f.FlatTri();
  const MtlData mtl{.materials = {Mtl("a"), Mtl("b")}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  EXPECT_FALSE(r->asset.nodes[0].primitives[0].material.has_value());
  EXPECT_THAT(r->asset.materials, IsEmpty());
  EXPECT_THAT(r->warnings, IsEmpty());
}

TEST(ObjToAsset, NoUsemtlWithTheSoleMaterialUsesIt) {
  ObjFixture f;
  f.Block("");
  f.FlatTri(0);
  f.Block("only");
  f.FlatTri(1);
  const MtlData mtl{.materials = {Mtl("only", {1, 0, 0})}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, Options());
  ASSERT_BUILT(r);
  ASSERT_EQ(r->asset.nodes[0].primitives.size(), 1u);
  EXPECT_EQ(r->asset.nodes[0].primitives[0].material, 0u);
  EXPECT_EQ(r->asset.nodes[0].primitives[0].indices.size(), 6u);
  ASSERT_EQ(r->asset.materials.size(), 1u);
  EXPECT_EQ(r->asset.materials[0].name, "only");
}

TEST(ObjToAsset, WeldingMakesOneVertexPerDistinctCorner) {
  ObjFixture f;
  f.Block("m");
  const int64_t up = f.Vn(0, 0, 1), up_again = f.Vn(0, 0, 1), t0 = f.Vt(0, 0), t1 = f.Vt(1, 0);
  const int64_t a = f.V(0, 0, 0), b = f.V(1, 0, 0), c = f.V(0, 1, 0), d = f.V(1, 1, 0);
  f.Tri(C(a, t0, up), C(b, t0, up), C(c, t0, up));
  f.Tri(C(b, t0, up), C(d, t0, up), C(c, t0, up));       // shares b and c: 1 new vertex
  f.Tri(C(b, t1, up), C(d, t0, up_again), C(c, t0, up));  // new (b, t1) and (d, up_again)
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  EXPECT_EQ(p.positions.size() / 3, 6u);
  EXPECT_THAT(p.indices, ElementsAre(0, 1, 2, 1, 3, 2, 4, 5, 2));
}

TEST(ObjToAsset, GeometricNormalsAreNotWeldedAcrossFacesOfDifferentOrientation) {
  ObjFixture f;
  f.Block("m");
  const int64_t vn = f.Vn(0, 0, 1);
  const int64_t a = f.V(0, 0, 0), b = f.V(1, 0, 0), c = f.V(0, 1, 0), e = f.V(0, 0, 1);
  f.Tri(C(a, -1, vn), C(b, -1, vn), C(c, -1, vn));
  f.Tri(C(a), C(b), C(e));            // faces -Y: a and b need vertices of their own
  f.Tri(C(a), C(e), C(c));            // faces -X: a and e again, with another normal
  f.Tri(C(b), C(f.V(1, 0, 1)), C(e));  // faces -Y too: shares b and e with the second
  const auto r = BuildAssetFromObj(f.obj, nullptr, Options());
  ASSERT_BUILT(r);
  const Primitive& p = r->asset.nodes[0].primitives[0];
  EXPECT_EQ(r->counts.normals_from_geometry, 9u);
  EXPECT_EQ(p.positions.size() / 3, 10u);
  EXPECT_THAT(p.indices, ElementsAre(0, 1, 2, 3, 4, 5, 6, 7, 8, 4, 9, 5));
  EXPECT_THAT(NormalOf(p, 3), ElementsAre(0.0f, -1.0f, 0.0f));
  EXPECT_THAT(NormalOf(p, 6), ElementsAre(-1.0f, 0.0f, 0.0f));
}

// SceneNet: one node per object.
TEST(ObjToAsset, PerObjectNodesRenameLaterDuplicates) {
  ObjFixture f;
  f.Block("wall", "wall.034");
  f.FlatTri(0);
  f.Block("wood", "wall.034");  // the same object continues with another material
  f.FlatTri(1);
  f.Block("", "bed");
  f.FlatTri(2);
  f.Block("floor", "floor_enclose");  // only `l`
  f.obj.blocks.back().line_records = 4;
  f.Block("wall", "wall.034");
  f.FlatTri(3);
  f.Block("wall", "", "Walls.132");  // no `o`: the group names it
  f.FlatTri(4);
  f.Block("", "a");
  f.FlatTri(5);
  f.Block("", "a");
  f.FlatTri(6);
  f.Block("", "b");
  f.FlatTri(7);
  f.Block("", "a");
  f.FlatTri(8);
  f.Block("", "a.001");
  f.FlatTri(9);
  ObjAssetOptions options = Options();
  options.grouping = NodeGrouping::kPerObject;
  const MtlData mtl{.materials = {Mtl("wall"), Mtl("wood"), Mtl("floor")}};
  const auto r = BuildAssetFromObj(f.obj, &mtl, options);
  ASSERT_BUILT(r);
  std::vector<std::string> names;
  for (const Node& n : r->asset.nodes) names.push_back(n.name);
  EXPECT_THAT(names, ElementsAre("wall.034", "bed", "wall.034.001", "Walls.132", "a", "b", "a.002", "a.001"));
  EXPECT_EQ(r->asset.nodes[0].primitives.size(), 2u);
  ASSERT_EQ(r->asset.nodes[1].primitives.size(), 1u);
  EXPECT_FALSE(r->asset.nodes[1].primitives[0].material.has_value());
  EXPECT_EQ(r->asset.materials.size(), 2u);  // wall, wood; floor is unused
  EXPECT_EQ(r->counts.empty_blocks_dropped, 1u);
  EXPECT_EQ(r->counts.triangles_out, 10u);
}

TEST(ObjToAsset, PerObjectKeepFilter) {
  ObjFixture f;
  for (const char* name : {"wall.034", "bed", "floor.004", "wall.034"}) {
    f.Block("", name);
    f.FlatTri();
  }
  ObjAssetOptions options = Options();
  options.grouping = NodeGrouping::kPerObject;
  std::vector<std::string> asked;
  options.keep_object = [&asked](const std::string& name) {
    asked.push_back(name);
    return name.starts_with("wall") || name.starts_with("floor");
  };
  const auto r = BuildAssetFromObj(f.obj, nullptr, options);
  ASSERT_BUILT(r);
  EXPECT_THAT(asked, ElementsAre("wall.034", "bed", "floor.004", "wall.034.001"));
  std::vector<std::string> names;
  for (const Node& n : r->asset.nodes) names.push_back(n.name);
  EXPECT_THAT(names, ElementsAre("wall.034", "floor.004", "wall.034.001"));
  EXPECT_EQ(r->counts.triangles_in, 4u);
  EXPECT_EQ(r->counts.triangles_out, 3u);

  options.keep_object = [](const std::string&) { return false; };
  const auto none = BuildAssetFromObj(f.obj, nullptr, options);
  ASSERT_FALSE(none.ok());
  EXPECT_THAT(none.status().message(), HasSubstr("empty_geometry"));
}

// Textures: a model folder <tmp>/model with models/ (OBJ, MTL) and images/.
class ObjTextureTest : public ::testing::Test {
 protected:
  ObjTextureTest() : root_(tmp_.path() / "model"), models_(root_ / "models"), images_(root_ / "images") {
    fs::create_directories(models_);
    fs::create_directories(images_);
    f_.Block("textured");
    f_.Tri(C(f_.V(0, 0, 0), f_.Vt(0, 0)), C(f_.V(1, 0, 0), f_.Vt(1, 0)), C(f_.V(0, 1, 0)));
  }

  static std::vector<uint8_t> EncodedImage(ImageFormat format) {
    Image8 image{.width = 4, .height = 4, .channels = 3, .pixels = std::vector<uint8_t>(48, 200)};
    auto bytes = EncodeImage(image, format);
    EXPECT_TRUE(bytes.ok()) << bytes.status().ToString();
    return bytes.ok() ? *bytes : std::vector<uint8_t>{};
  }

  static void Write(const fs::path& path, const std::vector<uint8_t>& bytes) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                static_cast<std::streamsize>(bytes.size()));
  }

  ObjAssetOptions TextureOptions() const {
    ObjAssetOptions options = Options();
    options.mtl_dir = models_;
    options.confine_root = root_;
    return options;
  }

  // One material "textured" with map_Kd `path`.
  Result<ObjAsset> BuildWith(const std::string& path, const ObjAssetOptions& options) {
    mtl_.materials = {Mtl("textured", {1, 1, 1})};
    mtl_.materials[0].map_kd = path;
    return BuildAssetFromObj(f_.obj, &mtl_, options);
  }
  Result<ObjAsset> BuildWith(const std::string& path) { return BuildWith(path, TextureOptions()); }

  solid::testing::TempDir tmp_;
  fs::path root_, models_, images_;
  ObjFixture f_;
  MtlData mtl_;
};

TEST_F(ObjTextureTest, TextureIsEmbeddedAndUvsFilled) {
  const std::vector<uint8_t> jpeg = EncodedImage(ImageFormat::kJpeg);
  Write(images_ / "texture0.jpg", jpeg);
  const auto r = BuildWith("../images/texture0.jpg");
  ASSERT_BUILT(r);
  EXPECT_THAT(r->warnings, IsEmpty());
  ASSERT_EQ(r->asset.textures.size(), 1u);
  EXPECT_EQ(r->asset.textures[0].name, "texture0.jpg");
  EXPECT_EQ(r->asset.textures[0].mime_type, "image/jpeg");
  EXPECT_EQ(r->asset.textures[0].bytes, jpeg);
  EXPECT_EQ(r->asset.materials.at(0).base_color_texture, 0u);
  EXPECT_THAT(r->asset.materials[0].base_color, ElementsAre(1.0f, 1.0f, 1.0f, 1.0f));
  EXPECT_EQ(r->counts.textures_embedded, 1u);
  EXPECT_EQ(r->counts.uvs_filled, 1u);
}

TEST_F(ObjTextureTest, MissingTextureFallsBackToKd) {
  const auto r = BuildWith("../images/texture4.jpg");
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("missing_texture"));
  EXPECT_THAT(r->warnings[0].message, HasSubstr("model.mtl:3: material 'textured': map_Kd '../images/texture4.jpg'"));
  EXPECT_EQ(r->counts.textures_missing, 1u);
  EXPECT_THAT(r->asset.textures, IsEmpty());
  EXPECT_FALSE(r->asset.materials[0].base_color_texture.has_value());
  // Still textured: SceneNet and later texture swaps need the UVs.
  EXPECT_EQ(r->asset.nodes[0].primitives[0].uvs.size(), 6u);
}

TEST_F(ObjTextureTest, TextureCase) {
  // `.JPG` is a JPEG (by its bytes), and a name differing only in case is found.
  Write(images_ / "texture1.JPG", EncodedImage(ImageFormat::kJpeg));
  const auto exact = BuildWith("../images/texture1.JPG");
  ASSERT_BUILT(exact);
  EXPECT_THAT(exact->warnings, IsEmpty());
  ASSERT_EQ(exact->asset.textures.size(), 1u);
  EXPECT_EQ(exact->asset.textures[0].mime_type, "image/jpeg");

  const auto folded = BuildWith("../images/Texture1.jpg");
  ASSERT_BUILT(folded);
  EXPECT_THAT(WarningCodes(*folded), ElementsAre("texture_case_mismatch"));
  ASSERT_EQ(folded->asset.textures.size(), 1u);
  EXPECT_EQ(folded->asset.textures[0].name, "texture1.JPG");
  EXPECT_EQ(folded->counts.textures_embedded, 1u);
}

TEST_F(ObjTextureTest, FormatComesFromMagicBytes) {
  Write(images_ / "really_png.jpg", EncodedImage(ImageFormat::kPng));
  Write(images_ / "texture.gif", {'G', 'I', 'F', '8', '9', 'a', 0, 0, 0, 0});
  const auto png = BuildWith("../images/really_png.jpg");
  ASSERT_BUILT(png);
  ASSERT_EQ(png->asset.textures.size(), 1u);
  EXPECT_EQ(png->asset.textures[0].mime_type, "image/png");

  const auto gif = BuildWith("../images/texture.gif");
  ASSERT_BUILT(gif);
  EXPECT_THAT(WarningCodes(*gif), ElementsAre("unsupported_texture"));
  EXPECT_EQ(gif->counts.textures_rejected, 1u);
  EXPECT_THAT(gif->asset.textures, IsEmpty());
}

TEST_F(ObjTextureTest, TooLargeTextureIsRejected) {
  Write(images_ / "big.png", EncodedImage(ImageFormat::kPng));
  ObjAssetOptions options = TextureOptions();
  options.max_texture_bytes = 16;
  const auto r = BuildWith("../images/big.png", options);
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("texture_too_large"));
  EXPECT_EQ(r->counts.textures_rejected, 1u);
  EXPECT_THAT(r->asset.textures, IsEmpty());
}

TEST_F(ObjTextureTest, PngHeaderClaiming100000x100000IsRejectedBeforeDecoding) {
  Write(images_ / "bomb.png", fixtures::PngClaimingSize(100000, 100000));
  const auto r = BuildWith("../images/bomb.png");
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("texture_too_large"));
  EXPECT_THAT(r->warnings[0].message, HasSubstr("map_Kd '../images/bomb.png': 100000x100000 pixels, over the limits "
                                                "of 8192 per side and 33554432 pixels"));
  EXPECT_EQ(r->counts.textures_rejected, 1u);
  EXPECT_THAT(r->asset.textures, IsEmpty());
}

TEST_F(ObjTextureTest, MapKdDirectory) {
  const auto r = BuildWith("../");
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("texture_is_directory"));
  EXPECT_EQ(r->counts.textures_rejected, 1u);
  EXPECT_FALSE(r->asset.materials[0].base_color_texture.has_value());

  // SceneNet names a texture_library category: a directory is what it should be.
  fs::create_directories(root_ / "texture_library" / "wall");
  Write(root_ / "texture_library" / "wall" / "0123.jpg", EncodedImage(ImageFormat::kJpeg));
  ObjAssetOptions validate = TextureOptions();
  validate.textures = TextureMode::kValidateOnly;
  const auto scenenet = BuildWith("../texture_library/wall", validate);
  ASSERT_BUILT(scenenet);
  EXPECT_THAT(scenenet->warnings, IsEmpty());
  EXPECT_EQ(scenenet->counts.textures_rejected, 0u);
  EXPECT_EQ(scenenet->asset.nodes[0].primitives[0].uvs.size(), 6u);
}

TEST_F(ObjTextureTest, ValidateOnlyReportsButEmbedsNothing) {
  Write(images_ / "t.jpg", EncodedImage(ImageFormat::kJpeg));
  ObjAssetOptions validate = TextureOptions();
  validate.textures = TextureMode::kValidateOnly;
  const auto found = BuildWith("../images/t.jpg", validate);
  ASSERT_BUILT(found);
  EXPECT_THAT(found->warnings, IsEmpty());
  EXPECT_THAT(found->asset.textures, IsEmpty());
  EXPECT_FALSE(found->asset.materials[0].base_color_texture.has_value());

  const auto missing = BuildWith("missing.jpg", validate);
  ASSERT_BUILT(missing);
  EXPECT_THAT(WarningCodes(*missing), ElementsAre("missing_texture"));
  const auto absolute = BuildWith("/abs/missing.jpg", validate);
  ASSERT_BUILT(absolute);
  EXPECT_THAT(WarningCodes(*absolute), ElementsAre("texture_path_rejected"));
}

TEST_F(ObjTextureTest, TextureEscapeIsRefused) {
  const std::vector<uint8_t> jpeg = EncodedImage(ImageFormat::kJpeg);
  Write(tmp_.path() / "x.jpg", jpeg);  // exists, outside the model folder
  Write(tmp_.path() / "outside" / "x.jpg", jpeg);
  fs::create_symlink(tmp_.path() / "x.jpg", images_ / "link.jpg");
  fs::create_directory_symlink(tmp_.path() / "outside", root_ / "linked_dir");
  for (const std::string path : {"../../x.jpg", "../../../x.jpg", "/abs/x.jpg", "C:\\x.jpg", "C:x.jpg",
                                 "//server/share/x.jpg", "http://example.com/x.jpg", "file:///x.jpg",
                                 "../images/../../x.jpg", "../images/link.jpg", "../linked_dir/x.jpg",
                                 "../images/LINK.jpg"}) {
    const auto r = BuildWith(path);
    ASSERT_BUILT(r);
    EXPECT_THAT(WarningCodes(*r), Contains("texture_path_rejected")) << path;
    EXPECT_EQ(r->counts.textures_rejected, 1u) << path;
    EXPECT_THAT(r->asset.textures, IsEmpty()) << path;
  }
}

TEST_F(ObjTextureTest, BackslashPathIsResolved) {
  Write(images_ / "t.jpg", EncodedImage(ImageFormat::kJpeg));
  const auto r = BuildWith("..\\images\\t.jpg");
  ASSERT_BUILT(r);
  EXPECT_THAT(r->warnings, IsEmpty());
  EXPECT_EQ(r->asset.textures.size(), 1u);
}

TEST_F(ObjTextureTest, MapDIsReportedNotApplied) {
  Write(images_ / "t.png", EncodedImage(ImageFormat::kPng));
  mtl_.materials = {Mtl("textured", {1, 1, 1}, 0.5)};
  mtl_.materials[0].map_kd = "../images/t.png";
  mtl_.materials[0].map_d = "../images/t_alpha.png";
  const auto r = BuildAssetFromObj(f_.obj, &mtl_, TextureOptions());
  ASSERT_BUILT(r);
  EXPECT_THAT(WarningCodes(*r), ElementsAre("alpha_map_ignored"));
  EXPECT_EQ(r->asset.textures.size(), 1u);
  EXPECT_TRUE(r->asset.materials[0].blend);
}

TEST_F(ObjTextureTest, OneFileIsEmbeddedOnce) {
  Write(images_ / "t.jpg", EncodedImage(ImageFormat::kJpeg));
  f_.Block("other");
  f_.FlatTri(1);
  mtl_.materials = {Mtl("textured"), Mtl("other")};
  mtl_.materials[0].map_kd = "../images/t.jpg";
  mtl_.materials[1].map_kd = "../models/../images/t.jpg";
  const auto r = BuildAssetFromObj(f_.obj, &mtl_, TextureOptions());
  ASSERT_BUILT(r);
  EXPECT_EQ(r->asset.textures.size(), 1u);
  EXPECT_EQ(r->counts.textures_embedded, 1u);
  ASSERT_EQ(r->asset.materials.size(), 2u);
  EXPECT_EQ(r->asset.materials[0].base_color_texture, 0u);
  EXPECT_EQ(r->asset.materials[1].base_color_texture, 0u);
}

TEST_F(ObjTextureTest, MapKdWithoutConfineRootIsAnOptionsError) {
  ObjAssetOptions options = TextureOptions();
  options.confine_root.clear();
  const auto r = BuildWith("../images/t.jpg", options);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace solid::convert
