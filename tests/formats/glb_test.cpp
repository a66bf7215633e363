#include "solid/formats/glb.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>

#include "fixtures/gltf_validator.h"
#include "fixtures/triangle_match.h"
#include "formats/test_util.h"
#include "solid/formats/image_codec.h"

namespace solid::gltf {
namespace {

using nlohmann::json;
using solid::testing::TempDir;

// ---------------------------------------------------------------------------
// Assets built in code

// An axis-aligned cube, 4 vertices per face so normals and uvs are per face,
// counter-clockwise seen from outside.
Primitive Cube(std::array<float, 3> center, float half, bool normals, bool uvs) {
  Primitive p;
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {-1.0f, 1.0f}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const auto base = static_cast<uint32_t>(p.positions.size() / 3);
      const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      for (const auto& c : corners) {
        std::array<float, 3> pos = center, n = {0, 0, 0};
        pos[axis] += sign * half;
        pos[u] += c[0] * half;
        pos[v] += c[1] * half;
        n[axis] = sign;
        p.positions.insert(p.positions.end(), pos.begin(), pos.end());
        if (normals) p.normals.insert(p.normals.end(), n.begin(), n.end());
        if (uvs) p.uvs.insert(p.uvs.end(), {(c[0] + 1) / 2, (c[1] + 1) / 2});
      }
      // (u, v, axis) is right-handed, so the corner order above faces +axis.
      if (sign > 0) {
        p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
      } else {
        p.indices.insert(p.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
      }
    }
  }
  return p;
}

// A torus with a UV seam (duplicated border vertices): 2 * nu * nv triangles.
Primitive Torus(int nu, int nv, float big_r, float small_r) {
  Primitive p;
  for (int i = 0; i <= nu; ++i) {
    for (int j = 0; j <= nv; ++j) {
      const double a = 2 * std::numbers::pi * i / nu, b = 2 * std::numbers::pi * j / nv;
      const double nx = std::cos(a) * std::cos(b), ny = std::sin(b), nz = std::sin(a) * std::cos(b);
      p.positions.insert(p.positions.end(),
                         {static_cast<float>(big_r * std::cos(a) + small_r * nx), static_cast<float>(small_r * ny),
                          static_cast<float>(big_r * std::sin(a) + small_r * nz)});
      p.normals.insert(p.normals.end(), {static_cast<float>(nx), static_cast<float>(ny), static_cast<float>(nz)});
      p.uvs.insert(p.uvs.end(), {static_cast<float>(i) / nu, static_cast<float>(j) / nv});
    }
  }
  auto at = [&](int i, int j) { return static_cast<uint32_t>(i * (nv + 1) + j); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      p.indices.insert(p.indices.end(),
                       {at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  return p;
}

std::vector<uint8_t> EncodeChecker(ImageFormat format) {
  Image8 image{16, 16, 3, {}};
  for (uint32_t y = 0; y < 16; ++y) {
    for (uint32_t x = 0; x < 16; ++x) {
      const uint8_t v = ((x / 4 + y / 4) % 2) ? 230 : 20;
      image.pixels.insert(image.pixels.end(), {v, static_cast<uint8_t>(255 - v), 128});
    }
  }
  auto bytes = EncodeImage(image, format);
  EXPECT_TRUE(bytes.ok()) << bytes.status().ToString();
  return bytes.ok() ? *bytes : std::vector<uint8_t>{};
}

Asset CubeAsset() {
  Asset a;
  a.nodes.push_back({"02691156/cube", {Cube({1, 2, 3}, 0.5f, true, true)}, json::object()});
  a.nodes[0].primitives[0].material = 0;
  a.materials.push_back({.name = "grey", .base_color = {0.5f, 0.5f, 0.5f, 1}});
  return a;
}

// Two materials on one node: a PNG-textured cube and a translucent, double-sided
// JPEG-textured torus; plus an unused texture, which glTF allows.
Asset TexturedAsset() {
  Asset a;
  Node node{"03001627/textured", {}, json::object()};
  node.primitives.push_back(Cube({0, 0, 0}, 1, true, true));
  node.primitives[0].material = 0;
  node.primitives.push_back(Torus(24, 12, 2, 0.5f));
  node.primitives[1].material = 1;
  a.nodes.push_back(std::move(node));
  a.materials.push_back(
      {.name = "wood Material.001", .base_color = {0.8f, 0.7f, 0.6f, 1}, .roughness = 0.75f, .base_color_texture = 0});
  a.materials.push_back({.name = "glass",
                         .base_color = {0.1f, 0.2f, 0.9f, 0.25f},
                         .blend = true,
                         .metallic = 0.3f,
                         .base_color_texture = 1,
                         .double_sided = true});
  a.textures.push_back({"images/wood.png", "image/png", EncodeChecker(ImageFormat::kPng)});
  a.textures.push_back({"glass.JPG", "image/jpeg", EncodeChecker(ImageFormat::kJpeg)});
  a.textures.push_back({"unused.png", "image/png", EncodeChecker(ImageFormat::kPng)});
  return a;
}

// SceneNet-like: several nodes with extras, a primitive without normals or uvs,
// primitives without material, a UTF-8 name.
Asset MultiNodeAsset() {
  Asset a;
  a.extras = {{"source", "scenenet"}, {"frame", "v2"}, {"centroid", {0.5, 1.25, -3}}};
  a.nodes.push_back({"chair", {Cube({0, 0, 0}, 0.4f, true, true)}, {{"category_id", 5}, {"structure", false}}});
  a.nodes[0].primitives[0].material = 0;
  a.nodes.push_back({"chair.001", {Cube({2, 0, 0}, 0.4f, false, false)}, {{"category_id", 5}}});
  a.nodes.push_back({"wall_стена", {Cube({0, 0, -5}, 3, true, false)}, {{"structure", "wall"}, {"ids", {1, 2, 3}}}});
  a.nodes[2].primitives.push_back(Cube({0, 4, -5}, 1, false, true));
  a.nodes[2].primitives[1].material = 0;
  a.materials.push_back({.name = "", .base_color = {1, 0, 0, 1}, .metallic = 0, .roughness = 0.5f});
  return a;
}

// ---------------------------------------------------------------------------
// Checks

std::vector<uint8_t> Write(const Asset& a, const DracoOptions& o = {}) {
  auto r = WriteGlb(a, o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? *r : std::vector<uint8_t>{};
}

Asset Read(const std::vector<uint8_t>& bytes) {
  auto r = ReadGlb(bytes, "test.glb");
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? *r : Asset{};
}

// Everything but geometry must survive exactly (geometry is checked by fidelity).
void ExpectSameNonGeometry(const Asset& in, const Asset& out) {
  EXPECT_EQ(in.extras, out.extras);
  ASSERT_EQ(in.nodes.size(), out.nodes.size());
  for (size_t i = 0; i < in.nodes.size(); ++i) {
    const Node &a = in.nodes[i], &b = out.nodes[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.extras, b.extras) << a.name;
    ASSERT_EQ(a.primitives.size(), b.primitives.size()) << a.name;
    for (size_t j = 0; j < a.primitives.size(); ++j) {
      const Primitive &p = a.primitives[j], &q = b.primitives[j];
      EXPECT_EQ(p.material, q.material) << a.name << " primitive " << j;
      EXPECT_EQ(p.normals.empty(), q.normals.empty()) << a.name << " primitive " << j;
      EXPECT_EQ(p.uvs.empty(), q.uvs.empty()) << a.name << " primitive " << j;
      EXPECT_EQ(p.indices.size(), q.indices.size()) << a.name << " primitive " << j;
    }
  }
  ASSERT_EQ(in.materials.size(), out.materials.size());
  for (size_t i = 0; i < in.materials.size(); ++i) {
    const Material &a = in.materials[i], &b = out.materials[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.base_color, b.base_color) << a.name;
    EXPECT_EQ(a.blend, b.blend) << a.name;
    EXPECT_EQ(a.metallic, b.metallic) << a.name;
    EXPECT_EQ(a.roughness, b.roughness) << a.name;
    EXPECT_EQ(a.base_color_texture, b.base_color_texture) << a.name;
    EXPECT_EQ(a.double_sided, b.double_sided) << a.name;
  }
  ASSERT_EQ(in.textures.size(), out.textures.size());
  for (size_t i = 0; i < in.textures.size(); ++i) {
    EXPECT_EQ(in.textures[i].name, out.textures[i].name);
    EXPECT_EQ(in.textures[i].mime_type, out.textures[i].mime_type);
    EXPECT_EQ(in.textures[i].bytes, out.textures[i].bytes) << in.textures[i].name;
  }
}

void ExpectFaithful(const Asset& in, const Asset& out, const DracoOptions& o = {}) {
  ASSERT_EQ(in.nodes.size(), out.nodes.size());
  for (size_t i = 0; i < in.nodes.size(); ++i) {
    ASSERT_EQ(in.nodes[i].primitives.size(), out.nodes[i].primitives.size());
    for (size_t j = 0; j < in.nodes[i].primitives.size(); ++j) {
      const fixtures::Fidelity f = fixtures::MatchTriangles(in.nodes[i].primitives[j], out.nodes[i].primitives[j], o);
      EXPECT_EQ(f.unmatched, 0u) << in.nodes[i].name << " primitive " << j;
    }
  }
}

// ---------------------------------------------------------------------------
// GLB surgery for malformed inputs

struct Glb {
  json gltf;
  std::vector<uint8_t> bin;
};

uint32_t U32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

void PutU32(std::vector<uint8_t>& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

// Our own output only: no checks.
Glb Unpack(const std::vector<uint8_t>& glb) {
  const uint32_t json_length = U32(glb, 12);
  Glb out;
  out.gltf = json::parse(glb.begin() + 20, glb.begin() + 20 + json_length);
  if (glb.size() > 20 + json_length) {
    const uint32_t bin_length = U32(glb, 20 + json_length);
    out.bin.assign(glb.begin() + 28 + json_length, glb.begin() + 28 + json_length + bin_length);
  }
  return out;
}

std::vector<uint8_t> Pack(std::string text, std::vector<uint8_t> bin) {
  text.resize((text.size() + 3) & ~size_t{3}, ' ');
  bin.resize((bin.size() + 3) & ~size_t{3}, 0);
  std::vector<uint8_t> out(12, 0);
  PutU32(out, 0, 0x46546C67);
  PutU32(out, 4, 2);
  auto chunk = [&](uint32_t type, const uint8_t* data, size_t size) {
    const size_t at = out.size();
    out.resize(at + 8);
    PutU32(out, at, static_cast<uint32_t>(size));
    PutU32(out, at + 4, type);
    out.insert(out.end(), data, data + size);
  };
  chunk(0x4E4F534A, reinterpret_cast<const uint8_t*>(text.data()), text.size());
  if (!bin.empty()) chunk(0x004E4942, bin.data(), bin.size());
  PutU32(out, 8, static_cast<uint32_t>(out.size()));
  return out;
}

std::vector<uint8_t> Pack(const Glb& g) { return Pack(g.gltf.dump(), g.bin); }

// Reading must fail with `code` and a message containing each of `parts`.
void ExpectError(const std::vector<uint8_t>& bytes, StatusCode code, std::initializer_list<std::string> parts) {
  auto r = ReadGlb(bytes, "bad.glb");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), code) << r.status().ToString();
  EXPECT_TRUE(r.status().message().starts_with("bad.glb: ")) << r.status().ToString();
  for (const std::string& part : parts) {
    EXPECT_NE(r.status().message().find(part), std::string::npos) << r.status().ToString() << "\nmissing: " << part;
  }
}

// ---------------------------------------------------------------------------
// Round trips

TEST(GltfWriter, CubeRoundTrip) {
  const Asset in = CubeAsset();
  const Asset out = Read(Write(in));
  ExpectSameNonGeometry(in, out);
  ExpectFaithful(in, out);
}

TEST(GltfWriter, TexturedTwoMaterialRoundTrip) {
  const Asset in = TexturedAsset();
  const auto glb = Write(in);
  const Asset out = Read(glb);
  ExpectSameNonGeometry(in, out);
  ExpectFaithful(in, out);

  const json gltf = Unpack(glb).gltf;
  ASSERT_EQ(gltf["samplers"].size(), 1u);
  EXPECT_EQ(gltf["samplers"][0], json({{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}));
  ASSERT_EQ(gltf["images"].size(), 3u);
  for (const json& image : gltf["images"]) {
    EXPECT_TRUE(image.contains("bufferView"));
    EXPECT_FALSE(image.contains("uri"));
  }
  EXPECT_EQ(gltf["materials"][1]["alphaMode"], "BLEND");
  EXPECT_EQ(gltf["materials"][1]["doubleSided"], true);
  EXPECT_FALSE(gltf["materials"][0].contains("alphaMode"));
}

TEST(GltfWriter, MultiNodeRoundTrip) {
  const Asset in = MultiNodeAsset();
  const auto glb = Write(in);
  const Asset out = Read(glb);
  ExpectSameNonGeometry(in, out);
  ExpectFaithful(in, out);

  const json gltf = Unpack(glb).gltf;
  EXPECT_TRUE(gltf["asset"]["generator"].get<std::string>().starts_with("solid "));
  EXPECT_EQ(gltf["scenes"], json::array({{{"nodes", {0, 1, 2}}}}));
  EXPECT_EQ(gltf["scene"], 0);
  EXPECT_EQ(gltf["extensionsUsed"], json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(gltf["extensionsRequired"], json::array({"KHR_draco_mesh_compression"}));
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(gltf["meshes"][i]["name"], gltf["nodes"][i]["name"]);
  // Draco-only file: no accessor has a bufferView, and the only views are Draco streams.
  for (const json& a : gltf["accessors"]) EXPECT_FALSE(a.contains("bufferView"));
  EXPECT_EQ(gltf["bufferViews"].size(), 4u);
  // The material-less primitives have no "material"; the second node has no NORMAL/TEXCOORD_0.
  EXPECT_FALSE(gltf["meshes"][1]["primitives"][0].contains("material"));
  EXPECT_EQ(gltf["meshes"][1]["primitives"][0]["attributes"].size(), 1u);
}

// A ShapeNet-sized mesh (10k triangles with seams): the fidelity bound, sizes and
// the accessors' consistency with the decoded data.
TEST(GltfWriter, TorusFidelityAndAccessors) {
  Asset in;
  in.nodes.push_back({"torus", {Torus(100, 50, 1.0f, 0.3f)}, json::object()});
  const DracoOptions options;
  const auto glb = Write(in, options);
  const Asset out = Read(glb);
  ExpectSameNonGeometry(in, out);
  const fixtures::Fidelity f = fixtures::MatchTriangles(in.nodes[0].primitives[0], out.nodes[0].primitives[0], options);
  EXPECT_EQ(f.unmatched, 0u);
  const Glb parts = Unpack(glb);
  const size_t triangles = in.nodes[0].primitives[0].indices.size() / 3;
  std::cout << "torus: " << triangles << " triangles, GLB " << glb.size() << " bytes, Draco " << parts.bin.size()
            << " bytes (" << static_cast<double>(parts.bin.size()) / triangles
            << " bytes/triangle), max position error " << f.max_error << " = " << f.max_error / f.diagonal
            << " of the bbox diagonal\n";

  const json& prim = parts.gltf["meshes"][0]["primitives"][0];
  const json& position = parts.gltf["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
  const Primitive& d = out.nodes[0].primitives[0];
  const size_t n = d.positions.size() / 3;
  EXPECT_EQ(position["count"], n);
  EXPECT_EQ(parts.gltf["accessors"][prim["indices"].get<size_t>()]["count"], d.indices.size());
  EXPECT_EQ(parts.gltf["accessors"][prim["indices"].get<size_t>()]["componentType"], 5123);
  for (int k = 0; k < 3; ++k) {
    float lo = d.positions[k], hi = d.positions[k];
    for (size_t i = 0; i < n; ++i) {
      lo = std::min(lo, d.positions[3 * i + k]);
      hi = std::max(hi, d.positions[3 * i + k]);
    }
    EXPECT_EQ(position["min"][k].get<float>(), lo);
    EXPECT_EQ(position["max"][k].get<float>(), hi);
  }
}

TEST(GltfWriter, IsDeterministic) {
  const Asset a = TexturedAsset();
  const Asset b = a;
  EXPECT_EQ(Write(a), Write(b));
  EXPECT_EQ(Write(MultiNodeAsset()), Write(MultiNodeAsset()));
}

TEST(GltfWriter, QuantizationBitsTradeSizeForError) {
  Asset in;
  in.nodes.push_back({"torus", {Torus(60, 30, 1.0f, 0.3f)}, json::object()});
  size_t previous_size = 0;
  double previous_error = 1e9;
  for (int bits : {8, 11, 14, 18}) {
    DracoOptions o;
    o.position_bits = bits;
    const auto glb = Write(in, o);
    const fixtures::Fidelity f = fixtures::MatchTriangles(in.nodes[0].primitives[0], Read(glb).nodes[0].primitives[0], o);
    EXPECT_EQ(f.unmatched, 0u) << bits << " bits";
    EXPECT_GT(glb.size(), previous_size) << bits << " bits";
    EXPECT_LT(f.max_error, previous_error) << bits << " bits";
    std::cout << "position_bits " << bits << ": " << glb.size() << " bytes, max error / diagonal "
              << f.max_error / f.diagonal << "\n";
    previous_size = glb.size();
    previous_error = f.max_error;
  }
  DracoOptions fewer_normal_bits;
  fewer_normal_bits.normal_bits = 6;
  fewer_normal_bits.texcoord_bits = 8;
  EXPECT_LT(Write(in, fewer_normal_bits).size(), Write(in).size());
}

TEST(GltfWriter, ReadsPlainAccessors) {
  // A non-Draco glb: interleaved POSITION/NORMAL, unsigned short indices.
  const std::vector<float> interleaved = {0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1};
  const std::vector<uint16_t> indices = {0, 1, 2, 2, 1, 3};
  std::vector<uint8_t> bin(interleaved.size() * 4 + indices.size() * 2);
  std::memcpy(bin.data(), interleaved.data(), interleaved.size() * 4);
  std::memcpy(bin.data() + interleaved.size() * 4, indices.data(), indices.size() * 2);
  const json gltf = {
      {"asset", {{"version", "2.0"}}},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteLength", 96}, {"byteStride", 24}},
        {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 12}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 0}, {"byteOffset", 12}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
      {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}}}}}}},
      {"nodes", {{{"name", "quad"}, {"mesh", 0}}, {{"name", "empty"}}}}};
  const Asset a = Read(Pack(gltf.dump(), bin));
  ASSERT_EQ(a.nodes.size(), 1u);
  EXPECT_EQ(a.nodes[0].name, "quad");
  const Primitive& p = a.nodes[0].primitives[0];
  EXPECT_EQ(p.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}));
  EXPECT_EQ(p.normals, (std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  EXPECT_FALSE(p.material.has_value());
}

// ---------------------------------------------------------------------------
// Invalid assets and options

TEST(GltfWriter, RejectsInconsistentAssets) {
  auto expect = [](const Asset& a, StatusCode code, const std::string& part) {
    auto r = WriteGlb(a);
    ASSERT_FALSE(r.ok()) << part;
    EXPECT_EQ(r.status().code(), code) << r.status().ToString();
    EXPECT_NE(r.status().message().find(part), std::string::npos) << r.status().ToString();
  };
  Asset a = CubeAsset();
  a.nodes[0].primitives[0].indices[5] = 24;
  expect(a, StatusCode::kInvalidArgument, "nodes[0] \"02691156/cube\": primitives[0]: index 5 is 24");
  a = CubeAsset();
  a.nodes[0].primitives[0].material = 3;
  expect(a, StatusCode::kInvalidArgument, "material 3 out of range");
  a = CubeAsset();
  a.nodes[0].primitives[0].normals.pop_back();
  expect(a, StatusCode::kInvalidArgument, "normal floats");
  a = CubeAsset();
  a.nodes[0].primitives[0].positions[4] = std::nanf("");
  expect(a, StatusCode::kInvalidArgument, "non-finite");
  a = CubeAsset();
  a.nodes[0].primitives.clear();
  expect(a, StatusCode::kInvalidArgument, "no primitives");
  a = CubeAsset();
  a.materials[0].base_color_texture = 0;
  expect(a, StatusCode::kInvalidArgument, "materials[0]: base_color_texture 0 out of range");
  a = CubeAsset();
  a.materials[0].base_color[0] = 1.5f;
  expect(a, StatusCode::kInvalidArgument, "outside [0, 1]");
  a = CubeAsset();
  a.nodes[0].name = "bad\xff";
  expect(a, StatusCode::kInvalidArgument, "nodes[0]: name: not valid UTF-8");
  a = CubeAsset();
  a.nodes[0].extras = {{"note", "bad\xff"}};
  expect(a, StatusCode::kInvalidArgument, "nodes[0] \"02691156/cube\": extras: not valid UTF-8");
  a = CubeAsset();
  a.materials[0].name = "\xc3";
  expect(a, StatusCode::kInvalidArgument, "materials[0]: name: not valid UTF-8");
  a = CubeAsset();
  a.textures.push_back({"fake.png", "image/png", {0xFF, 0xD8, 0xFF, 0}});
  expect(a, StatusCode::kInvalidArgument, "textures[0]: bytes are not image/png");
  a.textures[0] = {"x.gif", "image/gif", {'G', 'I', 'F'}};
  expect(a, StatusCode::kInvalidArgument, "image/gif");

  DracoOptions o;
  o.position_bits = 31;
  auto r = WriteGlb(CubeAsset(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  o = {};
  o.compression_level = 11;
  EXPECT_FALSE(WriteGlb(CubeAsset(), o).ok());
}

// ---------------------------------------------------------------------------
// Malformed input

TEST(GltfReader, RejectsBrokenContainers) {
  const auto good = Write(TexturedAsset());
  ExpectError({}, StatusCode::kParseError, {"shorter than a GLB header"});
  auto bad = good;
  bad[0] = 'X';
  ExpectError(bad, StatusCode::kParseError, {"bad magic"});
  bad = good;
  PutU32(bad, 4, 1);
  ExpectError(bad, StatusCode::kUnsupportedVersion, {"version 1"});
  bad = good;
  bad.push_back(0);
  ExpectError(bad, StatusCode::kParseError, {"header length"});
  bad = good;
  PutU32(bad, 12, 0xFFFFFFF0u);
  ExpectError(bad, StatusCode::kParseError, {"claims 4294967280 bytes"});
  bad = good;
  PutU32(bad, 20 + U32(good, 12), 0xFFFFFFFFu);
  ExpectError(bad, StatusCode::kParseError, {"claims 4294967295 bytes"});

  // Every truncation, with the header's length made to agree so the chunk checks are reached.
  for (size_t size = 0; size < good.size(); ++size) {
    std::vector<uint8_t> cut(good.begin(), good.begin() + static_cast<ptrdiff_t>(size));
    if (size >= 12) PutU32(cut, 8, static_cast<uint32_t>(size));
    EXPECT_FALSE(ReadGlb(cut, "cut.glb").ok()) << size;
  }
}

TEST(GltfReader, RejectsBadJson) {
  ExpectError(Pack("{not json", {}), StatusCode::kParseError, {"JSON chunk"});
  ExpectError(Pack("[1, 2]", {}), StatusCode::kParseError, {"not an object"});
  ExpectError(Pack(std::string(100000, '[') + std::string(100000, ']'), {}), StatusCode::kLimitExceeded,
              {"nested deeper"});
  ExpectError(Pack(R"({"asset": {"version": "1.0"}})", {}), StatusCode::kUnsupportedVersion, {"1.0"});
  ExpectError(Pack(R"({"asset": {"version": "2.0"}, "nodes": {}})", {}), StatusCode::kParseError,
              {"\"nodes\" is not an array"});
  ExpectError(Pack(R"({"asset": {"version": "2.0"}, "nodes": [{"mesh": 0, "name": 5}], "meshes": [{}]})", {}),
              StatusCode::kParseError, {"nodes[0]: \"name\" is not a string"});
  ExpectError(Pack(R"({"asset": {"version": "2.0"}, "extensionsRequired": ["EXT_meshopt_compression"]})", {}),
              StatusCode::kUnsupportedVersion, {"EXT_meshopt_compression"});
}

TEST(GltfReader, RejectsBadIndicesAndLengths) {
  const Glb good = Unpack(Write(TexturedAsset()));
  const std::string draco_view = "/meshes/0/primitives/1/extensions/KHR_draco_mesh_compression/bufferView";
  auto edit = [&](const std::function<void(json&)>& f) {
    Glb g = good;
    f(g.gltf);
    return Pack(g);
  };
  auto view_of = [&](const json& g) { return g.at(json::json_pointer(draco_view)).get<size_t>(); };

  ExpectError(edit([&](json& g) { g["bufferViews"][view_of(g)]["byteLength"] = 1u << 30; }), StatusCode::kCorrupt,
              {"meshes[0].primitives[1]: bufferViews[1]: bytes [", "overrun buffers[0]"});
  ExpectError(edit([&](json& g) { g["bufferViews"][view_of(g)]["byteOffset"] = UINT64_MAX; }), StatusCode::kCorrupt,
              {"meshes[0].primitives[1]", "overrun"});
  ExpectError(edit([&](json& g) { g[json::json_pointer(draco_view)] = 99; }), StatusCode::kCorrupt,
              {"meshes[0].primitives[1]: \"bufferView\" 99 out of range"});
  ExpectError(edit([&](json& g) { g["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 999; }),
              StatusCode::kCorrupt, {"meshes[0].primitives[0]: \"POSITION\" 999 out of range"});
  ExpectError(edit([&](json& g) { g["meshes"][0]["primitives"][0]["material"] = 7; }), StatusCode::kCorrupt,
              {"\"material\" 7 out of range (2 materials)"});
  ExpectError(edit([&](json& g) { g["materials"][1]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 3; }),
              StatusCode::kCorrupt, {"materials[1]: \"index\" 3 out of range"});
  ExpectError(edit([&](json& g) { g["textures"][0]["source"] = -1; }), StatusCode::kParseError,
              {"textures[0]: \"source\" is not a non-negative integer"});
  ExpectError(edit([&](json& g) { g["buffers"][0]["byteLength"] = 1u << 31; }), StatusCode::kCorrupt,
              {"exceeds the BIN chunk"});
  ExpectError(edit([&](json& g) { g["nodes"][0]["mesh"] = 1; }), StatusCode::kCorrupt,
              {"nodes[0]: \"mesh\" 1 out of range (1 meshes)"});
  ExpectError(edit([&](json& g) {
                const size_t a = g["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
                g["accessors"][a]["count"] = g["accessors"][a]["count"].get<size_t>() + 1;
              }),
              StatusCode::kCorrupt, {"meshes[0].primitives[0]", "POSITION accessor count", "Draco decoded"});
  ExpectError(edit([&](json& g) { g["meshes"][0]["primitives"][0]["mode"] = 1; }), StatusCode::kUnsupportedVersion,
              {"mode 1"});

  // A Draco stream of zeros.
  Glb zeros = good;
  const json& view = zeros.gltf["bufferViews"][view_of(zeros.gltf)];
  std::fill_n(zeros.bin.begin() + view["byteOffset"].get<ptrdiff_t>(), view["byteLength"].get<size_t>(), 0);
  ExpectError(Pack(zeros), StatusCode::kCorrupt, {"meshes[0].primitives[1]: KHR_draco_mesh_compression", "Draco"});
}

// The accessors of a Draco primitive declare the decoded data: float VEC3 positions and
// normals, float VEC2 texture coordinates, unsigned integer indices that hold every index.
// A reader that trusted other declarations would size its buffers wrongly.
TEST(GltfReader, DracoAccessorsDeclareWhatTheDecoderYields) {
  const std::vector<uint8_t> glb = Write(TexturedAsset());
  const Glb good = Unpack(glb);
  // Primitive 1 is the torus, whose every decoded point is some face's corner.
  const size_t torus_points = Read(glb).nodes[0].primitives[1].positions.size() / 3;
  ASSERT_GT(torus_points, 255u) << "more than unsigned bytes can index";
  auto edit = [&](size_t primitive, const std::string& semantic, const std::string& key, const json& value) {
    Glb g = good;
    const json& p = g.gltf["meshes"][0]["primitives"][primitive];
    const size_t a = semantic == "indices" ? p["indices"].get<size_t>() : p["attributes"][semantic].get<size_t>();
    g.gltf["accessors"][a][key] = value;
    return std::pair(Pack(g), fmt::format("accessors[{}]: ", a));
  };
  auto expect_corrupt = [&](size_t primitive, const std::string& semantic, const std::string& key, const json& value,
                            const std::string& says) {
    const auto [bytes, accessor] = edit(primitive, semantic, key, value);
    ExpectError(bytes, StatusCode::kCorrupt,
                {fmt::format("meshes[0].primitives[{}]: {}{}", primitive, accessor, semantic), says});
  };
  expect_corrupt(1, "POSITION", "type", "VEC2", "type VEC2, but Draco decodes VEC3");
  expect_corrupt(1, "NORMAL", "componentType", 5123, "componentType 5123, but Draco decodes floats (5126)");
  expect_corrupt(1, "TEXCOORD_0", "type", "VEC3", "type VEC3, but Draco decodes VEC2");
  // Plain accessors may hold TEXCOORD_0 as normalized bytes; Draco's are floats.
  expect_corrupt(1, "TEXCOORD_0", "componentType", 5121, "componentType 5121, but Draco decodes floats");
  expect_corrupt(1, "indices", "componentType", 5126, "componentType 5126, but Draco decodes unsigned integers");
  expect_corrupt(1, "indices", "type", "VEC3", "type VEC3, but Draco decodes SCALAR");
  expect_corrupt(
      1, "indices", "componentType", 5121,
      fmt::format("componentType 5121 holds indices below 255, but Draco decoded index {}", torus_points - 1));

  // Unsigned bytes index the 24 vertices of the cube, and unsigned ints any mesh.
  EXPECT_TRUE(ReadGlb(edit(0, "indices", "componentType", 5121).first, "cube.glb").ok());
  EXPECT_TRUE(ReadGlb(edit(1, "indices", "componentType", 5125).first, "torus.glb").ok());
}

TEST(GltfReader, AccessorCountsOverTheLimitsAreRefusedBeforeDecoding) {
  const Glb good = Unpack(Write(CubeAsset()));
  const json& primitive = good.gltf["meshes"][0]["primitives"][0];
  Glb many_vertices = good;
  many_vertices.gltf["accessors"][primitive["attributes"]["POSITION"].get<size_t>()]["count"] = kMaxGlbVertices + 1;
  ExpectError(Pack(many_vertices), StatusCode::kLimitExceeded,
              {"meshes[0].primitives[0]", "limits of 50000000 vertices and 50000000 triangles per file"});
  Glb many_triangles = good;
  many_triangles.gltf["accessors"][primitive["indices"].get<size_t>()]["count"] = 3 * (kMaxGlbTriangles + 1);
  ExpectError(Pack(many_triangles), StatusCode::kLimitExceeded, {"meshes[0].primitives[0]", "50000001 more triangles"});
}

// Seeded byte flips, anywhere and within the Draco streams: any outcome but a crash
// (ASan builds check for out-of-bounds reads too).
TEST(GltfReader, SurvivesRandomByteFlips) {
  const auto good = Write(TexturedAsset());
  const size_t bin_start = 28 + U32(good, 12);
  std::mt19937 rng(20240917);
  int ok = 0, failed = 0;
  for (int trial = 0; trial < 600; ++trial) {
    auto bad = good;
    const size_t lo = trial < 300 ? 0 : bin_start;
    std::uniform_int_distribution<size_t> where(lo, bad.size() - 1);
    const int flips = 1 + trial % 8;
    for (int i = 0; i < flips; ++i) bad[where(rng)] ^= static_cast<uint8_t>(1u << (rng() % 8));
    auto r = ReadGlb(bad, "flipped.glb");
    (r.ok() ? ok : failed)++;
  }
  std::cout << "byte flips: " << ok << " read, " << failed << " rejected\n";
  EXPECT_GT(failed, 0);
}

// ---------------------------------------------------------------------------
// Khronos glTF-Validator

void WriteFile(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<uint8_t> Decompress(const std::vector<uint8_t>& glb) {
  auto plain = fixtures::DecompressDraco(glb, "test.glb");
  EXPECT_TRUE(plain.ok()) << plain.status().ToString();
  return plain.ok() ? std::move(plain).value() : std::vector<uint8_t>{};
}

TEST(GltfWriter, KhronosValidatorReportsNoErrors) {
  if (auto why = fixtures::GltfValidatorUnavailable()) GTEST_SKIP() << *why;
  TempDir dir;
  Asset torus;
  torus.nodes.push_back({"torus", {Torus(100, 50, 1.0f, 0.3f)}, json::object()});
  const std::vector<std::pair<std::string, Asset>> assets = {{"cube.glb", CubeAsset()},
                                                             {"textured.glb", TexturedAsset()},
                                                             {"multi.glb", MultiNodeAsset()},
                                                             {"torus.glb", torus}};
  std::vector<std::filesystem::path> files;
  for (const auto& [name, asset] : assets) {
    const auto glb = Write(asset);
    WriteFile(dir.path() / name, glb);
    WriteFile(dir.path() / ("decompressed-" + name), Decompress(glb));
    files.insert(files.end(), {dir.path() / name, dir.path() / ("decompressed-" + name)});
  }
  const fixtures::GltfValidatorRun run = fixtures::RunGltfValidator(files);
  std::cout << run.report;
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.files_reported, files.size()) << run.report;

  // Negative control: the validator does check decoded data against our accessors.
  Glb wrong = Unpack(Decompress(Write(CubeAsset())));
  wrong.gltf["accessors"][0]["min"][0] = -100.0;
  WriteFile(dir.path() / "wrong-min.glb", Pack(wrong));
  const fixtures::GltfValidatorRun wrong_run = fixtures::RunGltfValidator({dir.path() / "wrong-min.glb"});
  EXPECT_EQ(wrong_run.exit_status, 1) << wrong_run.report;
  EXPECT_NE(wrong_run.report.find("ACCESSOR_MIN_MISMATCH"), std::string::npos) << wrong_run.report;
}

}  // namespace
}  // namespace solid::gltf
