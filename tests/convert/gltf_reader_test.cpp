// glTF input: ReadGltfModel over files the tests write (hand-built JSON + binary, our own
// Draco GLBs, @gltf-transform/cli variants), and `convert gltf` / `convert obj` end to end.
#include "gltf_reader.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <set>

#include "fixtures/gltf_validator.h"
#include "fixtures/run_command.h"
#include "fixtures/shared_testdata.h"
#include "fixtures/triangle_match.h"
#include "formats/test_util.h"
#include "solid/convert/convert.h"
#include "solid/formats/catalog.h"
#include "solid/formats/files.h"
#include "solid/formats/glb.h"
#include "solid/formats/image_codec.h"

namespace solid::convert {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using testing::TempDir;

// `solid convert gltf` and `solid convert obj` through the one call, Convert.
Result<ConvertReport> ConvertGltf(const fs::path& root, const fs::path& out, GltfLayout layout,
                                  ConvertOptions options) {
  options.source = Source::kGltf;
  options.root = root;
  options.out = out;
  options.gltf_layout = layout;
  return Convert(options);
}

Result<ConvertReport> ConvertObjFolder(const fs::path& root, const fs::path& out, ObjLayout layout,
                                       ConvertOptions options) {
  options.source = Source::kObj;
  options.root = root;
  options.out = out;
  options.obj_layout = layout;
  return Convert(options);
}

// A glTF document with one binary buffer, built accessor by accessor.
struct GltfBuilder {
  json doc = {{"asset", {{"version", "2.0"}}}, {"buffers", json::array()}, {"bufferViews", json::array()},
              {"accessors", json::array()}, {"meshes", json::array()}, {"nodes", json::array()}};
  std::vector<uint8_t> bin;

  template <typename T>
  int Accessor(const std::vector<T>& values, const char* type, int component_type, bool minmax = false) {
    while (bin.size() % 4 != 0) bin.push_back(0);
    const size_t offset = bin.size();
    bin.resize(offset + values.size() * sizeof(T));
    std::memcpy(bin.data() + offset, values.data(), values.size() * sizeof(T));
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * sizeof(T)}});
    const size_t n = std::string(type) == "VEC3" ? 3 : std::string(type) == "VEC2" ? 2 : 1;
    json a = {{"bufferView", doc["bufferViews"].size() - 1}, {"componentType", component_type},
              {"count", values.size() / n}, {"type", type}};
    if (minmax) {
      std::vector<double> lo(n, 1e300), hi(n, -1e300);
      for (size_t i = 0; i < values.size(); ++i) {
        lo[i % n] = std::min(lo[i % n], double(values[i]));
        hi[i % n] = std::max(hi[i % n], double(values[i]));
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    doc["accessors"].push_back(a);
    return static_cast<int>(doc["accessors"].size() - 1);
  }
  int Positions(const std::vector<float>& p) { return Accessor(p, "VEC3", 5126, true); }
  int Mesh(json primitive) {
    doc["meshes"].push_back({{"primitives", json::array({primitive})}});
    return static_cast<int>(doc["meshes"].size() - 1);
  }
  int Node(json node) {
    doc["nodes"].push_back(node);
    return static_cast<int>(doc["nodes"].size() - 1);
  }
  void Scene(std::vector<int> roots) {
    doc["scenes"] = json::array({{{"nodes", roots}}});
    doc["scene"] = 0;
  }
  // As a .gltf with the buffer in a data URI, or (bin_name set) in an external file.
  std::vector<uint8_t> Gltf(const fs::path& dir = {}, const std::string& bin_name = "") {
    json d = doc;
    if (bin_name.empty()) {
      static const char* kB64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      std::string b64;
      for (size_t i = 0; i < bin.size(); i += 3) {
        uint32_t v = uint32_t{bin[i]} << 16 | (i + 1 < bin.size() ? uint32_t{bin[i + 1]} << 8 : 0) |
                     (i + 2 < bin.size() ? bin[i + 2] : 0);
        b64 += kB64[v >> 18 & 63];
        b64 += kB64[v >> 12 & 63];
        b64 += i + 1 < bin.size() ? kB64[v >> 6 & 63] : '=';
        b64 += i + 2 < bin.size() ? kB64[v & 63] : '=';
      }
      d["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + b64}}});
    } else {
      d["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", bin_name}}});
      EXPECT_OK(files::WriteFileAtomically(dir / bin_name, bin));
    }
    std::string text = d.dump();
    return {text.begin(), text.end()};
  }
  std::vector<uint8_t> Glb() {
    json d = doc;
    d["buffers"] = bin.empty() ? json::array() : json::array({{{"byteLength", bin.size()}}});
    std::vector<uint8_t> padded = bin;
    while (padded.size() % 4 != 0) padded.push_back(0);
    auto glb = gltf::PackGlb(d, padded);
    EXPECT_TRUE(glb.ok());
    return glb.ok() ? *glb : std::vector<uint8_t>{};
  }
};

GltfReadResult Read(const std::vector<uint8_t>& bytes, const fs::path& path) {
  return ReadGltfModel(bytes, path, path.parent_path(), "model");
}

using Triangle = std::array<std::array<float, 3>, 3>;
// Triangles of an asset as position triples, each rotated to start at its smallest corner
// (winding kept), rounded to `step`.
std::multiset<std::array<long, 9>> TriangleSet(const gltf::Asset& a, double step) {
  std::multiset<std::array<long, 9>> out;
  for (const auto& n : a.nodes) {
    for (const auto& p : n.primitives) {
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        std::array<std::array<long, 3>, 3> c;
        for (size_t k = 0; k < 3; ++k) {
          for (size_t d = 0; d < 3; ++d) c[k][d] = std::lround(p.positions[3 * p.indices[t + k] + d] / step);
        }
        const size_t first = static_cast<size_t>(std::min_element(c.begin(), c.end()) - c.begin());
        std::array<long, 9> key;
        for (size_t k = 0; k < 3; ++k) {
          for (size_t d = 0; d < 3; ++d) key[3 * k + d] = c[(first + k) % 3][d];
        }
        out.insert(key);
      }
    }
  }
  return out;
}

const std::vector<float> kTriangle = {0, 0, 0, 1, 0, 0, 0, 1, 0};  // normal +Z

TEST(GltfReader, NodeHierarchyIsFlattenedWithTrsMatrixAndMirror) {
  TempDir dir;
  GltfBuilder b;
  const int mesh = b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}});
  // child: scale 2 then (parent) 90 degrees about +Y then translate x by 10.
  const int child = b.Node({{"mesh", mesh}, {"scale", {2, 2, 2}}});
  const double h = std::sqrt(0.5);
  const int parent = b.Node({{"children", {child}}, {"rotation", {0, h, 0, h}}, {"translation", {10, 0, 0}}});
  // A mirror in x through a matrix (column-major), translated by y 5.
  const int mirrored = b.Node({{"mesh", mesh}, {"matrix", {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 5, 0, 1}}});
  b.Scene({parent, mirrored});
  const fs::path path = dir.path() / "m.gltf";
  GltfReadResult r = Read(b.Gltf(), path);
  ASSERT_TRUE(r.ok) << r.failure.code << ": " << r.failure.message;
  gltf::Asset want;
  want.nodes.resize(1);
  // Rotation of +90 about Y: (x, y, z) -> (z, y, -x).
  want.nodes[0].primitives.push_back({std::nullopt, {10, 0, 0, 10, 0, -2, 10, 2, 0}, {}, {}, {0, 1, 2}});
  // Mirrored: (x, y, z) -> (-x, y + 5, z), winding flipped to keep the face outward.
  want.nodes[0].primitives.push_back({std::nullopt, {0, 5, 0, -1, 5, 0, 0, 6, 0}, {}, {}, {0, 2, 1}});
  EXPECT_EQ(TriangleSet(r.model.asset, 1e-5), TriangleSet(want, 1e-5));
  EXPECT_EQ(r.model.counts["mirrored_instances"], 1);
  EXPECT_EQ(r.model.counts["node_instances"], 3);
}

TEST(GltfReader, StripsFansAndEveryIndexTypeGiveTheSameTriangles) {
  TempDir dir;
  const std::vector<float> quad = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  std::multiset<std::array<long, 9>> reference;
  for (int type : {5121, 5123, 5125}) {
    GltfBuilder b;
    const int pos = b.Positions(quad);
    const int idx = type == 5121   ? b.Accessor(std::vector<uint8_t>{0, 1, 2, 2, 1, 3}, "SCALAR", type)
                    : type == 5123 ? b.Accessor(std::vector<uint16_t>{0, 1, 2, 2, 1, 3}, "SCALAR", type)
                                   : b.Accessor(std::vector<uint32_t>{0, 1, 2, 2, 1, 3}, "SCALAR", type);
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}}}, {"indices", idx}})}});
    GltfReadResult r = Read(b.Glb(), dir.path() / "q.glb");
    ASSERT_TRUE(r.ok) << r.failure.message;
    if (reference.empty()) reference = TriangleSet(r.model.asset, 1e-6);
    EXPECT_EQ(TriangleSet(r.model.asset, 1e-6), reference) << "component type " << type;
  }
  ASSERT_EQ(reference.size(), 2u);
  // Strip 0 1 2 3 is triangles (0 1 2), (2 1 3); fan 0 1 3 2 is (0 1 3), (0 3 2): the same quad.
  for (auto [mode, order] : {std::pair{5, std::vector<uint16_t>{0, 1, 2, 3}}, std::pair{6, std::vector<uint16_t>{0, 1, 3, 2}}}) {
    GltfBuilder b;
    const int pos = b.Positions(quad);
    const int idx = b.Accessor(order, "SCALAR", 5123);
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}}}, {"indices", idx}, {"mode", mode}})}});
    GltfReadResult r = Read(b.Glb(), dir.path() / "s.glb");
    ASSERT_TRUE(r.ok) << r.failure.message;
    EXPECT_EQ(r.model.counts["strips_fans_converted"], 1);
    if (mode == 5) {
      EXPECT_EQ(TriangleSet(r.model.asset, 1e-6), reference);
    }
    // Both turn the same way (+Z normals) as the indexed quad.
    for (size_t t = 0; t < 2; ++t) {
      const auto& p = r.model.asset.nodes[0].primitives[0];
      const float* a = &p.positions[3 * p.indices[3 * t]];
      const float* q = &p.positions[3 * p.indices[3 * t + 1]];
      const float* c = &p.positions[3 * p.indices[3 * t + 2]];
      EXPECT_GT((q[0] - a[0]) * (c[1] - a[1]) - (q[1] - a[1]) * (c[0] - a[0]), 0) << "mode " << mode << " t " << t;
    }
  }
}

TEST(GltfReader, PointsAndLinesAreDroppedWithAWarning) {
  TempDir dir;
  GltfBuilder b;
  const int pos = b.Positions(kTriangle);
  b.doc["meshes"].push_back({{"primitives", json::array({{{"attributes", {{"POSITION", pos}}}},
                                                         {{"attributes", {{"POSITION", pos}}}, {"mode", 1}},
                                                         {{"attributes", {{"POSITION", pos}}}, {"mode", 0}}})}});
  b.Node({{"mesh", 0}});
  GltfReadResult r = Read(b.Glb(), dir.path() / "p.glb");
  ASSERT_TRUE(r.ok) << r.failure.message;
  EXPECT_EQ(r.model.counts["points_lines_dropped"], 2);
  ASSERT_EQ(r.model.warnings.size(), 1u);
  EXPECT_EQ(r.model.warnings[0].code, "points_lines_dropped");
}

TEST(GltfReader, DataUriAndExternalBinGiveTheSameModelAndEscapesAreRefused) {
  TempDir dir;
  GltfBuilder b;
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
  fs::create_directories(dir.path() / "model");
  const fs::path path = dir.path() / "model" / "m.gltf";
  GltfReadResult embedded = Read(b.Gltf(), path);
  GltfReadResult external = Read(b.Gltf(dir.path() / "model", "m.bin"), path);
  ASSERT_TRUE(embedded.ok) << embedded.failure.message;
  ASSERT_TRUE(external.ok) << external.failure.message;
  EXPECT_EQ(TriangleSet(embedded.model.asset, 1e-6), TriangleSet(external.model.asset, 1e-6));

  // The same bytes one folder up: a URI leaving the model's folder is refused, not read.
  std::vector<uint8_t> escaping = b.Gltf(dir.path(), "secret.bin");
  std::string text(escaping.begin(), escaping.end());
  text.replace(text.find("\"secret.bin\""), 12, "\"../secret.bin\"");
  GltfReadResult r = Read(std::vector<uint8_t>(text.begin(), text.end()), path);
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.failure.code, "external_path_rejected") << r.failure.message;
  EXPECT_NE(r.failure.message.find("m.gltf"), std::string::npos) << r.failure.message;

  std::string absent = text;
  absent.replace(absent.find("\"../secret.bin\""), 15, "\"nothere.bin\"");
  GltfReadResult r2 = Read(std::vector<uint8_t>(absent.begin(), absent.end()), path);
  ASSERT_FALSE(r2.ok);
  EXPECT_EQ(r2.failure.code, "missing_file") << r2.failure.message;
}

TEST(GltfReader, RequiredUnsupportedExtensionFailsOptionalOneWarns) {
  TempDir dir;
  GltfBuilder b;
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
  b.doc["extensionsUsed"] = {"KHR_texture_basisu", "EXT_lights_image_based"};
  GltfReadResult optional = Read(b.Glb(), dir.path() / "o.glb");
  ASSERT_TRUE(optional.ok) << optional.failure.message;
  ASSERT_EQ(optional.model.warnings.size(), 2u);
  EXPECT_EQ(optional.model.warnings[0].code, "unsupported_optional_extension");
  b.doc["extensionsRequired"] = {"KHR_texture_basisu"};
  GltfReadResult required = Read(b.Glb(), dir.path() / "r.glb");
  ASSERT_FALSE(required.ok);
  EXPECT_EQ(required.failure.code, "unsupported_extension");
  EXPECT_NE(required.failure.message.find("/extensionsRequired: KHR_texture_basisu"), std::string::npos);
}

TEST(GltfReader, BrokenFilesFailWithTheirCodeAndWhere) {
  TempDir dir;
  auto code_of = [&](GltfBuilder& b) {
    GltfReadResult r = Read(b.Glb(), dir.path() / "x.glb");
    return r.ok ? std::string("ok") : r.failure.code + " | " + r.failure.message;
  };
  {  // a cycle: node 0 -> node 1 -> node 0
    GltfBuilder b;
    const int mesh = b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}});
    b.Node({{"mesh", mesh}, {"children", {1}}});
    b.Node({{"children", {0}}});
    b.Scene({0});
    EXPECT_TRUE(code_of(b).starts_with("node_cycle | ")) << code_of(b);
  }
  {  // an accessor running past its bufferView
    GltfBuilder b;
    const int pos = b.Positions(kTriangle);
    b.doc["accessors"][pos]["count"] = 4;
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}}}})}});
    const std::string c = code_of(b);
    EXPECT_TRUE(c.starts_with("corrupt | ")) << c;
    EXPECT_NE(c.find("/accessors/0"), std::string::npos) << c;
  }
  {  // an index past the vertices
    GltfBuilder b;
    const int pos = b.Positions(kTriangle);
    const int idx = b.Accessor(std::vector<uint16_t>{0, 1, 3}, "SCALAR", 5123);
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}}}, {"indices", idx}})}});
    const std::string c = code_of(b);
    EXPECT_TRUE(c.starts_with("corrupt | ")) << c;
    EXPECT_NE(c.find("/meshes/0/primitives/0/indices"), std::string::npos) << c;
  }
  {  // JSON nested past the limit (in extras, which tinygltf would otherwise recurse into)
    GltfBuilder b;
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
    json deep = 1;
    for (int i = 0; i < 100; ++i) deep = json::array({deep});
    b.doc["extras"] = deep;
    EXPECT_TRUE(code_of(b).starts_with("limit_exceeded | ")) << code_of(b);
  }
  {  // no triangle in the scene
    GltfBuilder b;
    b.Node({{"name", "empty"}});
    EXPECT_TRUE(code_of(b).starts_with("empty_geometry | ")) << code_of(b);
  }
  {  // an image's bufferView past its buffer (tinygltf 2.7 does not check it; gltf_fuzz found it)
    GltfBuilder b;
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
    b.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 16}, {"byteLength", 4096}});
    b.doc["images"] = json::array({{{"bufferView", 1}, {"mimeType", "image/png"}}});
    const std::string c = code_of(b);
    EXPECT_TRUE(c.starts_with("parse_error | ")) << c;
    EXPECT_NE(c.find("/images/0: bufferView 1 lies outside its buffer"), std::string::npos) << c;
  }
  {  // a meshopt "fallback" that is a number, not a boolean, used to throw (gltf_fuzz found it):
     // it is no fallback, and the buffer, used by nothing, is left alone
    GltfBuilder b;
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
    b.doc["buffers"].push_back({{"byteLength", 44}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", 8}}}}}});
    b.doc["extensionsUsed"] = json::array({"EXT_meshopt_compression"});
    EXPECT_EQ(code_of(b), "ok");
  }
  {  // a GLB buffer of byteLength 0, which tinygltf 2.7 indexes as if it had a byte (gltf_fuzz)
    GltfBuilder b;
    b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}});
    std::vector<uint8_t> glb = b.Glb();
    const std::string from = R"("buffers":[{"byteLength":)";
    std::string text(glb.begin(), glb.end());
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos);
    const size_t digits = text.find_first_not_of("0123456789", at + from.size());
    // The same number of bytes: the JSON chunk keeps its length.
    text.replace(at + from.size(), digits - at - from.size(), std::string(digits - at - from.size() - 1, ' ') + "0");
    GltfReadResult r = Read(std::vector<uint8_t>(text.begin(), text.end()), dir.path() / "z.glb");
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.failure.code, "parse_error") << r.failure.message;
    EXPECT_NE(r.failure.message.find("tinygltf: "), std::string::npos) << r.failure.message;
  }
  GltfReadResult garbage = Read({'g', 'l', 'T', 'F', 2, 0, 0, 0, 99, 0, 0, 0}, dir.path() / "g.glb");
  EXPECT_FALSE(garbage.ok);
  EXPECT_EQ(garbage.failure.code, "parse_error");
}

gltf::Asset TexturedQuadAsset() {
  gltf::Asset a;
  Image8 img{4, 4, 3, std::vector<uint8_t>(48, 200)};
  auto png = EncodeImage(img, ImageFormat::kPng);
  EXPECT_TRUE(png.ok());
  a.textures.push_back({"t.png", "image/png", *png});
  gltf::Material m;
  m.name = "painted";
  m.base_color = {0.5f, 0.25f, 1.0f, 1.0f};
  m.base_color_texture = 0;
  a.materials.push_back(m);
  gltf::Node n;
  n.name = "quad";
  n.primitives.push_back({0, {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5f}, {0, 0, 1, 0, 0, 1, 0, 0, 1, 0.6f, 0, 0.8f},
                          {0, 0, 1, 0, 0, 1, 1, 1}, {0, 1, 2, 2, 1, 3}});
  a.nodes.push_back(n);
  return a;
}

TEST(GltfReader, OurDracoGlbReadsBackWithinOneQuantizationStepWithItsTexture) {
  TempDir dir;
  const gltf::Asset in = TexturedQuadAsset();
  gltf::DracoOptions draco;
  auto glb = gltf::WriteGlb(in, draco);
  ASSERT_TRUE(glb.ok());
  GltfReadResult r = Read(*glb, dir.path() / "ours.glb");
  ASSERT_TRUE(r.ok) << r.failure.message;
  EXPECT_EQ(r.model.counts["draco_primitives"], 1);
  ASSERT_EQ(r.model.asset.textures.size(), 1u);
  EXPECT_EQ(r.model.asset.textures[0].bytes, in.textures[0].bytes);
  ASSERT_EQ(r.model.asset.materials.size(), 1u);
  EXPECT_EQ(r.model.asset.materials[0].base_color, in.materials[0].base_color);
  const fixtures::Fidelity f = fixtures::MatchTriangles(in.nodes[0].primitives[0], r.model.asset.nodes[0].primitives[0], draco);
  EXPECT_EQ(f.unmatched, 0u) << f.max_error;
}

TEST(GltfReader, TextureTransformIsAppliedToTheUvs) {
  TempDir dir;
  GltfBuilder b;
  Image8 img{2, 2, 3, std::vector<uint8_t>(12, 9)};
  auto png = EncodeImage(img, ImageFormat::kPng);
  ASSERT_TRUE(png.ok());
  const int pos = b.Positions(kTriangle);
  const int uv = b.Accessor(std::vector<float>{0, 0, 1, 0, 0, 1}, "VEC2", 5126);
  const int image_view = [&] {
    while (b.bin.size() % 4 != 0) b.bin.push_back(0);
    b.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", b.bin.size()}, {"byteLength", png->size()}});
    b.bin.insert(b.bin.end(), png->begin(), png->end());
    return static_cast<int>(b.doc["bufferViews"].size() - 1);
  }();
  b.doc["images"] = json::array({{{"bufferView", image_view}, {"mimeType", "image/png"}}});
  b.doc["textures"] = json::array({{{"source", 0}}});
  // Rotation pi/2 then scale (2, 3) then offset (0.5, 0.25): (u, v) -> (0.5 + 3v, 0.25 - 2u).
  json transform = {{"offset", {0.5, 0.25}}, {"rotation", M_PI / 2}, {"scale", {2, 3}}};
  json texture_info = {{"index", 0}, {"extensions", {{"KHR_texture_transform", transform}}}};
  json material = {{"pbrMetallicRoughness", {{"baseColorTexture", texture_info}}}};
  b.doc["materials"] = json::array({material});
  b.doc["extensionsUsed"] = {"KHR_texture_transform"};
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", uv}}}, {"material", 0}})}});
  GltfReadResult r = Read(b.Glb(), dir.path() / "t.glb");
  ASSERT_TRUE(r.ok) << r.failure.message;
  EXPECT_TRUE(r.model.warnings.empty());
  ASSERT_EQ(r.model.asset.textures.size(), 1u);
  EXPECT_EQ(r.model.asset.textures[0].bytes, *png);
  const std::vector<float>& got = r.model.asset.nodes[0].primitives[0].uvs;
  const std::vector<float> want = {0.5f, 0.25f, 0.5f, -1.75f, 3.5f, 0.25f};
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(got[i], want[i], 1e-6) << i;
}

TEST(GltfReader, QuantizedNormalizedAttributesAreDequantizedByTheNodeScale) {
  TempDir dir;
  GltfBuilder b;
  // KHR_mesh_quantization: int16 positions, with the node's scale doing the dequantization.
  const int pos = b.Accessor(std::vector<int16_t>{0, 0, 0, 1000, 0, 0, 0, 1000, 0}, "VEC3", 5122, true);
  const int nrm = b.Accessor(std::vector<int8_t>{0, 0, 127, 0, 0, 127, 0, 0, 127}, "VEC3", 5120);
  b.doc["accessors"][nrm]["normalized"] = true;
  b.doc["extensionsUsed"] = {"KHR_mesh_quantization"};
  b.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}}}})}, {"scale", {0.001, 0.001, 0.001}}});
  GltfReadResult r = Read(b.Glb(), dir.path() / "q.glb");
  ASSERT_TRUE(r.ok) << r.failure.message;
  gltf::Asset want;
  want.nodes.resize(1);
  want.nodes[0].primitives.push_back({std::nullopt, kTriangle, {}, {}, {0, 1, 2}});
  EXPECT_EQ(TriangleSet(r.model.asset, 1e-5), TriangleSet(want, 1e-5));
  const auto& n = r.model.asset.nodes[0].primitives[0].normals;
  ASSERT_EQ(n.size(), 9u);
  EXPECT_FLOAT_EQ(n[2], 1.0f);
}

std::map<std::string, CatalogEntry> Rows(const fs::path& out) {
  std::map<std::string, CatalogEntry> rows;
  auto catalog = Catalog::OpenReadOnly(out / "catalog.sqlite");
  EXPECT_TRUE(catalog.ok()) << catalog.status().ToString();
  if (!catalog.ok()) return rows;
  auto all = catalog->All();
  EXPECT_TRUE(all.ok());
  if (all.ok()) {
    for (auto& e : *all) rows.emplace(e.key, std::move(e));
  }
  return rows;
}

gltf::Asset ReadOutput(const fs::path& path) {
  auto bytes = files::ReadFile(path, 64 << 20);
  EXPECT_TRUE(bytes.ok());
  if (!bytes.ok()) return {};
  auto a = gltf::ReadGlb(*bytes, path.string());
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  return a.ok() ? *a : gltf::Asset{};
}

TEST(ConvertGltf, FlatAndObjaverseLayoutsQuarantineAndResume) {
  TempDir dir;
  const fs::path root = dir.path() / "in";
  fs::create_directories(root / "glbs" / "000-001");
  fs::create_directories(root / "sub");
  ASSERT_OK(files::WriteFileAtomically(root / "glbs" / "000-001" / "abc123.glb", *gltf::WriteGlb(TexturedQuadAsset())));
  GltfBuilder b;
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", b.Positions(kTriangle)}}}})}, {"scale", {2, 2, 2}}});
  ASSERT_OK(files::WriteFileAtomically(root / "sub" / "tri.gltf", b.Gltf(root / "sub", "tri.bin")));
  b.doc["extensionsRequired"] = {"KHR_texture_basisu"};
  ASSERT_OK(files::WriteFileAtomically(root / "bad.glb", b.Glb()));

  ConvertOptions options;
  options.jobs = 2;
  auto flat = ConvertGltf(root, dir.path() / "flat", GltfLayout::kFlat, options);
  ASSERT_TRUE(flat.ok()) << flat.status().ToString();
  EXPECT_EQ(flat->assets, 3);
  EXPECT_EQ(flat->ok, 2);
  EXPECT_EQ(flat->failed, 1);
  EXPECT_EQ(flat->failure_codes["unsupported_extension"], 1);
  auto rows = Rows(dir.path() / "flat");
  ASSERT_EQ(rows.size(), 3u);
  ASSERT_TRUE(rows.count("sub/tri") && rows.count("glbs/000-001/abc123") && rows.count("bad"));
  const CatalogEntry& tri = rows["sub/tri"];
  EXPECT_EQ(tri.source, "gltf");
  EXPECT_EQ(tri.input_files, json({"sub/tri.bin", "sub/tri.gltf"}));
  EXPECT_EQ(tri.extras["source_extent_m"], json({2.0, 2.0, 0.0}));
  // Normalised as ShapeNet v2: unit diagonal.
  ASSERT_TRUE(tri.bounds);
  const auto& bb = *tri.bounds;
  EXPECT_NEAR(std::hypot(bb[3] - bb[0], bb[4] - bb[1], bb[5] - bb[2]), 1.0, 1e-3);
  const gltf::Asset quad = ReadOutput(dir.path() / "flat" / *rows["glbs/000-001/abc123"].file);
  ASSERT_EQ(quad.textures.size(), 1u);
  EXPECT_EQ(quad.textures[0].bytes, TexturedQuadAsset().textures[0].bytes);
  EXPECT_EQ(rows["bad"].error_code, "unsupported_extension");

  // Rerun: nothing changed, nothing converted; a changed .bin reconverts its model only.
  auto again = ConvertGltf(root, dir.path() / "flat", GltfLayout::kFlat, options);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->up_to_date, 3);
  std::vector<uint8_t> bin = *files::ReadFile(root / "sub" / "tri.bin", 1 << 20);
  bin[0] ^= 1;
  ASSERT_OK(files::WriteFileAtomically(root / "sub" / "tri.bin", bin));
  auto changed = ConvertGltf(root, dir.path() / "flat", GltfLayout::kFlat, options);
  ASSERT_TRUE(changed.ok());
  EXPECT_EQ(changed->up_to_date, 2);
  EXPECT_EQ(changed->ok + changed->ok_with_warnings + changed->failed, 1);

  auto objaverse = ConvertGltf(root, dir.path() / "objaverse", GltfLayout::kObjaverse, options);
  ASSERT_TRUE(objaverse.ok()) << objaverse.status().ToString();
  auto orows = Rows(dir.path() / "objaverse");
  ASSERT_EQ(orows.size(), 1u);
  EXPECT_EQ(orows.begin()->first, "abc123");
  EXPECT_EQ(*orows.begin()->second.file, "models/abc123.glb");

  if (auto why = fixtures::GltfValidatorUnavailable()) {
    GTEST_SKIP() << *why;
  }
  std::vector<fs::path> outputs;
  for (const auto& [key, row] : rows) {
    if (row.file) outputs.push_back(dir.path() / "flat" / *row.file);
  }
  std::vector<fs::path> decompressed;
  for (const fs::path& p : outputs) {
    auto plain = fixtures::DecompressDraco(*files::ReadFile(p, 64 << 20), p.string());
    ASSERT_TRUE(plain.ok());
    decompressed.push_back(fs::path(p).replace_extension(".plain.glb"));
    ASSERT_OK(files::WriteFileAtomically(decompressed.back(), *plain));
  }
  outputs.insert(outputs.end(), decompressed.begin(), decompressed.end());
  fixtures::GltfValidatorRun run = fixtures::RunGltfValidator(outputs);
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.files_reported, outputs.size()) << run.report;
}

// Converts ROOT/obj as a flat OBJ folder and ROOT/gltf as a flat glTF folder, one model
// `key` in each, and expects one node from each with the same triangles: each side was
// quantized once with the same options, so one step covers the difference.
void ExpectSameGeometryFromObjAndGltf(const fs::path& root, const std::string& key, gltf::Asset* from_obj,
                                      gltf::Asset* from_gltf) {
  auto a = ConvertObjFolder(root / "obj", root / "out_obj", ObjLayout::kFlat, {});
  auto g = ConvertGltf(root / "gltf", root / "out_gltf", GltfLayout::kFlat, {});
  ASSERT_TRUE(a.ok() && g.ok());
  ASSERT_EQ(a->ok, 1);
  ASSERT_EQ(g->ok, 1);
  *from_obj = ReadOutput(root / "out_obj" / "models" / (key + ".glb"));
  *from_gltf = ReadOutput(root / "out_gltf" / "models" / (key + ".glb"));
  ASSERT_EQ(from_obj->nodes.size(), 1u);
  ASSERT_EQ(from_gltf->nodes.size(), 1u);
  gltf::DracoOptions coarser;
  coarser.position_bits -= 1;
  const fixtures::Fidelity f =
      fixtures::MatchTriangles(from_obj->nodes[0].primitives[0], from_gltf->nodes[0].primitives[0], coarser);
  EXPECT_EQ(f.unmatched, 0u) << f.max_error;
}

// A unit cube, as an OBJ (the ShapeNet path) and as a glTF: the same geometry out.
TEST(ConvertGltf, SameModelAsObjAndAsGltfGivesTheSameGeometry) {
  TempDir dir;
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
  const std::vector<uint32_t> tris = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                      1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
  std::string obj;
  for (size_t i = 0; i < p.size(); i += 3) obj += fmt::format("v {} {} {}\n", p[i], p[i + 1], p[i + 2] * 3);
  for (size_t t = 0; t < tris.size(); t += 3) obj += fmt::format("f {} {} {}\n", tris[t] + 1, tris[t + 1] + 1, tris[t + 2] + 1);
  fs::create_directories(dir.path() / "obj");
  fs::create_directories(dir.path() / "gltf");
  ASSERT_OK(files::WriteFileAtomically(dir.path() / "obj" / "cube.obj", std::vector<uint8_t>(obj.begin(), obj.end())));
  GltfBuilder b;
  const int pos = b.Positions(p);
  const int idx = b.Accessor(tris, "SCALAR", 5125);
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}}}, {"indices", idx}})}, {"scale", {1, 1, 3}}});
  ASSERT_OK(files::WriteFileAtomically(dir.path() / "gltf" / "cube.glb", b.Glb()));
  gltf::Asset from_obj, from_gltf;
  ExpectSameGeometryFromObjAndGltf(dir.path(), "cube", &from_obj, &from_gltf);
  EXPECT_EQ(TriangleCount(from_obj), 12u);
  EXPECT_EQ(TriangleCount(from_gltf), 12u);
  EXPECT_EQ(Rows(dir.path() / "out_gltf")["cube"].extras["source_extent_m"], json({1.0, 1.0, 3.0}));
}

TEST(ConvertObjFolder, GsoAndYcbLayoutsFindTheirMeshesAndTextures) {
  TempDir dir;
  Image8 img{2, 2, 3, std::vector<uint8_t>(12, 50)};
  auto png = EncodeImage(img, ImageFormat::kPng);
  ASSERT_TRUE(png.ok());
  const std::string obj = "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\n";
  auto put = [&](const fs::path& p, std::string_view text) {
    fs::create_directories(p.parent_path());
    ASSERT_OK(files::WriteFileAtomically(p, std::vector<uint8_t>(text.begin(), text.end())));
  };
  const fs::path gso = dir.path() / "gso";
  put(gso / "Mug" / "meshes" / "model.obj", obj);
  put(gso / "Mug" / "meshes" / "model.mtl", "newmtl m\nmap_Kd ../materials/textures/texture.png\n");
  fs::create_directories(gso / "Mug" / "materials" / "textures");
  ASSERT_OK(files::WriteFileAtomically(gso / "Mug" / "materials" / "textures" / "texture.png", *png));
  fs::create_directories(gso / "Empty");
  auto r = ConvertObjFolder(gso, dir.path() / "out_gso", ObjLayout::kGso, {});
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  auto rows = Rows(dir.path() / "out_gso");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows["Mug"].status, AssetStatus::kOk) << rows["Mug"].warnings.dump();
  EXPECT_EQ(rows["Mug"].textures, 1);
  EXPECT_EQ(rows["Mug"].source, "obj");
  EXPECT_EQ(rows["Empty"].error_code, "missing_obj");

  const fs::path ycb = dir.path() / "ycb";
  std::string ycb_obj = obj;
  ycb_obj.replace(ycb_obj.find("model.mtl"), 9, "textured.mtl");
  put(ycb / "003_cracker_box" / "google_16k" / "textured.obj", ycb_obj);
  put(ycb / "003_cracker_box" / "google_16k" / "textured.mtl", "newmtl m\nmap_Kd texture_map.png\n");
  ASSERT_OK(files::WriteFileAtomically(ycb / "003_cracker_box" / "google_16k" / "texture_map.png", *png));
  auto y = ConvertObjFolder(ycb, dir.path() / "out_ycb", ObjLayout::kYcb, {});
  ASSERT_TRUE(y.ok()) << y.status().ToString();
  auto yrows = Rows(dir.path() / "out_ycb");
  ASSERT_EQ(yrows.size(), 1u);
  EXPECT_EQ(yrows["003_cracker_box"].textures, 1);
  // The scans are +Z up: the triangle in the OBJ's x-y plane stands in the asset's x-z plane.
  EXPECT_EQ(yrows["003_cracker_box"].extras["source_extent_m"], json({1.0, 0.0, 1.0}));
  EXPECT_EQ(y->up_to_date, 0);

  // Another up axis is another conversion; the same one again is up to date.
  ConvertOptions y_up;
  y_up.obj_up = UpAxis::kY;
  auto again = ConvertObjFolder(ycb, dir.path() / "out_ycb", ObjLayout::kYcb, y_up);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(again->up_to_date, 0);
  EXPECT_EQ(Rows(dir.path() / "out_ycb")["003_cracker_box"].extras["source_extent_m"], json({1.0, 1.0, 0.0}));
  again = ConvertObjFolder(ycb, dir.path() / "out_ycb", ObjLayout::kYcb, y_up);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(again->up_to_date, 1);
}

// A +Z-up OBJ of a flat folder, told so, is turned to +Y up before normalisation: a post
// 3 units tall along z stands along y, and its triangles keep their outward winding.
TEST(ConvertObjFolder, ZUpModelsAreTurnedToYUp) {
  TempDir dir;
  std::string obj;
  for (int k = 0; k < 8; ++k) obj += fmt::format("v {} {} {}\n", k & 1, (k >> 1) & 1, 3 * (k >> 2));
  for (const char* face : {"1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"}) {
    obj += fmt::format("f {}\n", face);
  }
  fs::create_directories(dir.path() / "in");
  ASSERT_OK(files::WriteFileAtomically(dir.path() / "in" / "post.obj", std::vector<uint8_t>(obj.begin(), obj.end())));
  ConvertOptions z_up;
  z_up.obj_up = UpAxis::kZ;
  auto r = ConvertObjFolder(dir.path() / "in", dir.path() / "out", ObjLayout::kFlat, z_up);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->ok + r->ok_with_warnings, 1) << Rows(dir.path() / "out")["post"].error.value_or("");
  EXPECT_EQ(Rows(dir.path() / "out")["post"].extras["source_extent"], json({1.0, 3.0, 1.0}));
  const gltf::Asset asset = ReadOutput(dir.path() / "out" / "models" / "post.glb");
  // Every face normal points away from the centre (the mean of the vertices, the origin).
  size_t faces = 0;
  for (const gltf::Node& node : asset.nodes) {
    for (const gltf::Primitive& p : node.primitives) {
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        float c[3][3];
        for (int v = 0; v < 3; ++v) {
          for (int a = 0; a < 3; ++a) c[v][a] = p.positions[3 * p.indices[t + v] + a];
        }
        const float e1[3] = {c[1][0] - c[0][0], c[1][1] - c[0][1], c[1][2] - c[0][2]};
        const float e2[3] = {c[2][0] - c[0][0], c[2][1] - c[0][1], c[2][2] - c[0][2]};
        const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        const float mid[3] = {(c[0][0] + c[1][0] + c[2][0]) / 3, (c[0][1] + c[1][1] + c[2][1]) / 3,
                              (c[0][2] + c[1][2] + c[2][2]) / 3};
        EXPECT_GT(n[0] * mid[0] + n[1] * mid[1] + n[2] * mid[2], 0) << "triangle " << t / 3;
        ++faces;
      }
    }
  }
  EXPECT_EQ(faces, 12u);
}

// A command of tests/gltf_transform's npm packages, or empty when they or node are missing.
fs::path GltfTransformTool(std::string_view name) {
  const fs::path cli = fs::path(SOLID_SOURCE_DIR) / "tests/gltf_transform/node_modules/.bin" / name;
  std::error_code ec;
  if (!fs::exists(cli, ec) || std::system("node --version >/dev/null 2>&1") != 0) return {};
  return cli;
}

// obj2gltf (tests/gltf_transform; the converter SOLID and kubric used) turns a textured OBJ
// into a glb: it converts to the geometry and texture the OBJ itself converts to.
TEST(ConvertGltf, Obj2gltfOutputConvertsToTheGeometryOfItsObj) {
  const fs::path cli = GltfTransformTool("obj2gltf");
  if (cli.empty()) GTEST_SKIP() << "npm obj2gltf not installed: run npm ci --prefix tests/gltf_transform";
  TempDir dir;
  const fs::path obj_dir = dir.path() / "obj", gltf_dir = dir.path() / "gltf";
  fs::create_directories(obj_dir);
  fs::create_directories(gltf_dir);
  // A box 1 x 1 x 3 with one texture over every face.
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 3, 1, 0, 3, 1, 1, 3, 0, 1, 3};
  const std::vector<uint32_t> tris = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                      1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
  std::string obj = "mtllib box.mtl\nvt 0 0\nvt 1 0\nvt 1 1\n";
  for (size_t i = 0; i < p.size(); i += 3) obj += fmt::format("v {} {} {}\n", p[i], p[i + 1], p[i + 2]);
  obj += "usemtl painted\n";
  for (size_t t = 0; t < tris.size(); t += 3) {
    obj += fmt::format("f {}/1 {}/2 {}/3\n", tris[t] + 1, tris[t + 1] + 1, tris[t + 2] + 1);
  }
  const std::string mtl = "newmtl painted\nKd 1 1 1\nmap_Kd box.png\n";
  Result<std::vector<uint8_t>> png = EncodeImage(Image8{4, 4, 3, std::vector<uint8_t>(48, 180)}, ImageFormat::kPng);
  ASSERT_OK(png.status());
  ASSERT_OK(files::WriteFileAtomically(obj_dir / "box.obj", std::vector<uint8_t>(obj.begin(), obj.end())));
  ASSERT_OK(files::WriteFileAtomically(obj_dir / "box.mtl", std::vector<uint8_t>(mtl.begin(), mtl.end())));
  ASSERT_OK(files::WriteFileAtomically(obj_dir / "box.png", *png));
  const fixtures::CommandRun run = fixtures::RunCommand(fmt::format(
      "{} -i {} -o {}", fixtures::ShellQuote(cli.string()), fixtures::ShellQuote((obj_dir / "box.obj").string()),
      fixtures::ShellQuote((gltf_dir / "box.glb").string())));
  ASSERT_EQ(run.exit_status, 0) << run.output;
  gltf::Asset from_obj, from_gltf;
  ExpectSameGeometryFromObjAndGltf(dir.path(), "box", &from_obj, &from_gltf);
  EXPECT_EQ(from_obj.textures.size(), 1u);
  EXPECT_EQ(from_gltf.textures.size(), 1u);
}

// @gltf-transform/cli variants of one of our files (tests/gltf_transform; scripts/test.sh
// installs it): the geometry must survive meshopt, quantization, Draco and a separate .bin.
TEST(GltfReader, GltfTransformVariantsKeepTheGeometry) {
  const fs::path cli = GltfTransformTool("gltf-transform");
  if (cli.empty()) GTEST_SKIP() << "npm @gltf-transform/cli not installed: run npm ci --prefix tests/gltf_transform";
  TempDir dir;
  // A plain (uncompressed) input, so that every variant starts from exact geometry.
  GltfBuilder b;
  const gltf::Asset quad = TexturedQuadAsset();
  const auto& prim = quad.nodes[0].primitives[0];
  const int pos = b.Positions(prim.positions);
  const int nrm = b.Accessor(prim.normals, "VEC3", 5126);
  const int uv = b.Accessor(prim.uvs, "VEC2", 5126);
  const int idx = b.Accessor(std::vector<uint16_t>(prim.indices.begin(), prim.indices.end()), "SCALAR", 5123);
  b.Node({{"mesh", b.Mesh({{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}, {"TEXCOORD_0", uv}}}, {"indices", idx}})}});
  const fs::path input = dir.path() / "plain.glb";
  ASSERT_OK(files::WriteFileAtomically(input, b.Glb()));
  GltfReadResult reference = Read(b.Glb(), input);
  ASSERT_TRUE(reference.ok) << reference.failure.message;
  const std::string q = fixtures::ShellQuote(cli.string());
  struct Variant {
    std::string name, args, file;
    double step;  // position tolerance
  };
  const std::vector<Variant> variants = {
      {"meshopt", "meshopt", "meshopt.glb", 1e-3},
      {"quantize", "quantize --quantize-position 14", "quantize.glb", 2.0 / (1 << 13)},
      {"draco", "draco --quantize-position 14", "draco.glb", 2.0 / (1 << 13)},
      {"separate bin", "copy", "separate/model.gltf", 1e-6},
  };
  for (const Variant& v : variants) {
    const fs::path out = dir.path() / v.file;
    fs::create_directories(out.parent_path());
    std::string verb = v.args.substr(0, v.args.find(' '));
    std::string rest = v.args.size() > verb.size() ? v.args.substr(verb.size()) : "";
    fixtures::CommandRun run = fixtures::RunCommand(fmt::format("{} {} {} {}{}", q, verb, fixtures::ShellQuote(input.string()),
                                                                fixtures::ShellQuote(out.string()), rest));
    ASSERT_EQ(run.exit_status, 0) << v.name << ": " << run.output;
    auto bytes = files::ReadFile(out, 64 << 20);
    ASSERT_TRUE(bytes.ok());
    GltfReadResult r = ReadGltfModel(*bytes, out, out.parent_path(), "model");
    ASSERT_TRUE(r.ok) << v.name << ": " << r.failure.code << ": " << r.failure.message;
    EXPECT_EQ(TriangleCount(r.model.asset), TriangleCount(reference.model.asset)) << v.name;
    // Every reference corner has a corner within the variant's step.
    const auto& got = r.model.asset.nodes[0].primitives[0].positions;
    for (size_t i = 0; i < prim.positions.size(); i += 3) {
      double best = 1e9;
      for (size_t j = 0; j < got.size(); j += 3) {
        double d = 0;
        for (size_t k = 0; k < 3; ++k) d = std::max(d, double(std::fabs(got[j + k] - prim.positions[i + k])));
        best = std::min(best, d);
      }
      EXPECT_LE(best, v.step) << v.name << " vertex " << i / 3;
    }
    if (v.name == "separate bin") {
      EXPECT_TRUE(fs::exists(out.parent_path() / "model.bin")) << "copy kept one file";
    }
  }
}

TEST(ConvertGltfOnSharedData, BlenderExportsConvertAndAgreeWithTheirObj) {
  SOLID_SHARED_TESTDATA_OR_SKIP(examples, "gltf-examples");
  TempDir dir;
  ConvertOptions options;
  options.jobs = 1;
  auto g = ConvertGltf(examples, dir.path() / "gltf", GltfLayout::kFlat, options);
  ASSERT_TRUE(g.ok()) << g.status().ToString();
  EXPECT_EQ(g->failed, 0);
  auto rows = Rows(dir.path() / "gltf");
  ASSERT_TRUE(rows.count("example") && rows.count("example-embedded"));
  auto o = ConvertObjFolder(examples, dir.path() / "obj", ObjLayout::kFlat, options);
  ASSERT_TRUE(o.ok()) << o.status().ToString();
  const gltf::Asset from_glb = ReadOutput(dir.path() / "gltf" / "models" / "example.glb");
  const gltf::Asset from_gltf = ReadOutput(dir.path() / "gltf" / "models" / "example-embedded.glb");
  const gltf::Asset from_obj = ReadOutput(dir.path() / "obj" / "models" / "example.glb");
  EXPECT_EQ(TriangleCount(from_glb), TriangleCount(from_obj));
  EXPECT_EQ(TriangleCount(from_gltf), TriangleCount(from_obj));
  // Same normalised bounds within a quantization step of the unit-diagonal box.
  const gltf::Bounds a = gltf::ComputeBounds(from_glb), c = gltf::ComputeBounds(from_obj);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.min[k], c.min[k], 2e-3) << k;
    EXPECT_NEAR(a.max[k], c.max[k], 2e-3) << k;
  }
}

}  // namespace
}  // namespace solid::convert
